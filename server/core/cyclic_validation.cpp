// Cyclic set-point checks (stober-motion.md §3.8 CyclicSpeed, §3.11 CyclicPosition).
#include "server/core/cyclic_validation.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/core/errors.h"

namespace drivegw::server {

absl::StatusOr<CyclicMode> ValidateCyclicMode(v1::CyclicMode mode) {
  switch (mode) {
    case v1::CYCLIC_POSITION:
      return CyclicMode::kPosition;
    case v1::CYCLIC_VELOCITY:
      return CyclicMode::kVelocity;
    case v1::CYCLIC_MODE_UNSPECIFIED:
      return FieldError("mode",
                        "is required in the first message: CYCLIC_POSITION or CYCLIC_VELOCITY");
    default:
      break;
  }
  return FieldError("mode", absl::StrCat(static_cast<int>(mode),
                                         " is not a CyclicMode (1 CYCLIC_POSITION, 2 "
                                         "CYCLIC_VELOCITY)"));
}

absl::StatusOr<CyclicSetpoint> ValidateCyclicSetpoint(const v1::CyclicSetpoint& p, CyclicMode mode,
                                                      const AxisConfig& axis, uint64_t index) {
  const std::string value_field = absl::StrCat("setpoints[", index, "].value");
  const std::string ff_field = absl::StrCat("setpoints[", index, "].velocity_mm_s");
  const double v = p.value();
  if (!std::isfinite(v)) return FieldError(value_field, absl::StrCat(v, " is not a finite number"));
  if (mode == CyclicMode::kPosition) {
    // The drive would only clamp or raise event 78 (§3.11, L1763); the axis range is the
    // gateway's promise that no command leaves it (decision 005).
    if (v < axis.min_mm) {
      return FieldError(value_field, absl::StrCat(v, " is below axis min_mm ", axis.min_mm));
    }
    if (v > axis.max_mm) {
      return FieldError(value_field, absl::StrCat(v, " exceeds axis max_mm ", axis.max_mm));
    }
  } else if (std::fabs(v) > axis.max_velocity_mm_s) {
    return FieldError(value_field, absl::StrCat("|", v, "| exceeds axis max_velocity_mm_s ",
                                                axis.max_velocity_mm_s));
  }
  const double ff = p.velocity_mm_s();
  if (!std::isfinite(ff)) return FieldError(ff_field, absl::StrCat(ff, " is not a finite number"));
  if (mode == CyclicMode::kVelocity && ff != 0) {
    return FieldError(ff_field,
                      absl::StrCat(ff,
                                   ": a feed-forward velocity belongs to CYCLIC_POSITION; "
                                   "in CYCLIC_VELOCITY the value is the velocity"));
  }
  if (std::fabs(ff) > axis.max_velocity_mm_s) {
    return FieldError(ff_field, absl::StrCat("|", ff, "| exceeds axis max_velocity_mm_s ",
                                             axis.max_velocity_mm_s));
  }
  return CyclicSetpoint{v, ff};
}

}  // namespace drivegw::server
