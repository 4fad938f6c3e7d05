// Time curves of the simulated drive: D-29 evaluation and the start-parameter rules of §5.5.
#include "sim/linmot/time_curve.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "adapters/linmot/linudp/curve_info_block.h"
#include "adapters/linmot/mc/error_codes.h"

namespace drivegw::sim::linmot {
namespace {

constexpr double kMmPerInc = 1e-4;               // 0.1 um
constexpr double kSecondsPerUnit = 1e-5;         // 10 us (Curve Time, x-Length; §7 L1002)
constexpr double kMaxAmplitudePermille = 20000;  // ±2000 % in 0.1 % (§5.5 L526, L528)

// Curve time from the nominal x-Length and a time scale in 0.01 % (D-29): x-Length x 100 % /
// scale; 0 % stretches the curve to infinity (decision 606).
double ScaledDuration(uint32_t x_length, int64_t time_scale) {
  if (time_scale <= 0) return std::numeric_limits<double>::infinity();
  return static_cast<double>(x_length) * kSecondsPerUnit * 10000.0 /
         static_cast<double>(time_scale);
}

TimeCurvePlan Fail(uint16_t code, std::string reason) {
  return TimeCurvePlan{std::nullopt, code, std::move(reason)};
}

}  // namespace

double TimeCurve::At(double t_s) const {
  const size_t n = points.size();
  if (n == 0) return offset_mm;
  double tau = 0;
  if (std::isinf(duration_s)) {
    tau = 0;
  } else if (duration_s <= 0) {
    tau = 1;
  } else {
    tau = std::clamp(t_s / duration_s, 0.0, 1.0);
  }
  double y = points.back();
  if (n >= 2 && tau < 1) {
    const double x = tau * static_cast<double>(n - 1);
    const size_t i = std::min(static_cast<size_t>(x), n - 2);
    const double frac = x - static_cast<double>(i);
    y = points[i] + frac * (static_cast<double>(points[i + 1]) - points[i]);
  }
  return offset_mm + amplitude * (y - points.front()) * kMmPerInc;
}

TimeCurvePlan PlanTimeCurve(const action::RunCurve& cmd, const RtcChannel::StoredCurve* stored,
                            const Parameters& params, double demand_mm) {
  using Form = action::RunCurve::Form;
  namespace lu = ::drivegw::linmot::linudp;
  const std::string id = absl::StrCat("curve ", cmd.curve_id);
  // §7 L1007: starting a curve the drive does not hold raises 0062h. A stored block that does not
  // describe a position curve of >= 2 points counts as "not defined" (decision 606).
  if (stored == nullptr) return Fail(mc::kCurveNotDefined, absl::StrCat(id, ": not stored"));
  auto info = lu::DecodeCurveInfoBlock(stored->info);
  if (!info.ok()) return Fail(mc::kCurveNotDefined, std::string(info.status().message()));
  auto points = lu::DecodeCurveData(stored->data);
  if (!points.ok()) return Fail(mc::kCurveNotDefined, std::string(points.status().message()));
  auto model = lu::FromWireCurve(lu::WireCurve{*info, *points});
  if (!model.ok()) return Fail(mc::kCurveNotDefined, std::string(model.status().message()));
  if (points->size() < 2) {
    return Fail(mc::kCurveNotDefined,
                absl::StrCat(id, ": ", points->size(), " points (D-29: >= 2)"));
  }

  TimeCurve c;
  c.curve_id = cmd.curve_id;
  c.points = std::move(*points);
  const int64_t y0 = c.points.front();
  const int64_t y1 = c.points.back();
  const int64_t default_amplitude = params.Get(upid::kCurveAmplitudeScale);
  const int64_t default_time_scale = params.Get(upid::kCurveTimeScale);
  auto amplitude = [&](int64_t permille) -> std::optional<double> {
    // 044h/045h take the scale as given; beyond ±2000 % the drive refuses like the "To Pos"
    // forms (0089h, decision 606).
    if (std::abs(static_cast<double>(permille)) > kMaxAmplitudePermille) return std::nullopt;
    return static_cast<double>(permille) / 1000.0;
  };
  switch (cmd.form) {
    case Form::kDefault:
    case Form::kDefaultFromDemand:
      c.offset_mm =
          cmd.form == Form::kDefault ? params.Get(upid::kCurveOffset) * kMmPerInc : demand_mm;
      c.amplitude = static_cast<double>(default_amplitude) / 1000.0;
      c.duration_s = ScaledDuration(info->x_length, default_time_scale);
      break;
    case Form::kToPos:
    case Form::kToPosTime: {
      // §5.5 042h/043h, D-29: offset := demand; scale = (target - offset) / (y(1) - y(0)).
      c.offset_mm = demand_mm;
      if (y1 == y0) return Fail(mc::kCurveAmpScaleError, absl::StrCat(id, ": y(1) = y(0)"));
      const double scale = (cmd.target * kMmPerInc - demand_mm) / ((y1 - y0) * kMmPerInc);
      if (std::abs(scale) * 1000.0 > kMaxAmplitudePermille) {
        return Fail(mc::kCurveAmpScaleError,
                    absl::StrCat(id, ": amplitude scale ", scale * 100, " % beyond ±2000 %"));
      }
      c.amplitude = scale;
      // 042h's "default curve speed" has no UPID in the manual: the default time scale 14CBh
      // (decision 606).
      c.duration_s = cmd.form == Form::kToPos ? ScaledDuration(info->x_length, default_time_scale)
                                              : cmd.curve_time * kSecondsPerUnit;
      break;
    }
    case Form::kOffsetScales:
    case Form::kOffsetTimeAmplitude: {
      const auto a = amplitude(cmd.amplitude_scale);
      if (!a) {
        return Fail(mc::kCurveAmpScaleError,
                    absl::StrCat(id, ": amplitude scale ", cmd.amplitude_scale / 10.0, " %"));
      }
      c.offset_mm = cmd.offset * kMmPerInc;
      c.amplitude = *a;
      c.duration_s = cmd.form == Form::kOffsetScales
                         ? ScaledDuration(info->x_length, cmd.time_scale)
                         : cmd.curve_time * kSecondsPerUnit;
      break;
    }
  }
  return TimeCurvePlan{std::move(c), 0, ""};
}

}  // namespace drivegw::sim::linmot
