// Curves and curve sets (issue 6 "Curve sets"): family-independent value types, the motion they
// describe (sampled positions with derived velocity and acceleration) and pure validation against
// an axis and the LinMot curve limits (linmot-mc.md §7, L989-L1011; docs/decisions/012-curves.md).
// No I/O: storage, download and running live elsewhere.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive_config.h"

namespace drivegw {

// Equidistant position set points: point i is reached at t = i * time_step_s.
struct PositionTimeCurve {
  double time_step_s = 0;
  std::vector<double> positions_mm;
  friend bool operator==(const PositionTimeCurve&, const PositionTimeCurve&) = default;
};

// What a LinMot curve info block carries as far as the reference documents it (linmot-mc.md §7
// L1000-L1002, model D-29 L1009), plus the default start parameters written to UPIDs 14C9h-14CBh
// (L1003-L1004, L1011). The info block itself is 70 bytes on the wire (linmot-linudp.md L310).
struct LinMotParametricCurve {
  // Only position curves exist in the reference: SInt32 set points in 0.1 µm (§7 L1001).
  enum class YUnit { kPosition0p1um };

  static constexpr int kMinCurveId = 1;    // §7 L997 "Curve ID UInt16, 1 … 100"
  static constexpr int kMaxCurveId = 100;  // §7 L997
  static constexpr int kMinPoints = 2;     // D-29 "N ≥ 2 equally spaced SInt32 points" (L1009)
  // The Curve Service announces the data block size in one 16-bit word (linmot-linudp.md L310:
  // 0x50 "data block size (bytes)", 4 bytes per set point): at most 65535 / 4 points.
  static constexpr int kMaxPoints = 65535 / 4;
  // x-Length / Curve Time: UInt32 in 10 µs (§7 L1000, L1002; §5.5 043h, L527).
  static constexpr double kTimeUnitS = 10e-6;
  static constexpr double kMaxXLengthS = 4294967295.0 * kTimeUnitS;
  // Amplitude Scale SInt16 [0.1 %] −2000 … 2000 % (§7 L1002; §5.5 044h L528).
  static constexpr double kMinAmplitudeScalePct = -2000;
  static constexpr double kMaxAmplitudeScalePct = 2000;
  static constexpr double kAmplitudeScaleUnitPct = 0.1;
  // Time Scale UInt16 [0.01 %] 0 … 200 % (§7 L1002; §5.5 044h L528). 0 % would stretch the curve
  // to infinite time, so validation asks for > 0 (decision 012).
  static constexpr double kMaxTimeScalePct = 200;
  static constexpr double kTimeScaleUnitPct = 0.01;
  static constexpr double kPointUnitMm = 1e-4;  // 0.1 µm (§7 L1001)

  int curve_id = 1;
  double x_length_s = 0;  // nominal duration of the whole curve (x-Length, info block offset 32)
  YUnit y_unit = YUnit::kPosition0p1um;
  std::vector<int32_t> points;  // wire units (0.1 µm); point count = points.size()
  // Defaults used by 040h (UPIDs 14C9h, 14CAh, 14CBh; §5.5 L524, §7 L1003).
  double offset_mm = 0;
  double amplitude_scale_pct = 100;
  double time_scale_pct = 100;
  friend bool operator==(const LinMotParametricCurve&, const LinMotParametricCurve&) = default;
};

struct Curve {
  std::string name;
  std::string description;
  std::variant<PositionTimeCurve, LinMotParametricCurve> shape;
  friend bool operator==(const Curve&, const Curve&) = default;
};

// Curves for one machine/product.
struct CurveSet {
  std::string name;
  std::string description;
  std::vector<Curve> curves;
  friend bool operator==(const CurveSet&, const CurveSet&) = default;
};

// The motion a curve commands, one entry per set point. Velocity and acceleration are finite
// differences on the equidistant samples (decision 012): central differences inside
// (v = (p[i+1] - p[i-1]) / 2h, a = (p[i+1] - 2 p[i] + p[i-1]) / h²); at the ends the one-sided
// segment slope for v and the neighbour's a (a = 0 for a two-point curve).
struct CurveSamples {
  double time_step_s = 0;
  std::vector<double> t_s;
  std::vector<double> position_mm;
  std::vector<double> velocity_mm_s;
  std::vector<double> acceleration_mm_s2;
};

// Samples of the curve as run with its default parameters. A LinMot curve follows D-29
// (linmot-mc.md L1009): position = offset + amplitude/100 % × (y_i − y_0), step =
// x_length × 100 % / time_scale / (N − 1). Needs ≥ 2 points and a positive, finite step.
absl::StatusOr<CurveSamples> SampleCurve(const Curve& curve);

struct CurveSummary {
  double duration_s = 0;
  double start_mm = 0;
  double end_mm = 0;
  double min_mm = 0;
  double max_mm = 0;
  double peak_velocity_mm_s = 0;       // max |v|
  double peak_acceleration_mm_s2 = 0;  // max |a|
};
absl::StatusOr<CurveSummary> SummarizeCurve(const Curve& curve);

// Every problem of `curve` that does not depend on an axis: name, time step, point count and the
// LinMot wire ranges. Messages name the field, the value and the limit.
std::vector<std::string> CurveShapeErrors(const Curve& curve);
// CurveShapeErrors plus, when the shape is sound, the axis limits at every point: stroke,
// |v| ≤ max_velocity_mm_s, |a| ≤ max_acceleration_mm_s2 ("points[17]: velocity 812.4 mm/s exceeds
// axis.max_velocity_mm_s 500").
std::vector<std::string> CurveErrors(const Curve& curve, const AxisConfig& axis);

// InvalidArgument with the first error (and how many more there are), OK when there is none.
absl::Status ValidateCurveShape(const Curve& curve);
absl::Status ValidateCurve(const Curve& curve, const AxisConfig& axis);
// Set name, unique curve names, unique LinMot curve IDs, every curve's shape (prefix "curves[i]").
absl::Status ValidateCurveSetShape(const CurveSet& set);
absl::Status ValidateCurveSet(const CurveSet& set, const AxisConfig& axis);

}  // namespace drivegw
