// Curve sampling, derivation and validation (docs/decisions/012-curves.md).
#include "adapters/core/curve.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <string_view>

#include "absl/strings/str_cat.h"

namespace drivegw {
namespace {

using LM = LinMotParametricCurve;

constexpr size_t kMaxCurveNameLength = 128;
// Curve Offset SInt32 [0.1 µm] (linmot-mc.md §5.5 044h, L528).
constexpr double kMaxOffsetMm = 2147483647.0 * LM::kPointUnitMm;
// Tolerance for "is a whole number of wire units" (binary doubles of decimal values).
constexpr double kUnitTolerance = 1e-6;

bool IsWholeMultiple(double value, double unit) {
  const double n = value / unit;
  return std::abs(n - std::round(n)) <= kUnitTolerance * std::max(1.0, std::abs(n));
}

// The time step and positions the curve commands with its default parameters.
struct Equidistant {
  double step_s = 0;
  std::vector<double> positions_mm;
};

Equidistant ToEquidistant(const Curve& curve) {
  if (const auto* pt = std::get_if<PositionTimeCurve>(&curve.shape)) {
    return {pt->time_step_s, pt->positions_mm};
  }
  const auto& lm = std::get<LM>(curve.shape);
  Equidistant e;
  const size_t n = lm.points.size();
  if (n >= 2 && lm.time_scale_pct > 0) {
    // D-29 (linmot-mc.md L1009): Tc = nominal duration × 100 % / Time Scale, points equally spaced.
    e.step_s = lm.x_length_s * 100.0 / lm.time_scale_pct / static_cast<double>(n - 1);
  }
  e.positions_mm.reserve(n);
  const double y0 = n ? static_cast<double>(lm.points[0]) : 0;
  for (const int32_t y : lm.points) {
    // D-29: demand = Offset + AmpScale/100 % × (y − y(0)); amplitude relative to the first point.
    e.positions_mm.push_back(lm.offset_mm + lm.amplitude_scale_pct / 100.0 *
                                                (static_cast<double>(y) - y0) * LM::kPointUnitMm);
  }
  return e;
}

void LinMotErrors(const LM& lm, std::vector<std::string>& errors) {
  if (lm.curve_id < LM::kMinCurveId || lm.curve_id > LM::kMaxCurveId) {
    errors.push_back(absl::StrCat("curve_id: ", lm.curve_id, " is outside ", LM::kMinCurveId, "..",
                                  LM::kMaxCurveId, " (linmot-mc.md §7)"));
  }
  if (lm.y_unit != LM::YUnit::kPosition0p1um) {
    errors.push_back("y_unit: only position in 0.1 um is defined (linmot-mc.md §7)");
  }
  const size_t n = lm.points.size();
  if (n > static_cast<size_t>(LM::kMaxPoints)) {
    errors.push_back(absl::StrCat("points: count ", n, " exceeds the LinMot limit ", LM::kMaxPoints,
                                  " (16-bit data block size)"));
  }
  if (!std::isfinite(lm.x_length_s) || lm.x_length_s <= 0 || lm.x_length_s > LM::kMaxXLengthS) {
    errors.push_back(absl::StrCat("x_length_s: ", lm.x_length_s, " is outside (0, ",
                                  LM::kMaxXLengthS, "] s (UInt32 in 10 us)"));
  } else if (lm.x_length_s < LM::kTimeUnitS || !IsWholeMultiple(lm.x_length_s, LM::kTimeUnitS)) {
    errors.push_back(absl::StrCat("x_length_s: ", lm.x_length_s,
                                  " is not a whole number of 10 us units (minimum 1e-05 s)"));
  }
  if (!std::isfinite(lm.amplitude_scale_pct) ||
      lm.amplitude_scale_pct < LM::kMinAmplitudeScalePct ||
      lm.amplitude_scale_pct > LM::kMaxAmplitudeScalePct) {
    errors.push_back(absl::StrCat("amplitude_scale_pct: ", lm.amplitude_scale_pct, " is outside ",
                                  LM::kMinAmplitudeScalePct, "..", LM::kMaxAmplitudeScalePct,
                                  " %"));
  } else if (!IsWholeMultiple(lm.amplitude_scale_pct, LM::kAmplitudeScaleUnitPct)) {
    errors.push_back(absl::StrCat("amplitude_scale_pct: ", lm.amplitude_scale_pct,
                                  " is not a whole number of 0.1 % units"));
  }
  if (!std::isfinite(lm.time_scale_pct) || lm.time_scale_pct <= 0 ||
      lm.time_scale_pct > LM::kMaxTimeScalePct) {
    errors.push_back(absl::StrCat("time_scale_pct: ", lm.time_scale_pct, " is outside (0, ",
                                  LM::kMaxTimeScalePct, "] %"));
  } else if (!IsWholeMultiple(lm.time_scale_pct, LM::kTimeScaleUnitPct)) {
    errors.push_back(absl::StrCat("time_scale_pct: ", lm.time_scale_pct,
                                  " is not a whole number of 0.01 % units"));
  }
  if (!std::isfinite(lm.offset_mm) || std::abs(lm.offset_mm) > kMaxOffsetMm) {
    errors.push_back(absl::StrCat("offset_mm: ", lm.offset_mm, " is outside +-", kMaxOffsetMm,
                                  " mm (SInt32 in 0.1 um)"));
  }
}

absl::Status FirstError(const std::vector<std::string>& errors, std::string_view prefix) {
  if (errors.empty()) return absl::OkStatus();
  std::string message = absl::StrCat(std::string(prefix), errors.front());
  if (errors.size() > 1) absl::StrAppend(&message, " (and ", errors.size() - 1, " more)");
  return absl::InvalidArgumentError(message);
}

std::string CurveLabel(size_t index, const Curve& curve) {
  return absl::StrCat("curves[", index, "] '", curve.name, "': ");
}

}  // namespace

absl::StatusOr<CurveSamples> SampleCurve(const Curve& curve) {
  Equidistant e = ToEquidistant(curve);
  const size_t n = e.positions_mm.size();
  if (n < 2) {
    return absl::InvalidArgumentError(absl::StrCat("points: count ", n, " is below the minimum 2"));
  }
  if (!std::isfinite(e.step_s) || e.step_s <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("time_step_s: ", e.step_s, " is not a finite value > 0"));
  }
  const double h = e.step_s;
  CurveSamples s;
  s.time_step_s = h;
  s.t_s.resize(n);
  s.velocity_mm_s.resize(n);
  s.acceleration_mm_s2.resize(n, 0.0);
  for (size_t i = 0; i < n; ++i) s.t_s[i] = static_cast<double>(i) * h;
  const std::vector<double>& p = e.positions_mm;
  s.velocity_mm_s[0] = (p[1] - p[0]) / h;
  s.velocity_mm_s[n - 1] = (p[n - 1] - p[n - 2]) / h;
  for (size_t i = 1; i + 1 < n; ++i) {
    s.velocity_mm_s[i] = (p[i + 1] - p[i - 1]) / (2 * h);
    s.acceleration_mm_s2[i] = (p[i + 1] - 2 * p[i] + p[i - 1]) / (h * h);
  }
  if (n >= 3) {
    s.acceleration_mm_s2[0] = s.acceleration_mm_s2[1];
    s.acceleration_mm_s2[n - 1] = s.acceleration_mm_s2[n - 2];
  }
  s.position_mm = std::move(e.positions_mm);
  return s;
}

absl::StatusOr<CurveSummary> SummarizeCurve(const Curve& curve) {
  auto samples = SampleCurve(curve);
  if (!samples.ok()) return samples.status();
  const CurveSamples& s = *samples;
  CurveSummary sum;
  sum.duration_s = s.t_s.back();
  sum.start_mm = s.position_mm.front();
  sum.end_mm = s.position_mm.back();
  const auto [lo, hi] = std::minmax_element(s.position_mm.begin(), s.position_mm.end());
  sum.min_mm = *lo;
  sum.max_mm = *hi;
  for (const double v : s.velocity_mm_s) {
    sum.peak_velocity_mm_s = std::max(sum.peak_velocity_mm_s, std::abs(v));
  }
  for (const double a : s.acceleration_mm_s2) {
    sum.peak_acceleration_mm_s2 = std::max(sum.peak_acceleration_mm_s2, std::abs(a));
  }
  return sum;
}

std::vector<std::string> CurveShapeErrors(const Curve& curve) {
  std::vector<std::string> errors;
  if (curve.name.empty() || curve.name.size() > kMaxCurveNameLength) {
    errors.push_back(
        absl::StrCat("name: length ", curve.name.size(), " is outside 1..", kMaxCurveNameLength));
  }
  if (const auto* pt = std::get_if<PositionTimeCurve>(&curve.shape)) {
    // Time is monotone by construction (t = i × step); a positive finite step is all it takes.
    if (!std::isfinite(pt->time_step_s) || pt->time_step_s <= 0) {
      errors.push_back(
          absl::StrCat("time_step_s: ", pt->time_step_s, " is not a finite value > 0"));
    }
    if (pt->positions_mm.size() < 2) {
      errors.push_back(
          absl::StrCat("points: count ", pt->positions_mm.size(), " is below the minimum 2"));
    }
    for (size_t i = 0; i < pt->positions_mm.size(); ++i) {
      if (!std::isfinite(pt->positions_mm[i])) {
        errors.push_back(
            absl::StrCat("points[", i, "]: position ", pt->positions_mm[i], " is not finite"));
      }
    }
    return errors;
  }
  const auto& lm = std::get<LM>(curve.shape);
  if (lm.points.size() < static_cast<size_t>(LM::kMinPoints)) {
    errors.push_back(
        absl::StrCat("points: count ", lm.points.size(), " is below the minimum ", LM::kMinPoints));
  }
  LinMotErrors(lm, errors);
  return errors;
}

std::vector<std::string> CurveErrors(const Curve& curve, const AxisConfig& axis) {
  std::vector<std::string> errors = CurveShapeErrors(curve);
  if (!errors.empty()) return errors;  // the samples are meaningless on a broken shape
  auto samples = SampleCurve(curve);
  if (!samples.ok()) {
    errors.emplace_back(samples.status().message());
    return errors;
  }
  const CurveSamples& s = *samples;
  for (size_t i = 0; i < s.position_mm.size(); ++i) {
    const double p = s.position_mm[i];
    if (p < axis.min_mm) {
      errors.push_back(
          absl::StrCat("points[", i, "]: position ", p, " mm is below axis.min_mm ", axis.min_mm));
    } else if (p > axis.max_mm) {
      errors.push_back(
          absl::StrCat("points[", i, "]: position ", p, " mm exceeds axis.max_mm ", axis.max_mm));
    }
    const double v = s.velocity_mm_s[i];
    if (std::abs(v) > axis.max_velocity_mm_s) {
      errors.push_back(absl::StrCat("points[", i, "]: velocity ", v,
                                    " mm/s exceeds axis.max_velocity_mm_s ",
                                    axis.max_velocity_mm_s));
    }
    const double a = s.acceleration_mm_s2[i];
    if (std::abs(a) > axis.max_acceleration_mm_s2) {
      errors.push_back(absl::StrCat("points[", i, "]: acceleration ", a,
                                    " mm/s2 exceeds axis.max_acceleration_mm_s2 ",
                                    axis.max_acceleration_mm_s2));
    }
  }
  return errors;
}

absl::Status ValidateCurveShape(const Curve& curve) {
  return FirstError(CurveShapeErrors(curve), "");
}

absl::Status ValidateCurve(const Curve& curve, const AxisConfig& axis) {
  return FirstError(CurveErrors(curve, axis), "");
}

namespace {

// `axis` null: shape only.
absl::Status ValidateSetWith(const CurveSet& set, const AxisConfig* axis) {
  if (set.name.empty() || set.name.size() > kMaxCurveNameLength) {
    return absl::InvalidArgumentError(absl::StrCat("curve_set.name: length ", set.name.size(),
                                                   " is outside 1..", kMaxCurveNameLength));
  }
  std::set<std::string_view> names;
  std::set<int> ids;
  for (size_t i = 0; i < set.curves.size(); ++i) {
    const Curve& c = set.curves[i];
    if (!names.insert(c.name).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(CurveLabel(i, c), "name: listed twice in curve set '", set.name, "'"));
    }
    // A LinMot drive holds one curve per ID (linmot-mc.md §7 L997): two in one set would collide.
    if (const auto* lm = std::get_if<LM>(&c.shape); lm && !ids.insert(lm->curve_id).second) {
      return absl::InvalidArgumentError(absl::StrCat(CurveLabel(i, c), "curve_id: ", lm->curve_id,
                                                     " is used by another curve of the set"));
    }
    const std::vector<std::string> errors = axis ? CurveErrors(c, *axis) : CurveShapeErrors(c);
    if (absl::Status s = FirstError(errors, CurveLabel(i, c)); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateCurveSetShape(const CurveSet& set) { return ValidateSetWith(set, nullptr); }

absl::Status ValidateCurveSet(const CurveSet& set, const AxisConfig& axis) {
  return ValidateSetWith(set, &axis);
}

}  // namespace drivegw
