// The command model shared by every family: value types in physical units (mm, mm/s, mm/s²;
// degrees for rotary axes), plus the expert pass-through requests.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace drivegw {

struct MoveAbsolute {
  double position_mm = 0;
  double velocity_mm_s = 0;
  double acceleration_mm_s2 = 0;
  double deceleration_mm_s2 = 0;
};
struct MoveRelative {
  double distance_mm = 0;
  double velocity_mm_s = 0;
  double acceleration_mm_s2 = 0;
  double deceleration_mm_s2 = 0;
};
// Constant velocity towards the stroke end in the velocity's direction.
struct MoveVelocity {
  double velocity_mm_s = 0;  // signed
  double acceleration_mm_s2 = 0;
  double deceleration_mm_s2 = 0;
};
struct StopMotion {
  double deceleration_mm_s2 = 0;
};
using MotionCommand = std::variant<MoveAbsolute, MoveRelative, MoveVelocity, StopMotion>;

// Name of the command kind as the API reports it ("MoveAbsolute", ...).
std::string KindName(const MotionCommand& cmd);

// Parameter address: LinMot UPID; CANopen index << 8 | subindex for later families.
struct ParameterRef {
  uint32_t id = 0;
  bool rom = false;  // stored (ROM / non-volatile) value instead of the live (RAM) value
};

// LinMot motion command interface block (linmot-mc.md §4.1): header + up to 30 bytes.
struct LinMotMcRequest {
  uint8_t master_id = 0;
  uint8_t sub_id = 0;  // 0..15
  std::vector<uint8_t> parameters;  // bytes from offset 2, little-endian
};
// LinMot realtime-configuration command (linmot-linudp.md §3.5).
struct LinMotRtcRequest {
  uint8_t command_id = 0;
  uint16_t word2 = 0;
  uint16_t word3 = 0;
  uint16_t word4 = 0;
};
// LinMot DeviceNet general-purpose command (linmot-devicenet.md §8.1): the Addressed In slot.
struct LinMotDnRequest {
  uint16_t command = 0;  // word 1: motor select (15..12), T (7), command ID (6..0)
  int32_t value = 0;     // word 2: -32768..65535 (signed or unsigned per command)
};
using NativeRequest = std::variant<LinMotMcRequest, LinMotRtcRequest, LinMotDnRequest>;

struct NativeReply {
  uint64_t command_id = 0;  // command handle for motion commands, 0 otherwise
  uint32_t status = 0;      // RTC status byte
  uint16_t word2 = 0;
  uint16_t word3 = 0;
  uint16_t word4 = 0;
};

inline std::string KindName(const MotionCommand& cmd) {
  struct V {
    std::string operator()(const MoveAbsolute&) const { return "MoveAbsolute"; }
    std::string operator()(const MoveRelative&) const { return "MoveRelative"; }
    std::string operator()(const MoveVelocity&) const { return "MoveVelocity"; }
    std::string operator()(const StopMotion&) const { return "Stop"; }
  };
  return std::visit(V{}, cmd);
}

}  // namespace drivegw
