// Main state machine rules: linmot-mc.md §2.3 transitions T1-T29 with decisions D-03..D-08.
#include "sim/linmot/state_machine.h"

#include "adapters/linmot/mc/control_word.h"

namespace drivegw::sim::linmot {

using mc::MainState;

void SmEffects::Merge(const SmEffects& o) {
  power_on = power_on || o.power_on;
  power_off = power_off || o.power_off;
  stop_setpoints = stop_setpoints || o.stop_setpoints;
  quick_stop = quick_stop || o.quick_stop;
  clear_motion = clear_motion || o.clear_motion;
  freeze = freeze || o.freeze;
  resume = resume || o.resume;
  start_homing = start_homing || o.start_homing;
  cancel_homing = cancel_homing || o.cancel_homing;
  start_procedure = start_procedure || o.start_procedure;
  cancel_procedure = cancel_procedure || o.cancel_procedure;
  if (o.log_error != 0) log_error = o.log_error;
}

StateMachine::StateMachine(Duration hw_test_time) : hw_test_time_(hw_test_time) {}

void StateMachine::PowerUp() {
  state_ = MainState::kNotReadyToSwitchOn;
  control_word_ = 0;
  control_word_seen_ = false;
  hw_test_elapsed_ = Duration{0};
  error_code_ = 0;
  fatal_ = false;
  off3_stopping_ = false;
  procedure_finished_ = false;
}

bool StateMachine::Powered(MainState s) {
  // §2.2: state 5 runs the tests *before* the power stage is switched on; 6 and above hold the
  // position (14 until its quick stop ends).
  const auto n = static_cast<uint8_t>(s);
  return n >= static_cast<uint8_t>(MainState::kReadyToOperate);
}

bool StateMachine::Procedure(MainState s) {
  return s == MainState::kHoming || s == MainState::kGoingToInitialPosition ||
         s == MainState::kGoingToPosition || s == MainState::kJoggingPlus ||
         s == MainState::kJoggingMinus;
}

bool StateMachine::error_active() const {
  return state_ == MainState::kSetupError || state_ == MainState::kError ||
         state_ == MainState::kErrorBehaviourQuickStop;
}

uint8_t StateMachine::sub_state() const {
  switch (state_) {
    case MainState::kSetupError:
    case MainState::kError:
      // §2.6: the logged error code (every §10 code is <= 00FFh).
      return static_cast<uint8_t>(error_code_ & 0xFF);
    case MainState::kHoming:
    case MainState::kGoingToInitialPosition:
    case MainState::kGoingToPosition:
      return procedure_finished_ ? mc::kSubStateFinished : 0;
    case MainState::kJoggingPlus:
    case MainState::kJoggingMinus:
      return procedure_finished_ ? mc::kSubStateFinished : mc::kSubStateJogMoving;
    default:
      return 0;
  }
}

void StateMachine::Go(MainState to, SmEffects& fx) {
  const MainState from = state_;
  if (from == to) return;
  if (Procedure(from) && !procedure_finished_) {
    // D-06: leaving before completion stops the procedure (quick stop); homing leaves Homed = 0.
    (from == MainState::kHoming ? fx.cancel_homing : fx.cancel_procedure) = true;
  }
  if (Powered(from) && !Powered(to)) fx.power_off = true;
  if (!Powered(from) && Powered(to)) fx.power_on = true;
  if (to == MainState::kHwTests) hw_test_elapsed_ = Duration{0};
  if (Procedure(to)) {
    procedure_finished_ = false;
    (to == MainState::kHoming ? fx.start_homing : fx.start_procedure) = true;
  }
  if (!Powered(to)) off3_stopping_ = false;
  state_ = to;
}

SmEffects StateMachine::SetControlWord(uint16_t control_word, const SmInputs& in) {
  const uint16_t rising = static_cast<uint16_t>(control_word & ~control_word_);
  control_word_ = control_word;
  control_word_seen_ = true;
  return Evaluate(rising, in);
}

SmEffects StateMachine::Tick(Duration dt, const SmInputs& in) {
  if (state_ == MainState::kHwTests) hw_test_elapsed_ += dt;
  return Evaluate(0, in);
}

SmEffects StateMachine::Evaluate(uint16_t rising_edges, const SmInputs& in) {
  SmEffects fx;
  // Cascade (0 -> 1 -> 2 ...); an edge is consumed by the first step that sees it. Bounded:
  // no rule cycle is longer than a few states.
  for (int i = 0; i < 8; ++i) {
    if (!Step(rising_edges, in, fx)) break;
    rising_edges = 0;
  }
  return fx;
}

bool StateMachine::Step(uint16_t rising, const SmInputs& in, SmEffects& fx) {
  const uint16_t cw = control_word_;
  const bool switch_on = cw & mc::kSwitchOn;
  const bool voltage = cw & mc::kVoltageEnable;
  const bool no_quick_stop = cw & mc::kQuickStopN;
  const bool enable_op = cw & mc::kEnableOperation;
  const bool no_abort = cw & mc::kAbortN;
  const bool no_freeze = cw & mc::kFreezeN;
  const bool home = cw & mc::kHome;
  const MainState before = state_;

  switch (state_) {
    case MainState::kNotReadyToSwitchOn:
      // T2: waits for the release of bit 0 (anti-restart, §2.5). Before any control word has
      // arrived there is nothing to release (docs/decisions/601-linmot-sim-state-machine.md).
      if (control_word_seen_ && !switch_on) Go(MainState::kSwitchOnDisabled, fx);
      break;
    case MainState::kSwitchOnDisabled:
      // T3: pattern xxxx xxxx xxxx x110.
      if (voltage && no_quick_stop && !switch_on) Go(MainState::kReadyToSwitchOn, fx);
      break;
    case MainState::kReadyToSwitchOn:
      if (!voltage || !no_quick_stop) {
        Go(MainState::kSwitchOnDisabled, fx);  // D-05 OFF2/OFF3
      } else if (switch_on) {
        Go(MainState::kHwTests, fx);  // T4
      }
      break;
    case MainState::kSetupError:
      // D-03: rests while bit 0 is 0; bit 0 = 1 -> 4 with the code logged.
      if (switch_on) {
        Go(MainState::kError, fx);
        fx.log_error = error_code_;
      }
      break;
    case MainState::kError:
      // T28 / D-04: rising edge of bit 7, not fatal, PTC warn cleared.
      if ((rising & mc::kErrorAcknowledge) && !fatal_ && !in.acknowledge_blocked) {
        error_code_ = 0;
        Go(switch_on ? MainState::kNotReadyToSwitchOn : MainState::kSwitchOnDisabled, fx);
      }
      break;
    case MainState::kErrorBehaviourQuickStop:
      // T26 / D-34: after the quick stop the motor is no longer position-controlled.
      if (!in.moving) Go(MainState::kError, fx);
      break;
    case MainState::kHwTests:
      if (!voltage || !no_quick_stop) {
        Go(MainState::kSwitchOnDisabled, fx);
      } else if (!switch_on) {
        Go(MainState::kReadyToSwitchOn, fx);
      } else if (hw_test_elapsed_ >= hw_test_time_) {
        Go(MainState::kReadyToOperate, fx);  // T5
      }
      break;
    default: {
      // States 6 ... 21 (powered). D-05 first: OFF2, OFF3, OFF1, then T9, then per state.
      if (!voltage) {
        Go(MainState::kSwitchOnDisabled, fx);
        break;
      }
      if (!no_quick_stop || off3_stopping_) {
        // D-05 OFF3: quick stop with 1721h if moving, then power off -> 1.
        if (in.moving) {
          if (!off3_stopping_) fx.quick_stop = true;
          off3_stopping_ = true;
        } else {
          Go(MainState::kSwitchOnDisabled, fx);
        }
        break;
      }
      if (!switch_on) {
        Go(MainState::kReadyToSwitchOn, fx);  // D-05 OFF1: A-stop (no brake: no state 21)
        break;
      }
      if (!enable_op) {
        if (state_ != MainState::kReadyToOperate) {
          fx.stop_setpoints = true;  // T9: set-point generation stops immediately
          Go(MainState::kReadyToOperate, fx);
        }
        break;
      }
      switch (state_) {
        case MainState::kReadyToOperate:
          Go(MainState::kOperationEnabled, fx);  // T7 (no brake configured: no state 7)
          break;
        case MainState::kOperationEnabled:
          if (!no_abort) {
            fx.quick_stop = fx.clear_motion = true;  // T13, D-38
            Go(MainState::kAborting, fx);
          } else if (!no_freeze) {
            fx.quick_stop = fx.freeze = true;  // T15
            Go(MainState::kFreezing, fx);
          } else if (home) {
            Go(MainState::kHoming, fx);  // T10
          } else if (cw & mc::kGoToPosition) {
            Go(MainState::kGoingToPosition, fx);  // T17
          } else if (cw & mc::kJogPlus) {
            Go(MainState::kJoggingPlus, fx);  // T18
          } else if (cw & mc::kJogMinus) {
            Go(MainState::kJoggingMinus, fx);
          } else if (rising & mc::kGoToInitialPosition) {
            Go(MainState::kGoingToInitialPosition, fx);  // T12: rising edge
          }
          break;
        case MainState::kHoming:
        case MainState::kGoingToInitialPosition:
        case MainState::kGoingToPosition:
        case MainState::kJoggingPlus:
        case MainState::kJoggingMinus: {
          // T22 / D-06: finished -> sub state 0Fh; back to 8 when the requesting bit is 0.
          if (in.procedure_finished) procedure_finished_ = true;
          const uint16_t request_bit = state_ == MainState::kHoming ? mc::kHome
                                       : state_ == MainState::kGoingToInitialPosition
                                           ? mc::kGoToInitialPosition
                                       : state_ == MainState::kGoingToPosition ? mc::kGoToPosition
                                       : state_ == MainState::kJoggingPlus     ? mc::kJogPlus
                                                                               : mc::kJogMinus;
          if (!no_abort) {
            fx.quick_stop = fx.clear_motion = true;
            Go(MainState::kAborting, fx);
          } else if (!(cw & request_bit)) {
            Go(MainState::kOperationEnabled, fx);
          }
          break;
        }
        case MainState::kAborting:
          if (no_abort) Go(MainState::kOperationEnabled, fx);  // T14: no resumption
          break;
        case MainState::kFreezing:
          if (!no_abort) {
            fx.clear_motion = true;
            Go(MainState::kAborting, fx);
          } else if (no_freeze) {
            fx.resume = true;  // T16: the rising edge re-activates the frozen command
            Go(MainState::kOperationEnabled, fx);
          }
          break;
        default:
          // 7, 10, 18-21 are never entered by this simulator (D-07, decision 601).
          Go(MainState::kOperationEnabled, fx);
          break;
      }
      break;
    }
  }
  return state_ != before;
}

SmEffects StateMachine::RaiseError(uint16_t code, bool fatal, bool quick_stop_first) {
  SmEffects fx;
  fx.log_error = code;
  if (error_active()) {
    // The first error stays in the state var; a fatal one still upgrades the reaction.
    if (fatal && !fatal_) {
      fatal_ = true;
      if (state_ == MainState::kErrorBehaviourQuickStop) Go(MainState::kError, fx);
    }
    return fx;
  }
  error_code_ = code;
  fatal_ = fatal;
  if (quick_stop_first && powered()) {
    fx.quick_stop = true;  // T26, D-34
    Go(MainState::kErrorBehaviourQuickStop, fx);
  } else {
    Go(MainState::kError, fx);  // T25
  }
  return fx;
}

SmEffects StateMachine::RaiseSetupError(uint16_t code, bool fatal) {
  const auto n = static_cast<uint8_t>(state_);
  if (n > static_cast<uint8_t>(MainState::kReadyToSwitchOn)) return RaiseError(code, fatal, false);
  SmEffects fx;
  error_code_ = code;
  fatal_ = fatal;
  Go(MainState::kSetupError, fx);  // D-03: logged when bit 0 takes it to 4
  return fx;
}

}  // namespace drivegw::sim::linmot
