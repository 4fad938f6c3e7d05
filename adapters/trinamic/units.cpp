// Trinamic unit conversions: the formulas of trinamic-sixpack.md §5.1 (L487-497) and §5.3 (L557).
#include "adapters/trinamic/units.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"

namespace drivegw::trinamic {
namespace {

// Integral values print without exponent ("2147483647", not "2.14748e+09").
std::string Num(double v) {
  if (std::fabs(v) < 1e15 && v == std::trunc(v)) return absl::StrCat(static_cast<int64_t>(v));
  return absl::StrCat(v);
}

absl::Status Range(const char* field, double v, double min, double max) {
  if (!std::isfinite(v)) return absl::InvalidArgumentError(absl::StrCat(field, ": not finite"));
  if (v > max)
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", Num(v), " exceeds ", Num(max)));
  if (v < min)
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", Num(v), " below ", Num(min)));
  return absl::OkStatus();
}

absl::Status CheckMpu(double microsteps_per_unit) {
  if (!std::isfinite(microsteps_per_unit) || microsteps_per_unit <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("microsteps_per_unit: ", microsteps_per_unit, " must be > 0"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<double> MicrostepsPerVelocityUnit(VelocityScale scale) {
  if (auto s = Range("clkdiv", scale.clkdiv, 0, 31); !s.ok()) return s;  // L493
  if (auto s = Range("div", scale.div, 0, 3); !s.ok()) return s;         // L495
  return kClockHz / ((scale.clkdiv + 1) * std::ldexp(1.0, 14 + scale.div));
}

absl::StatusOr<double> VelocityToMicrostepsPerSecond(int velocity, VelocityScale scale) {
  if (auto s = Range("velocity", velocity, -511, 511); !s.ok()) return s;
  auto k = MicrostepsPerVelocityUnit(scale);
  if (!k.ok()) return k.status();
  const double f = *k * velocity;
  if (auto s = Range("velocity.microstep_hz", std::fabs(f), 0, kMaxMicrostepHz); !s.ok()) return s;
  return f;
}

absl::StatusOr<int> MicrostepsPerSecondToVelocity(double microsteps_s, VelocityScale scale) {
  auto k = MicrostepsPerVelocityUnit(scale);
  if (!k.ok()) return k.status();
  if (auto s = Range("velocity.microstep_hz", std::fabs(microsteps_s), 0, kMaxMicrostepHz);
      !s.ok()) {
    return s;
  }
  const double v = std::round(microsteps_s / *k);
  if (auto s = Range("velocity", v, -511, 511); !s.ok()) return s;
  const int register_value = static_cast<int>(v);
  // Rounding may still cross 200 kHz (e.g. K × 164 at clkdiv 0, div 0).
  if (auto s = Range("velocity.microstep_hz", std::fabs(*k * register_value), 0, kMaxMicrostepHz);
      !s.ok()) {
    return s;
  }
  return register_value;
}

absl::StatusOr<double> AmaxToMicrostepsPerSecond2(int amax, VelocityScale scale) {
  if (auto s = Range("amax", amax, 1, 32767); !s.ok()) return s;  // L556-559
  auto k = MicrostepsPerVelocityUnit(scale);
  if (!k.ok()) return k.status();
  return kAccelerationTicksPerS / kAmaxDivisor * amax * *k;  // 7.8125 × amax × K (§5.3)
}

absl::StatusOr<int> MicrostepsPerSecond2ToAmax(double microsteps_s2, VelocityScale scale) {
  auto k = MicrostepsPerVelocityUnit(scale);
  if (!k.ok()) return k.status();
  if (!std::isfinite(microsteps_s2)) return absl::InvalidArgumentError("amax: not finite");
  const double amax = std::round(microsteps_s2 / (kAccelerationTicksPerS / kAmaxDivisor * *k));
  if (auto s = Range("amax", amax, 1, 32767); !s.ok()) return s;
  return static_cast<int>(amax);
}

absl::StatusOr<double> MicrostepsToMm(int64_t microsteps, double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  return static_cast<double>(microsteps) / microsteps_per_unit;
}

absl::StatusOr<int32_t> MmToMicrosteps(double mm, double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  if (!std::isfinite(mm)) return absl::InvalidArgumentError("position_mm: not finite");
  const double steps = std::round(mm * microsteps_per_unit);
  // Positions are int32 microsteps (L60, L660).
  if (auto s = Range("position.microsteps", steps, INT32_MIN, INT32_MAX); !s.ok()) return s;
  return static_cast<int32_t>(steps);
}

absl::StatusOr<double> VelocityToMmPerSecond(int velocity, VelocityScale scale,
                                             double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  auto f = VelocityToMicrostepsPerSecond(velocity, scale);
  if (!f.ok()) return f.status();
  return *f / microsteps_per_unit;
}

absl::StatusOr<int> MmPerSecondToVelocity(double mm_s, VelocityScale scale,
                                          double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  return MicrostepsPerSecondToVelocity(mm_s * microsteps_per_unit, scale);
}

absl::StatusOr<double> AmaxToMmPerSecond2(int amax, VelocityScale scale,
                                          double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  auto a = AmaxToMicrostepsPerSecond2(amax, scale);
  if (!a.ok()) return a.status();
  return *a / microsteps_per_unit;
}

absl::StatusOr<int> MmPerSecond2ToAmax(double mm_s2, VelocityScale scale,
                                       double microsteps_per_unit) {
  if (auto s = CheckMpu(microsteps_per_unit); !s.ok()) return s;
  return MicrostepsPerSecond2ToAmax(mm_s2 * microsteps_per_unit, scale);
}

}  // namespace drivegw::trinamic
