// STOBER native command validation (stober-motion.md §1.1, §2.1, §3; decision 1103 for the SDO
// size limit).
#include "server/core/validation_stober.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

// I401 "Command": 0 MC_DoNothing .. 11 MC_Halt (stober-motion.md §1.1, L118-129).
constexpr int kMaxStoberCommand = 11;
// I411 movement direction: 0 optimized, 1 positive, 2 negative, 3 keep (§3.2, L263-271).
constexpr uint32_t kMaxDirection = 3;
// I409 Command Mode: 0 aborting, 1 buffered (§2.5 L228-245; decision 1162).
constexpr uint32_t kMaxCommandMode = 1;
// I429 is UNSIGNED32 in 0.001 u/s (adapters/stober/object_map.cpp, decision 1172).
constexpr double kMaxEndVelocity = 4294967.295;

// Commands that can be a buffered (subsequent) block: 1-5, 8, 11 (§2.7 L292).
bool Bufferable(int command) {
  return (command >= 1 && command <= 5) || command == 8 || command == 11;
}
// The largest download the SDO client accepts (kSdoDefaultMaxSize, decision 1103).
constexpr size_t kMaxSdoBytes = 65536;

absl::Status CheckFinite(const char* field, double v) {
  if (std::isfinite(v)) return absl::OkStatus();
  return FieldError(field, absl::StrCat(v, " is not a finite number"));
}

}  // namespace

absl::StatusOr<NativeRequest> ValidateStober(const v1::StoberMotionCommand& c) {
  // Proto3 enums are open: a client may send any number, the drive knows only 0..11.
  const int command = static_cast<int>(c.command());
  if (command < 0 || command > kMaxStoberCommand) {
    return FieldError("stober.command", absl::StrCat(command,
                                                     " is not a motion-core command 0..11 (I401, "
                                                     "stober-motion.md §1.1)"));
  }
  const std::pair<const char*, double> values[] = {
      {"stober.position_mm", c.position_mm()},
      {"stober.velocity_mm_s", c.velocity_mm_s()},
      {"stober.acceleration_mm_s2", c.acceleration_mm_s2()},
      {"stober.deceleration_mm_s2", c.deceleration_mm_s2()},
      {"stober.jerk_mm_s3", c.jerk_mm_s3()},
      {"stober.torque_percent", c.torque_percent()},
      {"stober.end_velocity_mm_s", c.end_velocity_mm_s()},
  };
  for (const auto& [field, v] : values) {
    if (auto s = CheckFinite(field, v); !s.ok()) return s;
  }
  if (c.direction() > kMaxDirection) {
    return FieldError("stober.direction",
                      absl::StrCat(c.direction(),
                                   " exceeds 3 (I411: 0 optimized, 1 positive, 2 negative, 3 keep; "
                                   "stober-motion.md §3.2)"));
  }
  // I400 is a 32-bit signed object (adapters/stober/object_map.cpp, decision 1172).
  if (c.motion_id() > static_cast<uint32_t>(std::numeric_limits<int32_t>::max())) {
    return FieldError("stober.motion_id",
                      absl::StrCat(c.motion_id(), " exceeds 2147483647 (I400 is 32-bit signed)"));
  }
  if (c.command_mode() > kMaxCommandMode) {
    return FieldError("stober.command_mode",
                      absl::StrCat(c.command_mode(),
                                   " exceeds 1 (I409: 0 aborting, 1 buffered; stober-motion.md "
                                   "§2.5)"));
  }
  if (c.command_mode() == 1 && !Bufferable(command)) {
    return FieldError("stober.command_mode",
                      absl::StrCat("1 (buffered) applies to commands 1-5, 8, 11, not ", command,
                                   " (stober-motion.md §2.7)"));
  }
  if (c.end_velocity_mm_s() < 0 || c.end_velocity_mm_s() > kMaxEndVelocity) {
    return FieldError("stober.end_velocity_mm_s",
                      absl::StrCat(c.end_velocity_mm_s(),
                                   " outside 0..4294967.295 (I429 is a speed, the sign is the "
                                   "travel direction)"));
  }
  if (c.end_velocity_mm_s() != 0 && (command < 1 || command > 3)) {
    return FieldError("stober.end_velocity_mm_s",
                      absl::StrCat("applies to MoveAbsolute/Relative/Additive (1-3) only, not ",
                                   command, " (I429, stober-motion.md §3.2)"));
  }
  StoberMcRequest out;
  out.command = static_cast<uint8_t>(command);
  out.position_mm = c.position_mm();
  out.velocity_mm_s = c.velocity_mm_s();
  out.acceleration_mm_s2 = c.acceleration_mm_s2();
  out.deceleration_mm_s2 = c.deceleration_mm_s2();
  out.jerk_mm_s3 = c.jerk_mm_s3();
  out.direction = static_cast<int>(c.direction());
  out.torque_percent = c.torque_percent();
  out.motion_id = c.motion_id();
  out.command_mode = static_cast<uint8_t>(c.command_mode());
  out.end_velocity_mm_s = c.end_velocity_mm_s();
  return out;
}

absl::StatusOr<NativeRequest> ValidateCanOpenSdo(const v1::CanOpenSdo& c) {
  if (c.index() > 0xFFFF) {
    return FieldError("canopen_sdo.index",
                      absl::StrCat(c.index(), " exceeds 65535 (a 16-bit object index, CiA 301)"));
  }
  if (c.sub_index() > 0xFF) {
    return FieldError("canopen_sdo.sub_index",
                      absl::StrCat(c.sub_index(), " exceeds 255 (an 8-bit subindex, CiA 301)"));
  }
  const size_t n = c.data().size();
  if (c.write()) {
    if (n == 0) {
      return FieldError("canopen_sdo.data", "is empty; a download (write) carries 1..65536 bytes");
    }
    if (n > kMaxSdoBytes) {
      return FieldError("canopen_sdo.data",
                        absl::StrCat(n, " bytes exceed 65536 (the SDO size limit, decision 1103)"));
    }
  } else if (n != 0) {
    return FieldError(
        "canopen_sdo.data",
        absl::StrCat(n, " bytes given for an upload (write false); leave data empty"));
  }
  CanOpenSdoRequest out;
  out.index = static_cast<uint16_t>(c.index());
  out.sub_index = static_cast<uint8_t>(c.sub_index());
  out.write = c.write();
  out.data.assign(c.data().begin(), c.data().end());
  return out;
}

}  // namespace drivegw::server
