// The MC SW main state machine as a remote master drives it through the control word (§2, §3.1).
#pragma once

#include <cstdint>

#include "adapters/core/clock.h"
#include "adapters/linmot/mc/state_var.h"

namespace drivegw::sim::linmot {

namespace mc = ::drivegw::linmot::mc;  // as in options.h

// What the state machine needs to know about the motion side.
struct SmInputs {
  bool moving = false;  // set-point generation running or demand velocity != 0
  // The special motion of the current state (9 homing, 11, 15, 16, 17) has finished (D-06).
  bool procedure_finished = false;
  bool acknowledge_blocked = false;  // §2.6: a PTC error whose warn bit is still set
};

// What the device must do to the motion side after an evaluation. Several may be set.
struct SmEffects {
  bool power_on = false;        // entering a position-controlled state from an unpowered one
  bool power_off = false;       // OFF1/OFF2, error state: set-points end, current 0 (D-05)
  bool stop_setpoints = false;  // T9: >= 8 -> 6, set-point generation stops at once
  bool quick_stop = false;      // 12, 13, 14, OFF3: decelerate with 1721h
  bool clear_motion = false;    // /Abort: motion command and event handler cleared (D-38)
  bool freeze = false;          // 13: keep the running command for resumption
  bool resume = false;          // 13 -> 8: finish the frozen command (T16)
  bool start_homing = false;    // 8 -> 9 (T10)
  bool cancel_homing = false;   // 9 left before finished (D-06): Homed = 0
  // 8 -> 11, 15, 16, 17 (T12, T17, T18): the device starts the motion of the new state.
  bool start_procedure = false;
  bool cancel_procedure = false;  // 11, 15, 16, 17 left before finished (D-06): quick stop
  uint16_t log_error = 0;         // an error to enter in the error log (§2.6, D-03)

  void Merge(const SmEffects& o);
};

// Pure logic: no clock reads. Control word bits are evaluated on every new word (edges) and on
// every tick (levels, the 300 ms HW test); transitions cascade within one evaluation (0 -> 1 -> 2
// for 003Eh, linmot-mc.md §2.7 step 1).
class StateMachine {
 public:
  explicit StateMachine(Duration hw_test_time);

  // Power-up (T1): state 0, no error, no control word seen yet.
  void PowerUp();

  // A control word from the interface (LinUDP block or 001x). Rising edges are taken against
  // the previous word, so a word held at 1 never acknowledges again (§2.4).
  SmEffects SetControlWord(uint16_t control_word, const SmInputs& in);
  // Advances timers by `dt` and re-evaluates the level rules.
  SmEffects Tick(Duration dt, const SmInputs& in);

  // D-34: an error; `quick_stop_first` (non-fatal class while moving, powered) goes through 14.
  // While already in 3, 4 or 14 the first error stays pending (the new one is only logged).
  SmEffects RaiseError(uint16_t code, bool fatal, bool quick_stop_first);
  // D-03: a setup/configuration error while not switched on (states 0-2) -> 3; elsewhere as
  // RaiseError.
  SmEffects RaiseSetupError(uint16_t code, bool fatal);

  uint8_t main_state() const { return static_cast<uint8_t>(state_); }
  mc::MainState state() const { return state_; }
  // Sub state for every main state except 8 (whose sub state the device composes, §2.1).
  uint8_t sub_state() const;
  uint16_t error_code() const { return error_code_; }
  bool fatal() const { return fatal_; }
  // Error pending: states 3, 4 and 14 (status word bit 3).
  bool error_active() const;
  uint16_t control_word() const { return control_word_; }
  // Position controller active (states 6 ... 21, §2.2): the motor holds or follows a demand.
  bool powered() const { return Powered(state_); }
  // Set-point generation belongs to a stop (OFF3 quick stop in progress): no new commands.
  bool off3_stopping() const { return off3_stopping_; }
  bool switch_on_locked() const { return state_ == mc::MainState::kNotReadyToSwitchOn; }
  bool procedure_finished() const { return procedure_finished_; }
  // States 9, 11, 15, 16, 17: a procedure started by a control word bit (D-06, D-40).
  static bool Procedure(mc::MainState s);

  static bool Powered(mc::MainState s);

 private:
  SmEffects Evaluate(uint16_t rising_edges, const SmInputs& in);
  // One rule step; returns true if the state changed.
  bool Step(uint16_t rising_edges, const SmInputs& in, SmEffects& fx);
  void Go(mc::MainState to, SmEffects& fx);

  Duration hw_test_time_;
  mc::MainState state_ = mc::MainState::kNotReadyToSwitchOn;
  uint16_t control_word_ = 0;
  bool control_word_seen_ = false;
  Duration hw_test_elapsed_{0};
  uint16_t error_code_ = 0;
  bool fatal_ = false;
  bool off3_stopping_ = false;
  bool procedure_finished_ = false;
};

}  // namespace drivegw::sim::linmot
