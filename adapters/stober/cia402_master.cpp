// CiA 402 power states after CiA 402-2 §6.2 (status word bits 0-3, 5, 6; Table 30) — the same
// decoding sim/stober/cia402.cpp encodes; I89/I90 texts after stober-motion.md §2.6 and
// decision 1145.
#include "adapters/stober/cia402_master.h"

#include "absl/strings/str_cat.h"

namespace drivegw::stober {

PowerState DecodePowerState(uint16_t sw) {
  if ((sw & 0x4F) == 0x00) return PowerState::kNotReadyToSwitchOn;
  if ((sw & 0x4F) == 0x40) return PowerState::kSwitchOnDisabled;
  if ((sw & 0x6F) == 0x21) return PowerState::kReadyToSwitchOn;
  if ((sw & 0x6F) == 0x23) return PowerState::kSwitchedOn;
  if ((sw & 0x6F) == 0x27) return PowerState::kOperationEnabled;
  if ((sw & 0x6F) == 0x07) return PowerState::kQuickStopActive;
  if ((sw & 0x4F) == 0x0F) return PowerState::kFaultReactionActive;
  if ((sw & 0x4F) == 0x08) return PowerState::kFault;
  return PowerState::kNotReadyToSwitchOn;  // undefined combination: not usable
}

const char* ToString(PowerState s) {
  switch (s) {
    case PowerState::kNotReadyToSwitchOn:
      return "not ready to switch on";
    case PowerState::kSwitchOnDisabled:
      return "switch on disabled";
    case PowerState::kReadyToSwitchOn:
      return "ready to switch on";
    case PowerState::kSwitchedOn:
      return "switched on";
    case PowerState::kOperationEnabled:
      return "operation enabled";
    case PowerState::kQuickStopActive:
      return "quick stop active";
    case PowerState::kFaultReactionActive:
      return "fault reaction active";
    case PowerState::kFault:
      return "fault";
  }
  return "?";
}

bool IsFaultState(PowerState s) {
  return s == PowerState::kFault || s == PowerState::kFaultReactionActive;
}

uint16_t NextEnableStep(PowerState from) {
  switch (from) {
    case PowerState::kSwitchOnDisabled:
    case PowerState::kNotReadyToSwitchOn:
      return control::kShutdown;
    case PowerState::kReadyToSwitchOn:
      return control::kSwitchOn;
    default:
      return control::kEnableOperation;  // switched on, quick stop active, operation enabled
  }
}

std::string PlcStateText(int s) {
  switch (s) {
    case kPlcDisabled:
      return "0: Disabled";
    case kPlcStandstill:
      return "2: Standstill";
    case kPlcDiscrete:
      return "3: Discrete motion";
    case kPlcContinuous:
      return "4: Continuous motion";
    case kPlcStopping:
      return "6: Stopping";
    case kPlcErrorStop:
      return "7: Error stop";
    case kPlcHoming:
      return "8: Homing";
    case kPlcCyclic:
      return "11: Cyclic motion";
    default:
      return absl::StrCat(s, ": unknown");
  }
}

std::string CauseText(int cause) {
  switch (cause) {
    case 0:
      return "error free";
    case 1:
      return "position outside software limits I50..I51";
    case 2:
      return "hardware limit switch active in travel direction (I441/I442)";
    case 3:
      return "travel direction blocked by permitted direction I04";
    case 4:
      return "set position outside revolution length I01";
    case 5:
      return "zero profile value (velocity I404, acceleration I405, deceleration I406 or "
             "jerk I407 = 0)";
    case 6:
      return "zero maximum value (maximum acceleration I11 or maximum jerk I16 = 0)";
    case 7:
      return "axis not referenced (I86 = 0)";
    case 8:
      return "MC_Home needs standstill (I89 = 2)";
    case 9:
      return "referencing type inactive (I30 = 0, A586 = 0)";
    case 10:
      return "MC_Stop active: commands are denied until it released";
    case 11:
      return "limit switch fault";
    case 12:
      return "event 78 position limit cyclic";
    case 13:
      return "axis not enabled (CiA 402 state is not operation enabled)";
    case 14:
      return "error stop active (I89 = 7): fault reset required";
    case 15:
      return "zero pulse not found within the index search distance I37";
    default:
      return absl::StrCat("cause ", cause, " (not documented, G-06)");
  }
}

bool IsMotionPlcState(int s) {
  return s == kPlcDiscrete || s == kPlcContinuous || s == kPlcStopping || s == kPlcCyclic;
}

DriveState MapState(const MotionStatus& status) {
  const PowerState p = DecodePowerState(status.status_word);
  if (IsFaultState(p)) return DriveState::kFault;
  if (p == PowerState::kQuickStopActive) {
    // Still ramping unless I199 says standstill (a drive may stay in quick stop active at rest).
    return (status.flags & status_bit::kStandstill) != 0 ? DriveState::kDisabled
                                                         : DriveState::kMoving;
  }
  if (p != PowerState::kOperationEnabled) return DriveState::kDisabled;
  if (status.plc_state == kPlcErrorStop) return DriveState::kFault;
  if (status.plc_state == kPlcHoming) return DriveState::kHoming;
  if (IsMotionPlcState(status.plc_state)) return DriveState::kMoving;
  return DriveState::kEnabled;
}

const char* CommandName(uint8_t command) {
  static constexpr const char* kNames[] = {
      "MC_DoNothing",    "MC_MoveAbsolute",  "MC_MoveRelative",   "MC_MoveAdditive",
      "MC_MoveVelocity", "MC_Stop",          "MC_Home",           "MC_CyclicSpeed",
      "MC_MoveSpeed",    "MC_TorqueControl", "MC_CyclicPosition", "MC_Halt"};
  return command < 12 ? kNames[command] : "MC_?";
}

bool IsCyclicCommand(uint8_t command) {
  return command == mc::kCyclicSpeed || command == mc::kTorqueControl ||
         command == mc::kCyclicPosition;
}

CommandState Evaluate(CommandProgress& progress, const MotionStatus& status) {
  if (!status.done() && !status.error()) progress.reset_seen = true;
  if (progress.reset_seen && status.error()) return CommandState::kError;
  const bool cyclic = IsCyclicCommand(progress.command);
  if (progress.reset_seen && status.done() && !cyclic) return CommandState::kDone;
  if (status.command_state() != 0 || IsMotionPlcState(status.plc_state) ||
      status.plc_state == kPlcHoming || (cyclic && progress.reset_seen && status.done())) {
    progress.active_seen = true;
  }
  return progress.active_seen ? CommandState::kActive : CommandState::kBusy;
}

}  // namespace drivegw::stober
