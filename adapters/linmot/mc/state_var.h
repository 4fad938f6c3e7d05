// LinMot MC SW state var (main state + sub state) and the 22 main states (linmot-mc.md §2.1, §2.2).
#pragma once

#include <cstdint>

namespace drivegw::linmot::mc {

// Main states 0..21, linmot-mc.md §2.2 (MC22 L497-628).
enum class MainState : uint8_t {
  kNotReadyToSwitchOn = 0,
  kSwitchOnDisabled = 1,
  kReadyToSwitchOn = 2,
  kSetupError = 3,
  kError = 4,
  kHwTests = 5,
  kReadyToOperate = 6,
  kBrakeReleaseDelay = 7,
  kOperationEnabled = 8,
  kHoming = 9,
  kClearanceCheck = 10,
  kGoingToInitialPosition = 11,
  kAborting = 12,
  kFreezing = 13,
  kErrorBehaviourQuickStop = 14,
  kGoingToPosition = 15,
  kJoggingPlus = 16,
  kJoggingMinus = 17,
  kLinearizing = 18,
  kPhaseSearching = 19,
  kSpecialMode = 20,
  kBrakeSetDelay = 21,
};
inline constexpr uint8_t kMainStateCount = 22;

// The manual's name of a main state ("Operation Enabled"); "Unknown State" for >= 22.
const char* MainStateName(uint8_t main_state);
inline const char* MainStateName(MainState s) { return MainStateName(static_cast<uint8_t>(s)); }

// Sub state value meaning "procedure finished" in states 9, 10, 11, 15, 16, 17 (§2.2).
inline constexpr uint8_t kSubStateFinished = 0x0F;
// Sub state while jogging is moving (states 16/17, §2.2).
inline constexpr uint8_t kSubStateJogMoving = 0x01;

// State var: bits 15-8 main state, bits 7-0 sub state (§2.1, MC22 L489-520). In main state 8
// the sub state carries the count echo and four status copies (MC22 L564-568); in states 3/4 it
// carries the (low byte of the) error code (§2.6).
struct StateVar {
  uint8_t main_state = 0;
  uint8_t sub_state = 0;

  static constexpr uint8_t kCountMask = 0x0F;
  static constexpr uint8_t kEventHandlerActiveBit = 1u << 4;  // = status word bit 8
  static constexpr uint8_t kMotionActiveBit = 1u << 5;        // = status word bit 13
  static constexpr uint8_t kInTargetPositionBit = 1u << 6;    // = status word bit 10
  static constexpr uint8_t kHomedBit = 1u << 7;               // = status word bit 11

  static constexpr StateVar FromRaw(uint16_t raw) {
    return StateVar{static_cast<uint8_t>(raw >> 8), static_cast<uint8_t>(raw & 0xFF)};
  }
  // Main state 8 with the given echo and flags (simulators).
  static constexpr StateVar OperationEnabled(uint8_t count_echo, bool event_handler_active,
                                             bool motion_active, bool in_target_position,
                                             bool homed) {
    return StateVar{static_cast<uint8_t>(MainState::kOperationEnabled),
                    static_cast<uint8_t>((count_echo & kCountMask) |
                                         (event_handler_active ? kEventHandlerActiveBit : 0) |
                                         (motion_active ? kMotionActiveBit : 0) |
                                         (in_target_position ? kInTargetPositionBit : 0) |
                                         (homed ? kHomedBit : 0))};
  }
  constexpr uint16_t raw() const {
    return static_cast<uint16_t>((static_cast<uint16_t>(main_state) << 8) | sub_state);
  }
  constexpr MainState state() const { return static_cast<MainState>(main_state); }
  constexpr bool is(MainState s) const { return main_state == static_cast<uint8_t>(s); }
  constexpr bool operation_enabled() const { return is(MainState::kOperationEnabled); }

  // The following read the sub state as main state 8 defines it; meaningless in other states.
  constexpr uint8_t count_echo() const { return sub_state & kCountMask; }
  constexpr bool event_handler_active() const { return (sub_state & kEventHandlerActiveBit) != 0; }
  constexpr bool motion_active() const { return (sub_state & kMotionActiveBit) != 0; }
  constexpr bool in_target_position() const { return (sub_state & kInTargetPositionBit) != 0; }
  constexpr bool homed() const { return (sub_state & kHomedBit) != 0; }

  friend constexpr bool operator==(StateVar, StateVar) = default;
};

}  // namespace drivegw::linmot::mc
