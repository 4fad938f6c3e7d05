// Physical units <-> LinMot-style fixed-point wire units, checked: out-of-range values are
// errors naming the field and the limit, never clamps (STYLE.md §3 "linmot_client" lesson).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

namespace drivegw::units {

// Scale factors of the LinMot MC interface (linmot-mc.md §0.4): 1 increment =
inline constexpr double kPositionPerMm = 10'000.0;      // 0.1 µm
inline constexpr double kVelocityPerMmS = 1'000.0;      // 1E-6 m/s = 1 µm/s
inline constexpr double kAccelerationPerMmS2 = 100.0;   // 1E-5 m/s² = 0.01 mm/s²
inline constexpr double kJerkPerMmS3 = 10.0;            // 1E-4 m/s³ = 0.1 mm/s³

// Fields are std::string: Debian's abseil 20220623 has its own absl::string_view, which StrCat
// does not convert from std::string_view.
// Rounds value*scale to the nearest integer and checks it fits [lo, hi].
inline absl::StatusOr<int64_t> ToFixed(const std::string& field, double value, double scale,
                                       int64_t lo, int64_t hi) {
  if (!std::isfinite(value)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " is not a finite number"));
  }
  const double scaled = std::nearbyint(value * scale);
  if (scaled < static_cast<double>(lo) || scaled > static_cast<double>(hi)) {
    return absl::OutOfRangeError(absl::StrCat(field, ": ", value, " is outside the wire range [",
                                              static_cast<double>(lo) / scale, ", ",
                                              static_cast<double>(hi) / scale, "]"));
  }
  return static_cast<int64_t>(scaled);
}

inline absl::StatusOr<int32_t> PositionToWire(const std::string& field, double mm) {
  auto v = ToFixed(field, mm, kPositionPerMm, std::numeric_limits<int32_t>::min(),
                   std::numeric_limits<int32_t>::max());
  if (!v.ok()) return v.status();
  return static_cast<int32_t>(*v);
}
// Velocity limits: UInt32 0 … 7FFF'FFFFh (linmot-mc.md §6.1).
inline absl::StatusOr<uint32_t> VelocityToWire(const std::string& field, double mm_s) {
  auto v = ToFixed(field, mm_s, kVelocityPerMmS, 0, 0x7FFF'FFFF);
  if (!v.ok()) return v.status();
  return static_cast<uint32_t>(*v);
}
inline absl::StatusOr<uint32_t> AccelerationToWire(const std::string& field, double mm_s2) {
  auto v = ToFixed(field, mm_s2, kAccelerationPerMmS2, 0, 0x7FFF'FFFF);
  if (!v.ok()) return v.status();
  return static_cast<uint32_t>(*v);
}

inline double PositionFromWire(int32_t v) { return v / kPositionPerMm; }
inline double VelocityFromWire(int32_t v) { return v / kVelocityPerMmS; }
inline double AccelerationFromWire(int32_t v) { return v / kAccelerationPerMmS2; }

}  // namespace drivegw::units
