// Trinamic unit conversions (trinamic-sixpack.md §5.1-5.3): microsteps <-> mm, velocity register
// <-> microsteps/s, amax <-> microsteps/s². Checked, never clamped; errors name field and limit.
#pragma once

#include <cstdint>

#include "absl/status/statusor.h"

namespace drivegw::trinamic {

inline constexpr double kClockHz = 20'000'000.0;         // f_clk (L492)
inline constexpr double kMaxMicrostepHz = 200'000.0;     // L497
inline constexpr double kAccelerationTicksPerS = 500.0;  // 2 ms cycle (L557)
inline constexpr double kAmaxDivisor = 64.0;             // amax/64 per tick (L557, G-07)

// Global clkdiv (`$12`, 0..31) and per-motor div (`$13` P5, 0..3): the velocity scale.
struct VelocityScale {
  int clkdiv = 5;  // default (L359-371)
  int div = 2;
};

// K = 20 MHz / ((clkdiv + 1) × 2^(14 + div)) microsteps/s per velocity unit (§5.1).
absl::StatusOr<double> MicrostepsPerVelocityUnit(VelocityScale scale);

// Velocity register (−511..511, L494) → microsteps/s. Also refuses > 200 kHz (L497).
absl::StatusOr<double> VelocityToMicrostepsPerSecond(int velocity, VelocityScale scale);
// microsteps/s → register, rounded to nearest; refuses |v| > 511 and > 200 kHz.
absl::StatusOr<int> MicrostepsPerSecondToVelocity(double microsteps_s, VelocityScale scale);

// amax (1..32767, L556) → microsteps/s² = 7.8125 × amax × K (§5.3).
absl::StatusOr<double> AmaxToMicrostepsPerSecond2(int amax, VelocityScale scale);
// microsteps/s² → amax, rounded to nearest; refuses results outside 1..32767.
absl::StatusOr<int> MicrostepsPerSecond2ToAmax(double microsteps_s2, VelocityScale scale);

// Position: int32 microsteps (L60, L660) ↔ mm with the configured microsteps_per_unit (> 0).
absl::StatusOr<double> MicrostepsToMm(int64_t microsteps, double microsteps_per_unit);
absl::StatusOr<int32_t> MmToMicrosteps(double mm, double microsteps_per_unit);

// Velocity / acceleration in mm: microsteps/s ÷ microsteps_per_unit and back.
absl::StatusOr<double> VelocityToMmPerSecond(int velocity, VelocityScale scale,
                                             double microsteps_per_unit);
absl::StatusOr<int> MmPerSecondToVelocity(double mm_s, VelocityScale scale,
                                          double microsteps_per_unit);
absl::StatusOr<double> AmaxToMmPerSecond2(int amax, VelocityScale scale,
                                          double microsteps_per_unit);
absl::StatusOr<int> MmPerSecond2ToAmax(double mm_s2, VelocityScale scale,
                                       double microsteps_per_unit);

}  // namespace drivegw::trinamic
