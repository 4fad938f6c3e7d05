// Checks of the family-neutral parts of a DriveConfig that a factory refuses before it builds a
// drive: every time-out positive, an axis range that is not empty. Messages name the field below
// `where` ("drive 'x'"), as the LinMot factories always did.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "adapters/core/drive_config.h"

namespace drivegw {

// InvalidArgument "<where>.timeouts.<field>: <ms> ms must be positive" (request, accept, homing
// in this order), then "<where>.axis.min_mm: <min> must be below axis.max_mm <max>".
absl::Status CheckTimeoutsAndAxis(const DriveConfig& config, const std::string& where);

}  // namespace drivegw
