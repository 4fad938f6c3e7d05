// Checks of the cyclic set-point stream (StreamCyclicSetpoints): the mode of the first message
// and every set point against the axis. Errors are InvalidArgument field violations: in a stream,
// OUT_OF_RANGE would read as "iterated past the end"
// (docs/decisions/008-cyclic-setpoint-stream.md).
#pragma once

#include <cstdint>

#include "absl/status/statusor.h"
#include "adapters/core/command.h"
#include "adapters/core/drive_config.h"
#include "drivegw/v1/drive.pb.h"

namespace drivegw::server {

// CYCLIC_POSITION or CYCLIC_VELOCITY; field "mode".
absl::StatusOr<CyclicMode> ValidateCyclicMode(v1::CyclicMode mode);

// Set point number `index` (0-based over the stream): finite; position within min_mm..max_mm
// (CYCLIC_POSITION) or |velocity| <= max_velocity_mm_s (CYCLIC_VELOCITY); feed-forward finite,
// |v| <= max_velocity_mm_s, and 0 in CYCLIC_VELOCITY. Fields "setpoints[i].value",
// "setpoints[i].velocity_mm_s".
absl::StatusOr<CyclicSetpoint> ValidateCyclicSetpoint(const v1::CyclicSetpoint& p, CyclicMode mode,
                                                      const AxisConfig& axis, uint64_t index);

}  // namespace drivegw::server
