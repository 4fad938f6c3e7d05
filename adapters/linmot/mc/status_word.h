// LinMot MC SW status word (drive -> master): one accessor per bit (linmot-mc.md §3.2).
#pragma once

#include <cstdint>

namespace drivegw::linmot::mc {

// linmot-mc.md §3.2 (MC22 L674-712). Bits 1, 2, 4, 5 mirror control word bits 0, 3, 1, 2 (§1).
struct StatusWord {
  uint16_t raw = 0;

  static constexpr uint16_t kOperationEnabled = 1u << 0;  // main state >= 8 (D-08)
  static constexpr uint16_t kSwitchOnActive = 1u << 1;    // mirrors CW bit 0
  static constexpr uint16_t kEnableOperation = 1u << 2;   // mirrors CW bit 3
  static constexpr uint16_t kError = 1u << 3;
  static constexpr uint16_t kVoltageEnable = 1u << 4;   // mirrors CW bit 1
  static constexpr uint16_t kQuickStopN = 1u << 5;      // mirrors CW bit 2 (1 = no quick stop)
  static constexpr uint16_t kSwitchOnLocked = 1u << 6;  // released by CW bit 0 = 0 (§2.5)
  static constexpr uint16_t kWarning = 1u << 7;         // warn word != 0
  static constexpr uint16_t kEventHandlerActive = 1u << 8;
  static constexpr uint16_t kSpecialMotionActive = 1u << 9;  // D-40
  static constexpr uint16_t kInTargetPosition = 1u << 10;
  static constexpr uint16_t kHomed = 1u << 11;
  static constexpr uint16_t kFatalError = 1u << 12;  // cannot be acknowledged
  static constexpr uint16_t kMotionActive = 1u << 13;
  static constexpr uint16_t kRangeIndicator1 = 1u << 14;
  static constexpr uint16_t kRangeIndicator2 = 1u << 15;

  constexpr bool operation_enabled() const { return (raw & kOperationEnabled) != 0; }
  constexpr bool switch_on_active() const { return (raw & kSwitchOnActive) != 0; }
  constexpr bool enable_operation() const { return (raw & kEnableOperation) != 0; }
  constexpr bool error() const { return (raw & kError) != 0; }
  constexpr bool voltage_enable() const { return (raw & kVoltageEnable) != 0; }
  constexpr bool quick_stop_n() const { return (raw & kQuickStopN) != 0; }
  constexpr bool switch_on_locked() const { return (raw & kSwitchOnLocked) != 0; }
  constexpr bool warning() const { return (raw & kWarning) != 0; }
  constexpr bool event_handler_active() const { return (raw & kEventHandlerActive) != 0; }
  constexpr bool special_motion_active() const { return (raw & kSpecialMotionActive) != 0; }
  constexpr bool in_target_position() const { return (raw & kInTargetPosition) != 0; }
  constexpr bool homed() const { return (raw & kHomed) != 0; }
  constexpr bool fatal_error() const { return (raw & kFatalError) != 0; }
  constexpr bool motion_active() const { return (raw & kMotionActive) != 0; }
  constexpr bool range_indicator_1() const { return (raw & kRangeIndicator1) != 0; }
  constexpr bool range_indicator_2() const { return (raw & kRangeIndicator2) != 0; }

  // Returns a copy with `mask` set to `on` (simulators build the word bit by bit).
  constexpr StatusWord With(uint16_t mask, bool on) const {
    return StatusWord{static_cast<uint16_t>(on ? (raw | mask) : (raw & ~mask))};
  }
  friend constexpr bool operator==(StatusWord, StatusWord) = default;
};

}  // namespace drivegw::linmot::mc
