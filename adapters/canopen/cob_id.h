// CANopen identifiers: the CiA 301 predefined connection set (function code << 7 | node id), node
// id limits and the classification of an 11-bit CAN identifier. Pure (no I/O).
// Source: CiA 301 v4.2.0 §7.3.3 "Pre-defined connection set" (Table 71/72: broadcast objects NMT
// 000h, SYNC 080h, TIME 100h; peer-to-peer objects EMCY 080h+n, PDO 180h..500h+n, SDO 580h/600h+n,
// NMT error control 700h+n) and §7.2.8.1 (node id 1..127).
#pragma once

#include <cstdint>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::canopen {

// CiA 301 §7.2.8.1: node ids 1..127; 0 addresses all nodes in NMT commands only.
inline constexpr uint8_t kMinNodeId = 1;
inline constexpr uint8_t kMaxNodeId = 127;
inline constexpr uint16_t kMaxCobId = 0x7FF;  // 11-bit base frame identifiers only

// Communication objects of the predefined connection set.
enum class Function : uint8_t {
  kNmt,              // 000h, broadcast
  kSync,             // 080h, broadcast
  kEmcy,             // 080h + n
  kTime,             // 100h, broadcast
  kTpdo1,            // 180h + n (node → master)
  kRpdo1,            // 200h + n (master → node)
  kTpdo2,            // 280h + n
  kRpdo2,            // 300h + n
  kTpdo3,            // 380h + n
  kRpdo3,            // 400h + n
  kTpdo4,            // 480h + n
  kRpdo4,            // 500h + n
  kSdoTx,            // 580h + n, server → client (the node's answers)
  kSdoRx,            // 600h + n, client → server (requests to the node)
  kNmtErrorControl,  // 700h + n, heartbeat / boot-up / node guarding
};

// "nmt", "sync", "emcy", "time", "tpdo1".., "rpdo1".., "sdo_tx", "sdo_rx", "nmt_error_control".
std::string_view FunctionName(Function function);
// The identifier base (function code << 7): 000h, 080h, 080h, 100h, 180h, 200h, ... 700h.
uint16_t FunctionBase(Function function);
// True for NMT, SYNC and TIME, whose identifiers carry no node id.
bool IsBroadcast(Function function);

// OK for 1..127; otherwise InvalidArgument "canopen <field>: 0 outside 1..127".
absl::Status ValidateNodeId(uint8_t node, std::string_view field = "node_id");

// The identifier of `function` for `node`. Broadcast functions need node 0 and return the fixed
// identifier; the others need 1..127 ("canopen emcy.node_id: 128 outside 1..127").
absl::StatusOr<uint16_t> CobId(Function function, uint8_t node);

struct CobIdClass {
  Function function = Function::kNmt;
  uint8_t node = 0;  // 0 for broadcast functions
  friend constexpr bool operator==(CobIdClass, CobIdClass) = default;
};

// Classifies an 11-bit identifier. InvalidArgument above 7FFh ("exceeds 0x7FF"); NotFound for
// identifiers outside the predefined set (e.g. 101h..17Fh, 180h with node 0, 680h..6FFh,
// 780h..7FFh: "canopen cob id 0x680: not in the CiA 301 predefined connection set").
absl::StatusOr<CobIdClass> ClassifyCobId(uint32_t id);

}  // namespace drivegw::canopen
