// NMT node control and error control (CiA 301 v4.2.0 §7.2.8.3.1, §7.2.8.3.2, Figure 48).
#include "adapters/canopen/nmt.h"

#include <array>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"

namespace drivegw::canopen {
namespace {

constexpr uint16_t kNmtCobId = 0x000;
constexpr uint16_t kErrorControlBase = 0x700;
constexpr uint8_t kToggleBit = 0x80;

bool IsNmtCommand(uint8_t b) {
  return b == 0x01 || b == 0x02 || b == 0x80 || b == 0x81 || b == 0x82;
}
bool IsNmtState(uint8_t b) { return b == 0x00 || b == 0x04 || b == 0x05 || b == 0x7F; }

absl::Status CheckDataFrame(const transport::CanFrame& frame, std::string_view what) {
  if (frame.extended || frame.rtr || frame.error) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen ", std::string(what),
                     ": needs a base-format data frame (no RTR, extended, error)"));
  }
  return absl::OkStatus();
}

}  // namespace

std::string_view NmtCommandName(NmtCommand command) {
  switch (command) {
    case NmtCommand::kStart:
      return "start";
    case NmtCommand::kStop:
      return "stop";
    case NmtCommand::kEnterPreOperational:
      return "enter_pre_operational";
    case NmtCommand::kResetNode:
      return "reset_node";
    case NmtCommand::kResetCommunication:
      return "reset_communication";
  }
  return "unknown";
}

absl::StatusOr<transport::CanFrame> EncodeNmt(const NmtMessage& message) {
  if (!IsNmtCommand(static_cast<uint8_t>(message.command))) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "canopen nmt.command: 0x%02X is no NMT command specifier (01h 02h 80h 81h 82h)",
        static_cast<uint8_t>(message.command)));
  }
  if (message.node > kMaxNodeId) {
    return absl::InvalidArgumentError(absl::StrCat("canopen nmt.node_id: ", message.node,
                                                   " exceeds ", kMaxNodeId, " (0 = all nodes)"));
  }
  const std::array<uint8_t, 2> bytes = {static_cast<uint8_t>(message.command), message.node};
  return transport::MakeCanFrame(kNmtCobId, bytes);
}

absl::StatusOr<NmtMessage> DecodeNmt(const transport::CanFrame& frame) {
  if (auto s = CheckDataFrame(frame, "nmt"); !s.ok()) return s;
  if (frame.id != kNmtCobId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen nmt: cob id 0x%03X is not 0x000", frame.id));
  }
  if (frame.dlc != 2) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen nmt.dlc: ", frame.dlc, " bytes, need 2"));
  }
  if (!IsNmtCommand(frame.data[0])) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "canopen nmt.command: 0x%02X is no NMT command specifier (01h 02h 80h 81h 82h)",
        frame.data[0]));
  }
  if (frame.data[1] > kMaxNodeId) {
    return absl::InvalidArgumentError(absl::StrCat("canopen nmt.node_id: ", frame.data[1],
                                                   " exceeds ", kMaxNodeId, " (0 = all nodes)"));
  }
  return NmtMessage{static_cast<NmtCommand>(frame.data[0]), frame.data[1]};
}

std::string_view NmtStateName(NmtState state) {
  switch (state) {
    case NmtState::kBootUp:
      return "boot_up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre_operational";
  }
  return "unknown";
}

NmtState NmtStateAfter(NmtState state, NmtCommand command) {
  // Figure 48: start/stop/enter pre-operational are accepted in every state after
  // initialisation; both resets pass through initialisation (boot-up) to pre-operational.
  switch (command) {
    case NmtCommand::kStart:
      return NmtState::kOperational;
    case NmtCommand::kStop:
      return NmtState::kStopped;
    case NmtCommand::kEnterPreOperational:
      return NmtState::kPreOperational;
    case NmtCommand::kResetNode:
    case NmtCommand::kResetCommunication:
      return NmtState::kPreOperational;
  }
  return state;
}

absl::StatusOr<transport::CanFrame> EncodeErrorControl(const ErrorControl& message) {
  if (auto s = ValidateNodeId(message.node, "heartbeat.node_id"); !s.ok()) return s;
  if (!IsNmtState(static_cast<uint8_t>(message.state))) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen heartbeat.state: 0x%02X is no NMT state (00h 04h 05h 7Fh)",
                        static_cast<uint8_t>(message.state)));
  }
  if (message.state == NmtState::kBootUp && message.toggle) {
    return absl::InvalidArgumentError("canopen heartbeat.toggle: the boot-up message is 00h");
  }
  const std::array<uint8_t, 1> bytes = {static_cast<uint8_t>(static_cast<uint8_t>(message.state) |
                                                             (message.toggle ? kToggleBit : 0))};
  return transport::MakeCanFrame(kErrorControlBase + message.node, bytes);
}

absl::StatusOr<ErrorControl> DecodeErrorControl(const transport::CanFrame& frame) {
  if (auto s = CheckDataFrame(frame, "heartbeat"); !s.ok()) return s;
  if (frame.id <= kErrorControlBase || frame.id > kErrorControlBase + kMaxNodeId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen heartbeat: cob id 0x%03X outside 0x701..0x77F", frame.id));
  }
  if (frame.dlc != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen heartbeat.dlc: ", frame.dlc, " bytes, need 1"));
  }
  const uint8_t state = frame.data[0] & 0x7F;
  if (!IsNmtState(state)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "canopen heartbeat.state: 0x%02X is no NMT state (00h 04h 05h 7Fh)", state));
  }
  ErrorControl out;
  out.node = static_cast<uint8_t>(frame.id - kErrorControlBase);
  out.state = static_cast<NmtState>(state);
  out.toggle = (frame.data[0] & kToggleBit) != 0 && state != 0;
  return out;
}

absl::StatusOr<transport::CanFrame> NodeGuardRequest(uint8_t node) {
  if (auto s = ValidateNodeId(node, "node_guard.node_id"); !s.ok()) return s;
  return transport::MakeCanRtrFrame(kErrorControlBase + node, 1);
}

}  // namespace drivegw::canopen
