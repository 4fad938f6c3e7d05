// What every curve runner needs once (issue 6 RunCurve; docs/decisions/013-curve-run.md): the set
// points of a curve at a bus cycle, a coarse piecewise-linear form for controllers that take moves
// rather than set points, and the LinMot wire form of any curve. Pure functions, no I/O.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/curve.h"

namespace drivegw {

// Position set points every `period_s` from t = 0 to the curve's end (inclusive; the last set
// point is the curve's end point exactly), linearly interpolated between the samples (D-29's
// interpolation, linmot-mc.md L1009). InvalidArgument for a period <= 0 or not finite.
absl::StatusOr<std::vector<double>> ResampleCurve(const CurveSamples& samples, double period_s);

// One leg of a curve run as moves: reach `position_mm` at `end_time_s` travelling at
// `velocity_mm_s` (|distance| / leg duration, > 0 unless the leg stands still).
struct CurveSegment {
  double end_time_s = 0;
  double position_mm = 0;
  double velocity_mm_s = 0;
};
// At most `max_segments` legs with equal durations (fewer when the curve has fewer points), each
// ending on a curve sample; the last leg ends on the curve's end point.
std::vector<CurveSegment> SegmentCurve(const CurveSamples& samples, int max_segments);

// The LinMot wire form of `curve`: a LinMotParametricCurve as it is; a PositionTimeCurve becomes
// `curve_id` with points in 0.1 µm (rounded), x-Length = (N - 1) · time step, offset = the first
// point, amplitude and time scale 100 % — so that D-29 replays the same positions. Errors name
// the field (a point outside SInt32 × 0.1 µm, a duration that is not a whole 10 µs count).
absl::StatusOr<LinMotParametricCurve> ToLinMotCurve(const Curve& curve, int curve_id);

}  // namespace drivegw
