// CANopen network management: NMT node control commands (COB-ID 000h) and the NMT error control
// byte of heartbeat / boot-up / node-guarding frames (700h + n). Pure (no I/O).
// Source: CiA 301 v4.2.0 §7.2.8.3.1 (NMT services: command specifiers 01h/02h/80h/81h/82h,
// node id 0 = all nodes), §7.2.8.3.2 (error control: boot-up 00h, heartbeat states 04h/05h/7Fh,
// node guarding toggle bit 7), Figure 48 (NMT slave state diagram).
#pragma once

#include <cstdint>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::canopen {

// Command specifier, byte 0 of an NMT frame (§7.2.8.3.1).
enum class NmtCommand : uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82,
};
// "start", "stop", "enter_pre_operational", "reset_node", "reset_communication", "unknown".
std::string_view NmtCommandName(NmtCommand command);

struct NmtMessage {
  NmtCommand command = NmtCommand::kStart;
  uint8_t node = 0;  // 0 = all nodes
  friend constexpr bool operator==(NmtMessage, NmtMessage) = default;
};

// COB-ID 000h, DLC 2: [command, node]. Node 0..127 ("canopen nmt.node_id: 128 exceeds 127").
absl::StatusOr<transport::CanFrame> EncodeNmt(const NmtMessage& message);
// InvalidArgument for another identifier, RTR/extended frames, DLC != 2, an unknown command
// specifier or node > 127.
absl::StatusOr<NmtMessage> DecodeNmt(const transport::CanFrame& frame);

// NMT state as reported in the error control byte (bits 6..0).
enum class NmtState : uint8_t {
  kBootUp = 0x00,  // also "initialising": the boot-up message
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};
// "boot_up", "stopped", "operational", "pre_operational", "unknown".
std::string_view NmtStateName(NmtState state);

// State of an NMT slave after `command` from `state` (Figure 48). Both resets end in the boot-up
// message and then pre-operational; the caller sends the boot-up frame in between.
NmtState NmtStateAfter(NmtState state, NmtCommand command);

// Heartbeat / boot-up / node-guarding response, COB-ID 700h + n, DLC 1.
struct ErrorControl {
  uint8_t node = 1;
  NmtState state = NmtState::kBootUp;
  bool toggle = false;  // bit 7: node guarding only; heartbeats send 0 and decoders ignore it
  friend constexpr bool operator==(ErrorControl, ErrorControl) = default;
};

// Node 1..127; boot-up frames never carry the toggle bit ("heartbeat.toggle: boot-up is 00h").
absl::StatusOr<transport::CanFrame> EncodeErrorControl(const ErrorControl& message);
// Heartbeat / boot-up: the toggle bit is masked off (§7.2.8.3.2.3); byte 00h is boot-up.
// InvalidArgument for an identifier outside 701h..77Fh, RTR, DLC != 1 or a state byte that is
// not 00h/04h/05h/7Fh ("canopen heartbeat.state: 0x03 is no NMT state").
absl::StatusOr<ErrorControl> DecodeErrorControl(const transport::CanFrame& frame);
// The node-guarding request: an RTR frame on 700h + n with DLC 1.
absl::StatusOr<transport::CanFrame> NodeGuardRequest(uint8_t node);

}  // namespace drivegw::canopen
