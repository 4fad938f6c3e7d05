// Request validation against the drive's configured axis: the one place where API values are
// checked, so gRPC and REST callers get the same field-named errors.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/command.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/drive.pb.h"

namespace drivegw::server {

// Each returns the command in physical units with defaults applied (deceleration 0 → the
// acceleration; stop deceleration 0 → the axis' max acceleration), or a FieldError naming
// the request field and the limit (InvalidArgument for never-valid values, OutOfRange beyond
// the configured axis).
absl::StatusOr<MotionCommand> ValidateMoveAbsolute(const v1::MoveAbsoluteRequest& r,
                                                   const AxisConfig& axis);
absl::StatusOr<MotionCommand> ValidateMoveRelative(const v1::MoveRelativeRequest& r,
                                                   const AxisConfig& axis,
                                                   double demand_position_mm);
absl::StatusOr<MotionCommand> ValidateMoveVelocity(const v1::MoveVelocityRequest& r,
                                                   const AxisConfig& axis);
absl::StatusOr<MotionCommand> ValidateStop(const v1::StopRequest& r, const AxisConfig& axis);
absl::StatusOr<NativeRequest> ValidateNative(const v1::SendNativeCommandRequest& r);
// The native command must be one of the drive's own family (FieldError naming the oneof field).
absl::Status ValidateNativeFamily(const v1::SendNativeCommandRequest& r, const std::string& family);
// A command that needs a particular transport of its drive (trinamic_tunnel: CAN only);
// FailedPrecondition naming the oneof field.
absl::Status ValidateNativeTransport(const v1::SendNativeCommandRequest& r,
                                     const DriveConfig& config);

// Coordinated move: at least two targets (checked before the drives are looked up).
absl::Status ValidateCoordinatedTargetCount(const v1::MoveCoordinatedRequest& r);
// Positions against each target's axis, velocity and acceleration against EVERY target's axis
// (which one has the longest path depends on where the axes stand when the move starts).
// `axes[i]` is the axis of r.targets(i).
absl::StatusOr<CoordinatedMove> ValidateMoveCoordinated(const v1::MoveCoordinatedRequest& r,
                                                        const std::vector<AxisConfig>& axes);
absl::Status ValidateParameterId(const char* request, const std::string& family,
                                 uint32_t parameter_id);

}  // namespace drivegw::server
