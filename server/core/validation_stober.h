// Range checks of the STOBER native commands (motion-core command, raw CANopen SDO) before they
// reach the family; each refusal is a BadRequest field violation naming the field and the limit.
#pragma once

#include "absl/status/statusor.h"
#include "adapters/core/command.h"
#include "drivegw/v1/drive.pb.h"

namespace drivegw::server {

// Command 0..11 (I401), every value finite, direction 0..3 (I411), motion_id a 32-bit signed
// I400, command_mode 0..1 (I409; 1 only for 1-5, 8, 11), end_velocity_mm_s 0..4294967.295
// (I429; non-zero only for 1-3). Field paths "stober.<field>".
absl::StatusOr<NativeRequest> ValidateStober(const v1::StoberMotionCommand& c);
// index 0..65535, sub_index 0..255; a download (write) carries 1..65536 bytes, an upload none.
// Field paths "canopen_sdo.<field>".
absl::StatusOr<NativeRequest> ValidateCanOpenSdo(const v1::CanOpenSdo& c);

}  // namespace drivegw::server
