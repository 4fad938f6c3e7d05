// Curve resampling, segmentation and the LinMot wire form (decision 013).
#include "adapters/core/curve_run.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace drivegw {
namespace {

// Linear interpolation of the equidistant samples at time t (clamped to the curve).
double PositionAt(const CurveSamples& s, double t) {
  const size_t n = s.position_mm.size();
  if (n == 0) return 0;
  if (n == 1 || t <= 0) return s.position_mm.front();
  const double x = t / s.time_step_s;
  const auto i = static_cast<size_t>(std::floor(x));
  if (i + 1 >= n) return s.position_mm.back();
  const double frac = x - static_cast<double>(i);
  return s.position_mm[i] + frac * (s.position_mm[i + 1] - s.position_mm[i]);
}

}  // namespace

absl::StatusOr<std::vector<double>> ResampleCurve(const CurveSamples& samples, double period_s) {
  if (!(period_s > 0) || !std::isfinite(period_s)) {
    return absl::InvalidArgumentError(absl::StrCat("cycle period ", period_s, " s must be > 0"));
  }
  if (samples.position_mm.empty()) return absl::InvalidArgumentError("curve has no points");
  const double duration = samples.time_step_s * static_cast<double>(samples.position_mm.size() - 1);
  // The last cycle carries the end point exactly, even when the duration is not a multiple.
  const auto cycles = static_cast<size_t>(std::ceil(duration / period_s - 1e-9));
  std::vector<double> out;
  out.reserve(cycles + 1);
  for (size_t k = 0; k < cycles; ++k) out.push_back(PositionAt(samples, period_s * k));
  out.push_back(samples.position_mm.back());
  return out;
}

std::vector<CurveSegment> SegmentCurve(const CurveSamples& samples, int max_segments) {
  std::vector<CurveSegment> legs;
  const size_t n = samples.position_mm.size();
  if (n < 2 || max_segments < 1) return legs;
  const size_t intervals = n - 1;
  const size_t count = std::min(intervals, static_cast<size_t>(max_segments));
  double prev_t = 0;
  double prev_p = samples.position_mm.front();
  for (size_t k = 1; k <= count; ++k) {
    // Sample index closest to an equal share of the intervals; the last leg ends on the end point.
    const size_t idx = k == count ? intervals : (k * intervals + count / 2) / count;
    const double t = samples.time_step_s * static_cast<double>(idx);
    const double p = samples.position_mm[idx];
    const double dt = t - prev_t;
    legs.push_back({t, p, dt > 0 ? std::abs(p - prev_p) / dt : 0});
    prev_t = t;
    prev_p = p;
  }
  return legs;
}

absl::StatusOr<LinMotParametricCurve> ToLinMotCurve(const Curve& curve, int curve_id) {
  if (const auto* lin = std::get_if<LinMotParametricCurve>(&curve.shape)) return *lin;
  const auto& pt = std::get<PositionTimeCurve>(curve.shape);
  using L = LinMotParametricCurve;
  if (curve_id < L::kMinCurveId || curve_id > L::kMaxCurveId) {
    return absl::InvalidArgumentError(
        absl::StrCat("curve_id ", curve_id, " outside ", L::kMinCurveId, "..", L::kMaxCurveId));
  }
  if (pt.positions_mm.size() < static_cast<size_t>(L::kMinPoints) ||
      pt.positions_mm.size() > static_cast<size_t>(L::kMaxPoints)) {
    return absl::InvalidArgumentError(absl::StrCat("positions_mm: ", pt.positions_mm.size(),
                                                   " points outside ", L::kMinPoints, "..",
                                                   L::kMaxPoints, " (LinMot curve service)"));
  }
  L out;
  out.curve_id = curve_id;
  out.points.reserve(pt.positions_mm.size());
  for (size_t i = 0; i < pt.positions_mm.size(); ++i) {
    const double raw = std::round(pt.positions_mm[i] / L::kPointUnitMm);
    if (!(raw >= std::numeric_limits<int32_t>::min() &&
          raw <= std::numeric_limits<int32_t>::max())) {
      return absl::InvalidArgumentError(absl::StrCat("positions_mm[", i, "]: ", pt.positions_mm[i],
                                                     " mm outside SInt32 x 0.1 um"));
    }
    out.points.push_back(static_cast<int32_t>(raw));
  }
  const double duration = pt.time_step_s * static_cast<double>(pt.positions_mm.size() - 1);
  const double units = duration / L::kTimeUnitS;
  if (!(std::abs(units - std::round(units)) < 1e-6 * std::max(1.0, units)) || units < 1 ||
      units > 4294967295.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "time_step_s: duration ", duration, " s is not a whole count of 10 us in 1..2^32-1"));
  }
  out.x_length_s = std::round(units) * L::kTimeUnitS;
  out.offset_mm = static_cast<double>(out.points.front()) * L::kPointUnitMm;
  out.amplitude_scale_pct = 100;
  out.time_scale_pct = 100;
  return out;
}

}  // namespace drivegw
