// The command model shared by every family: value types in physical units (mm, mm/s, mm/s²;
// degrees for rotary axes), plus the expert pass-through requests.
#pragma once

#include <array>
#include <chrono>
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
// Trinamic SIXpack/QUADpack instruction (trinamic-sixpack.md §4.1) to the drive's controller: the
// opcode and the seven parameter bytes P0..P6 as on the wire. The gateway fills in the controller
// address and, for queries, its own response address; service opcodes $F2..$F7 are refused.
struct TrinamicRequest {
  uint8_t opcode = 0;
  std::array<uint8_t, 7> params{};
};
// Trinamic RS-232-over-CAN tunnel (§3.5, L307-317): bytes sent out of the controller's RS-232 port
// (CAN identifier (A << 3) + 1). CAN transport only; 1..8 bytes.
struct TrinamicTunnelRequest {
  std::vector<uint8_t> data;
};
// STOBER motion-core command (stober-motion.md §1.1, §3): command number I401 (0..11) with its set
// values in physical units, started by a rising edge of Execute I402. Unused values are ignored by
// the command (the reference's per-command tables say which it latches).
struct StoberMcRequest {
  uint8_t command = 0;            // I401: 0 DoNothing ... 11 Halt
  double position_mm = 0;         // I403 (MoveAbsolute target, MoveRelative/Additive distance)
  double velocity_mm_s = 0;       // I404
  double acceleration_mm_s2 = 0;  // I405
  double deceleration_mm_s2 = 0;  // I406
  double jerk_mm_s3 = 0;          // I407
  int direction = 0;              // I411 (endless axes: 0..3, §3.2)
  double torque_percent = 0;      // A558 / I428 (TorqueControl)
  uint32_t motion_id = 0;         // I400
  // I409 Command Mode (§2.5): 0 aborting (cancels the running block), 1 buffered (starts at the
  // end of the running block; commands 1-5, 8, 11). Decision 1162.
  uint8_t command_mode = 0;
  // I429 End velocity (§3.2 L364-373, commands 1-3): the target is passed at this speed (>= 0;
  // 0 = stop there). Decision 1161.
  double end_velocity_mm_s = 0;
};
// Raw CANopen SDO access to the drive's object dictionary (CiA 301): upload (read) or download.
struct CanOpenSdoRequest {
  uint16_t index = 0;
  uint8_t sub_index = 0;
  bool write = false;
  std::vector<uint8_t> data;  // download payload (1..64 KiB, decision 1103); empty for upload
};
using NativeRequest = std::variant<LinMotMcRequest, LinMotRtcRequest, LinMotDnRequest,
                                   TrinamicRequest, TrinamicTunnelRequest, StoberMcRequest,
                                   CanOpenSdoRequest>;

struct NativeReply {
  uint64_t command_id = 0;  // command handle for motion commands, 0 otherwise
  uint32_t status = 0;      // RTC status byte
  uint16_t word2 = 0;
  uint16_t word3 = 0;
  uint16_t word4 = 0;
  // Raw reply body where the family has one (Trinamic: CMD P0..P6, 8 bytes; empty when the
  // instruction has no reply, §2.4; CANopen SDO upload: the object's bytes).
  std::vector<uint8_t> data;
};

// Cyclic set-point streaming (STOBER MC_CyclicPosition / MC_CyclicSpeed, stober-motion.md §3.8,
// §3.11): the client supplies set points, the family forwards one per bus cycle (CANopen SYNC).
enum class CyclicMode { kPosition, kVelocity };
struct CyclicSetpoint {
  double value = 0;          // mm (kPosition) or mm/s (kVelocity)
  double velocity_mm_s = 0;  // kPosition: optional velocity feed-forward (I426), 0 = none
};
struct CyclicStats {
  uint64_t received = 0;  // set points pushed by the client
  uint64_t sent = 0;      // cycles that carried a fresh set point
  uint64_t late = 0;      // set points that arrived after their cycle had gone (dropped)
  uint64_t missing = 0;   // cycles without a fresh set point (the drive extrapolated, I423)
  std::chrono::microseconds cycle{0};
};

// Linear interpolated move of several axes of one controller (Trinamic `$26` targets + `$50`,
// trinamic-sixpack.md §4.2 `$50`, §5.5): all axes start in the same cycle and arrive together.
// Velocity and acceleration limit the axis with the longest path; the others scale down.
struct CoordinatedMove {
  std::vector<double> positions_mm;  // one target per drive of the group, in group order
  double velocity_mm_s = 0;
  double acceleration_mm_s2 = 0;
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
