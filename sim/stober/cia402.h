// CiA 402 power state machine of the simulated STOBER axis: control word A515 (6040h) in,
// status word A516 (6041h) out. Pure: evaluated once per motion-core cycle by MotionCore.
// Transition numbers are those of CiA 402-2; choices the reference leaves open are decisions
// 1143-1144 (quick stop option, fault reset, bit 4 voltage enabled).
#pragma once

#include <cstdint>
#include <string_view>

namespace drivegw::sim::stober {

enum class PowerState {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};
std::string_view PowerStateName(PowerState state);

// Control word bits (CiA 402; bit 4 = Execute, bit 6 = relative, stober-motion.md §5.1 A515).
namespace cw {
inline constexpr uint16_t kSwitchOn = 1u << 0;
inline constexpr uint16_t kEnableVoltage = 1u << 1;
inline constexpr uint16_t kQuickStop = 1u << 2;  // active low
inline constexpr uint16_t kEnableOperation = 1u << 3;
inline constexpr uint16_t kExecute = 1u << 4;
inline constexpr uint16_t kRelative = 1u << 6;
inline constexpr uint16_t kFaultReset = 1u << 7;
inline constexpr uint16_t kHalt = 1u << 8;
// Device control commands (CiA 402 table "device control commands"), as whole words.
inline constexpr uint16_t kShutdownWord = 0x06;
inline constexpr uint16_t kSwitchOnWord = 0x07;
inline constexpr uint16_t kEnableOperationWord = 0x0F;
inline constexpr uint16_t kDisableVoltageWord = 0x00;
inline constexpr uint16_t kQuickStopWord = 0x02;
inline constexpr uint16_t kDisableOperationWord = 0x07;
inline constexpr uint16_t kFaultResetWord = 0x80;
}  // namespace cw

// Status word bits (CiA 402).
namespace sw {
inline constexpr uint16_t kReadyToSwitchOn = 1u << 0;
inline constexpr uint16_t kSwitchedOn = 1u << 1;
inline constexpr uint16_t kOperationEnabled = 1u << 2;
inline constexpr uint16_t kFault = 1u << 3;
inline constexpr uint16_t kVoltageEnabled = 1u << 4;
inline constexpr uint16_t kQuickStop = 1u << 5;  // 0 = quick stop active
inline constexpr uint16_t kSwitchOnDisabled = 1u << 6;
inline constexpr uint16_t kWarning = 1u << 7;
inline constexpr uint16_t kRemote = 1u << 9;
inline constexpr uint16_t kTargetReached = 1u << 10;
inline constexpr uint16_t kInternalLimitActive = 1u << 11;
inline constexpr uint16_t kOpModeSpecific12 = 1u << 12;
inline constexpr uint16_t kOpModeSpecific13 = 1u << 13;
}  // namespace sw

// What the motion core contributes to the status word besides the state bits.
struct StatusWordInputs {
  bool warning = false;
  bool target_reached = false;
  bool internal_limit_active = false;
  bool op_mode_bit12 = false;
  bool op_mode_bit13 = false;
};

class PowerStateMachine {
 public:
  // A new machine is "Not ready to switch on"; the first Step() finishes the self test
  // (transition 1). `operation_enabled` starts it in Operation enabled instead (test fixtures
  // F-LIN/F-END/F-CYC: "at rest, I89 = 2").
  explicit PowerStateMachine(bool operation_enabled = false);

  // Evaluates `control_word` once (one motion-core cycle). `motion_stopped` tells whether the
  // quick-stop / fault-reaction ramp has finished (transitions 12 and 14).
  void Step(uint16_t control_word, bool motion_stopped);
  // A fault from any state: Fault reaction active (transition 13), then Fault once stopped.
  void RaiseFault();
  // A device control command the drive gives itself (6007h abort connection option, decision
  // 1483): `control_word` (kQuickStopWord, kDisableVoltageWord) takes the transition it would
  // take from the bus, now; the bus's next control word is evaluated from the new state.
  void LocalCommand(uint16_t control_word);

  PowerState state() const { return state_; }
  // The motion core may run commands only in Operation enabled.
  bool operation_enabled() const { return state_ == PowerState::kOperationEnabled; }
  // The drive must ramp down with the quick-stop deceleration (Quick stop active, Fault reaction).
  bool stopping() const {
    return state_ == PowerState::kQuickStopActive || state_ == PowerState::kFaultReactionActive;
  }
  // The power stage is on (operation enabled or ramping down on it).
  bool power_stage_on() const { return operation_enabled() || stopping(); }
  // True in the Step() that saw a rising edge of control-word bit 7.
  bool fault_reset_edge() const { return fault_reset_edge_; }

  uint16_t StatusWord(const StatusWordInputs& inputs) const;

 private:
  void Transition(int command, bool motion_stopped);

  PowerState state_;
  uint16_t previous_control_word_ = 0;
  bool fault_reset_edge_ = false;
};

}  // namespace drivegw::sim::stober
