// Family-neutral DriveConfig checks for the drive factories (drive_config_check.h).
#include "adapters/core/drive_config_check.h"

#include <chrono>
#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw {

absl::Status CheckTimeoutsAndAxis(const DriveConfig& config, const std::string& where) {
  const TimeoutConfig& t = config.timeouts;
  for (const auto& [field, value] : {std::pair{"request", t.request}, std::pair{"accept", t.accept},
                                     std::pair{"homing", t.homing}}) {
    if (value <= std::chrono::milliseconds(0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".timeouts.", field, ": ", value.count(), " ms must be positive"));
    }
  }
  if (!(config.axis.min_mm < config.axis.max_mm)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".axis.min_mm: ", config.axis.min_mm,
                                                   " must be below axis.max_mm ",
                                                   config.axis.max_mm));
  }
  return absl::OkStatus();
}

}  // namespace drivegw
