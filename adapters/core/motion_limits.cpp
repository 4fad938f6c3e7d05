// Motion-command limit checks shared by the drive families (motion_limits.h).
#include "adapters/core/motion_limits.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"

namespace drivegw {

absl::Status CheckProfileLimit(const std::string& field, double value, double axis_limit,
                               const char* axis_field, const char* positive_note) {
  if (!std::isfinite(value) || value <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", value, " must be positive", positive_note));
  }
  if (value > axis_limit) {
    return absl::OutOfRangeError(absl::StrCat(field, ": ", value, " exceeds axis limit ",
                                              axis_limit, " (", axis_field, ")"));
  }
  return absl::OkStatus();
}

absl::Status CheckMoveProfile(const std::string& kind, double v, double a, double d,
                              const AxisConfig& axis, const char* positive_note) {
  DGW_RETURN_IF_ERROR(CheckProfileLimit(kind + ".velocity_mm_s", v, axis.max_velocity_mm_s,
                                        "axis.max_velocity_mm_s", positive_note));
  DGW_RETURN_IF_ERROR(CheckProfileLimit(kind + ".acceleration_mm_s2", a,
                                        axis.max_acceleration_mm_s2, "axis.max_acceleration_mm_s2",
                                        positive_note));
  return CheckProfileLimit(kind + ".deceleration_mm_s2", d, axis.max_acceleration_mm_s2,
                           "axis.max_acceleration_mm_s2", positive_note);
}

absl::Status CheckAxisPosition(const std::string& field, double value, double target,
                               const AxisConfig& axis) {
  if (!std::isfinite(value)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " is not a finite number"));
  }
  if (target < axis.min_mm || target > axis.max_mm) {
    if (value == target) {
      return absl::OutOfRangeError(absl::StrCat(field, ": ", value, " is outside the axis range [",
                                                axis.min_mm, ", ", axis.max_mm, "]"));
    }
    return absl::OutOfRangeError(absl::StrCat(field, ": ", value, " takes the axis to ", target,
                                              ", outside the axis range [", axis.min_mm, ", ",
                                              axis.max_mm, "]"));
  }
  return absl::OkStatus();
}

}  // namespace drivegw
