// CiA 402 power state machine (CiA 402-2 state diagram; stober-motion.md §7.2, issue 5).
#include "sim/stober/cia402.h"

namespace drivegw::sim::stober {
namespace {

enum class Command {
  kNone,
  kShutdown,
  kSwitchOn,  // also "disable operation" in Operation enabled
  kEnableOperation,
  kDisableVoltage,
  kQuickStop,
};

// Device control commands; bit 7 (fault reset) and bits 4-15 do not take part (CiA 402).
Command Decode(uint16_t word) {
  if ((word & cw::kEnableVoltage) == 0) return Command::kDisableVoltage;  // xxxx xx0x
  if ((word & cw::kQuickStop) == 0) return Command::kQuickStop;           // xxxx x01x
  if ((word & cw::kSwitchOn) == 0) return Command::kShutdown;             // xxxx x110
  if ((word & cw::kEnableOperation) == 0) return Command::kSwitchOn;      // xxxx 0111
  return Command::kEnableOperation;                                       // xxxx 1111
}

}  // namespace

std::string_view PowerStateName(PowerState state) {
  switch (state) {
    case PowerState::kNotReadyToSwitchOn:
      return "Not ready to switch on";
    case PowerState::kSwitchOnDisabled:
      return "Switch on disabled";
    case PowerState::kReadyToSwitchOn:
      return "Ready to switch on";
    case PowerState::kSwitchedOn:
      return "Switched on";
    case PowerState::kOperationEnabled:
      return "Operation enabled";
    case PowerState::kQuickStopActive:
      return "Quick stop active";
    case PowerState::kFaultReactionActive:
      return "Fault reaction active";
    case PowerState::kFault:
      return "Fault";
  }
  return "?";
}

PowerStateMachine::PowerStateMachine(bool operation_enabled)
    : state_(operation_enabled ? PowerState::kOperationEnabled : PowerState::kNotReadyToSwitchOn) {
  if (operation_enabled) previous_control_word_ = cw::kEnableOperationWord;
}

void PowerStateMachine::RaiseFault() {
  if (state_ != PowerState::kFault) state_ = PowerState::kFaultReactionActive;  // transition 13
}

void PowerStateMachine::Step(uint16_t control_word, bool motion_stopped) {
  fault_reset_edge_ =
      (control_word & cw::kFaultReset) != 0 && (previous_control_word_ & cw::kFaultReset) == 0;
  previous_control_word_ = control_word;
  Transition(static_cast<int>(Decode(control_word)), motion_stopped);
}

void PowerStateMachine::LocalCommand(uint16_t control_word) {
  Transition(static_cast<int>(Decode(control_word)), /*motion_stopped=*/false);
}

void PowerStateMachine::Transition(int code, bool motion_stopped) {
  const auto command = static_cast<Command>(code);
  switch (state_) {
    case PowerState::kNotReadyToSwitchOn:
      state_ = PowerState::kSwitchOnDisabled;  // 1: self test done
      break;
    case PowerState::kSwitchOnDisabled:
      if (command == Command::kShutdown) state_ = PowerState::kReadyToSwitchOn;  // 2
      break;
    case PowerState::kReadyToSwitchOn:
      // 3: "switch on" and "enable operation" both contain the switch-on pattern; the enable
      // takes effect in the next cycle (4), as the state diagram has no 2-step transition.
      if (command == Command::kSwitchOn || command == Command::kEnableOperation) {
        state_ = PowerState::kSwitchedOn;
      } else if (command == Command::kDisableVoltage || command == Command::kQuickStop) {
        state_ = PowerState::kSwitchOnDisabled;  // 7
      }
      break;
    case PowerState::kSwitchedOn:
      if (command == Command::kEnableOperation) {
        state_ = PowerState::kOperationEnabled;  // 4
      } else if (command == Command::kShutdown) {
        state_ = PowerState::kReadyToSwitchOn;  // 6
      } else if (command == Command::kDisableVoltage || command == Command::kQuickStop) {
        state_ = PowerState::kSwitchOnDisabled;  // 10
      }
      break;
    case PowerState::kOperationEnabled:
      if (command == Command::kSwitchOn) {
        state_ = PowerState::kSwitchedOn;  // 5: disable operation
      } else if (command == Command::kShutdown) {
        state_ = PowerState::kReadyToSwitchOn;  // 8
      } else if (command == Command::kDisableVoltage) {
        state_ = PowerState::kSwitchOnDisabled;  // 9
      } else if (command == Command::kQuickStop) {
        state_ = PowerState::kQuickStopActive;  // 11
      }
      break;
    case PowerState::kQuickStopActive:
      // Quick stop option code 2 (decision 1143): ramp down, then Switch on disabled (12).
      if (command == Command::kDisableVoltage || motion_stopped) {
        state_ = PowerState::kSwitchOnDisabled;
      }
      break;
    case PowerState::kFaultReactionActive:
      if (motion_stopped) state_ = PowerState::kFault;  // 14
      break;
    case PowerState::kFault:
      if (fault_reset_edge_) state_ = PowerState::kSwitchOnDisabled;  // 15
      break;
  }
}

uint16_t PowerStateMachine::StatusWord(const StatusWordInputs& in) const {
  uint16_t w = 0;
  switch (state_) {  // CiA 402 status word patterns xxxx xxxx x??? ????
    case PowerState::kNotReadyToSwitchOn:
      break;  // x0xx 0000
    case PowerState::kSwitchOnDisabled:
      w = sw::kSwitchOnDisabled;
      break;                            // x1xx 0000
    case PowerState::kReadyToSwitchOn:  // x01x 0001
      w = sw::kQuickStop | sw::kReadyToSwitchOn | sw::kVoltageEnabled;
      break;
    case PowerState::kSwitchedOn:  // x01x 0011
      w = sw::kQuickStop | sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kVoltageEnabled;
      break;
    case PowerState::kOperationEnabled:  // x01x 0111
      w = sw::kQuickStop | sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled |
          sw::kVoltageEnabled;
      break;
    case PowerState::kQuickStopActive:  // x00x 0111
      w = sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled | sw::kVoltageEnabled;
      break;
    case PowerState::kFaultReactionActive:  // x0xx 1111
      w = sw::kReadyToSwitchOn | sw::kSwitchedOn | sw::kOperationEnabled | sw::kFault |
          sw::kVoltageEnabled;
      break;
    case PowerState::kFault:
      w = sw::kFault;
      break;  // x0xx 1000
  }
  w |= sw::kRemote;  // the control word is always taken from the bus (decision 1143)
  if (in.warning) w |= sw::kWarning;
  if (in.target_reached) w |= sw::kTargetReached;
  if (in.internal_limit_active) w |= sw::kInternalLimitActive;
  if (in.op_mode_bit12) w |= sw::kOpModeSpecific12;
  if (in.op_mode_bit13) w |= sw::kOpModeSpecific13;
  return w;
}

}  // namespace drivegw::sim::stober
