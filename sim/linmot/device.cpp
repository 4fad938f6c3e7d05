// Simulated LinMot drive: ties the state machine, interpreter, parameters, RTC channel and the
// sim/motion axis together; produces every LinUDP response block (linmot-linudp.md §4).
#include "sim/linmot/device.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_format.h"
#include "adapters/core/log.h"
#include "adapters/linmot/mc/control_word.h"
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/state_var.h"
#include "adapters/linmot/mc/status_word.h"
#include "adapters/linmot/mc/warn_word.h"

namespace drivegw::sim::linmot {

using mc::MainState;
using sim::motion::Axis;
using sim::motion::Limits;
using sim::motion::StartFrom;
using sim::motion::ZeroLimits;

namespace {

// Wire units (linmot-mc.md §0.4) <-> sim/motion units (mm, mm/s, mm/s²).
constexpr double kIncPerMm = 1e4;    // 0.1 um
constexpr double kVelPerMmS = 1e3;   // 1E-6 m/s
constexpr double kAccPerMmS2 = 1e2;  // 1E-5 m/s^2

int32_t ToInc(double mm) {
  const double v = std::nearbyint(mm * kIncPerMm);
  return static_cast<int32_t>(std::clamp(v, double{std::numeric_limits<int32_t>::min()},
                                         double{std::numeric_limits<int32_t>::max()}));
}
Limits ToLimits(int64_t velocity, int64_t acceleration, int64_t deceleration) {
  return Limits{velocity / kVelPerMmS, acceleration / kAccPerMmS2, deceleration / kAccPerMmS2};
}

// D-34: errors of the power stage switch off at once, whatever their class.
bool PowerStageError(uint16_t code) {
  return code == 0x000D || (code >= 0x0018 && code <= 0x001B) ||
         (code >= 0x0028 && code <= 0x002C) || (code >= 0x0030 && code <= 0x003C);
}

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

}  // namespace

absl::StatusOr<std::unique_ptr<LinMotDevice>> LinMotDevice::Create(const SimOptions& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  auto device = std::unique_ptr<LinMotDevice>(new LinMotDevice(options));
  device->PowerUp();
  return device;
}

LinMotDevice::LinMotDevice(const SimOptions& options)
    : options_(options),
      params_(Parameters::ForOptions(options)),
      sm_(options.hw_test_time),
      interpreter_(options.product, options.force_control_key),
      rtc_(options),
      slider_mm_(options.initial_position_mm) {}

// ---------------------------------------------------------------------------------------------
// Power, boot, time.

void LinMotDevice::PowerUp() {
  // D-31: RAM := ROM. §4.3 rule 4 / A-08: remembered counts 0. D-39: not homed.
  params_.Boot();
  sm_.PowerUp();
  interpreter_.PowerUp();
  rtc_.PowerUp();
  mc_stopped_ = false;
  homed_ = !params_.Get(upid::kMotorRequiresHoming);
  homing_.reset();
  running_.reset();
  frozen_.reset();
  last_vai_.reset();
  curve_.reset();
  after_actual_.reset();
  trigger_move_.reset();
  transition_.reset();
  // The reported frame restarts equal to the physical one (decision 604).
  auto axis = Axis::Create(
      sim::motion::AxisConfig{-std::numeric_limits<double>::infinity(),
                              std::numeric_limits<double>::infinity(), options_.in_target_window_mm,
                              options_.lag_time_constant_s},
      slider_mm_);
  if (axis.ok()) axis_ = std::move(*axis);
  target_ = ToInc(axis_.target());
  RefreshVariables();
}

void LinMotDevice::StartBoot() {
  // A-11 / §4.3: the drive stops answering for the boot time, the motor is unpowered.
  booting_ = true;
  boot_left_ = options_.boot_time;
  ResyncAxisToSlider();
  log::Info(
      "linmot_sim.reboot",
      log::Fields()
          .Add("drive", options_.name)
          .Add("boot_ms",
               std::chrono::duration_cast<std::chrono::milliseconds>(options_.boot_time).count()));
}

void LinMotDevice::Advance(Duration dt) {
  if (dt <= Duration{0}) return;
  remainder_ += dt;
  while (remainder_ >= options_.tick) {
    if (Quiescent()) {
      // Nothing can change until the next telegram or hook: skip the idle ticks in one step
      // (an idle simulator must not spend seconds catching up after an hour without a master).
      const auto n = remainder_ / options_.tick;
      sim_time_ += n * options_.tick;
      remainder_ -= n * options_.tick;
      break;
    }
    remainder_ -= options_.tick;
    Tick();
  }
}

bool LinMotDevice::Quiescent() const {
  if (booting_) return false;
  if (mc_stopped_) return true;
  const MainState s = sm_.state();
  if (s == MainState::kHwTests || s == MainState::kErrorBehaviourQuickStop || sm_.off3_stopping()) {
    return false;
  }
  // Standing still with the slider exactly on the demand: no lag, no event, no limit can fire.
  return !homing_ && !after_actual_ && !axis_.motion_active() && axis_.demand().velocity == 0 &&
         axis_.actual().position == axis_.demand().position &&
         slider_mm_ == axis_.physical_position() && slider_velocity_ == 0;
}

uint64_t LinMotDevice::operating_ms() const {
  return static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::milliseconds>(sim_time_).count());
}

void LinMotDevice::Tick() {
  const Duration dt = options_.tick;
  const double dts = ToSeconds(dt);
  sim_time_ += dt;
  if (booting_) {
    boot_left_ -= dt;
    if (boot_left_ <= Duration{0}) {
      booting_ = false;
      ++boots_;
      PowerUp();
    }
    return;
  }
  if (mc_stopped_) return;

  const double previous_demand = axis_.demand().position;
  if (homing_) {
    homing_->Advance(axis_, dts);
  } else {
    if (curve_) StepCurve(dts);
    axis_.Advance(dts);
  }
  // The slider follows the axis' actual position with the motor's speed capability, unless it
  // is blocked; the mechanical stroke is a hard stop (decision 604).
  const double before = slider_mm_;
  if (sm_.powered() && !blocked_) {
    const double max_step = options_.max_velocity_mm_s * dts;
    slider_mm_ += std::clamp(axis_.physical_position() - slider_mm_, -max_step, max_step);
  }
  slider_mm_ = std::clamp(slider_mm_, options_.stroke_min_mm, options_.stroke_max_mm);
  slider_velocity_ = (slider_mm_ - before) / dts;

  if (homing_) {
    if (homing_->phase() == sim::motion::HomingPhase::kDone) {
      homed_ = true;  // D-39
      target_ = ToInc(axis_.target());
      homing_.reset();
    } else if (homing_->phase() == sim::motion::HomingPhase::kAborted) {
      log::Warn(
          "linmot_sim.homing_aborted",
          log::Fields().Add("drive", options_.name).Add("reason", homing_->status().message()));
      homing_.reset();
    }
  }
  FireEvents(previous_demand);
  Monitor();
  Apply(sm_.Tick(dt, Inputs()));
}

// ---------------------------------------------------------------------------------------------
// State machine coupling.

SmInputs LinMotDevice::Inputs() const {
  SmInputs in;
  in.moving = axis_.motion_active() || axis_.demand().velocity != 0;
  const MainState s = sm_.state();
  in.procedure_finished = s == MainState::kHoming
                              ? homed_ && !homing_
                              : StateMachine::Procedure(s) && !axis_.motion_active();
  // §2.6 / §11.3: a PTC error is acknowledged only after its warn bit has gone.
  const uint16_t code = sm_.error_code();
  const uint16_t warn = warn_word();
  in.acknowledge_blocked =
      (code == mc::kPtc1SensorTooHot && (warn & mc::WarnWord::kPtcSensor1Hot)) ||
      (code == 0x000F && (warn & mc::WarnWord::kPtcSensor2Hot));
  return in;
}

void LinMotDevice::ResyncAxisToSlider() {
  // Demand := actual = the slider, reported frame kept, no motion (power off, T9, D-05).
  const double offset = axis_.reference_offset();
  auto axis = Axis::Create(axis_.config(), slider_mm_);
  if (!axis.ok()) return;
  axis->SetPosition(slider_mm_ + offset);
  axis_ = std::move(*axis);
  slider_velocity_ = 0;
}

void LinMotDevice::Apply(const SmEffects& fx) {
  const double quick_stop = params_.Get(upid::kQuickStopDeceleration) / kAccPerMmS2;
  // §7 L1008: a curve is aborted by /Freeze (and cannot be resumed) and by every other
  // interruption of set-point generation (decision 606).
  if (fx.quick_stop || fx.stop_setpoints || fx.power_off || fx.power_on || fx.clear_motion ||
      fx.freeze || fx.resume || fx.cancel_procedure || fx.start_procedure || fx.start_homing) {
    curve_.reset();
  }
  if (fx.log_error != 0) error_log_.Add(fx.log_error, operating_ms());
  if (fx.cancel_homing) {
    // D-06: releasing bit 11 (or leaving 9 otherwise) before completion stops the procedure
    // with the quick-stop deceleration; Homed stays 0.
    if (homing_) homing_->Abort(axis_, quick_stop);
    homing_.reset();
    homed_ = false;
  }
  if (fx.freeze) {
    frozen_.reset();
    if (axis_.motion_active() && running_) frozen_ = running_;  // T15: target kept
  }
  if (fx.clear_motion) {
    // linmot-mc.md §3.1 bit 4: the motion command is cleared; D-38: event handler off.
    running_.reset();
    frozen_.reset();
    after_actual_.reset();
    trigger_move_.reset();
    transition_.reset();
  }
  if (fx.quick_stop) {
    if (axis_.Stop(quick_stop, ZeroLimits::kHoldPosition).ok()) target_ = ToInc(axis_.target());
  }
  if (fx.stop_setpoints) {
    // T9: set-point generation stops immediately, position control stays active.
    homing_.reset();
    ResyncAxisToSlider();
    running_.reset();
    after_actual_.reset();
    target_ = ToInc(axis_.target());
  }
  if (fx.power_off || fx.power_on) {
    homing_.reset();
    ResyncAxisToSlider();
    running_.reset();
    frozen_.reset();
    target_ = ToInc(axis_.target());
  }
  if (fx.power_off) {
    after_actual_.reset();
    trigger_move_.reset();
    transition_.reset();
  }
  if (fx.resume && frozen_) {
    // T16: the rising edge of /Freeze finishes the frozen command from the demand state.
    const Resumable r = *frozen_;
    frozen_.reset();
    absl::Status s =
        r.infinite
            ? axis_.Jog(r.direction * r.limits.max_velocity, r.limits, std::nullopt,
                        StartFrom::kDemand, ZeroLimits::kHoldPosition)
            : axis_.MoveTo(r.target_mm, r.limits, StartFrom::kDemand, ZeroLimits::kHoldPosition);
    if (s.ok()) running_ = r;
  }
  if (fx.cancel_procedure) {
    // D-06: go-to-position / initial position / jog released early: quick stop.
    if (axis_.Stop(quick_stop, ZeroLimits::kHoldPosition).ok()) target_ = ToInc(axis_.target());
    running_.reset();
  }
  if (fx.start_procedure) {
    // States 11, 15, 16, 17 with the project parameters of decision 601 (D-32).
    const double a = params_.Get(upid::kHomingAcceleration) / kAccPerMmS2;
    const Limits go{params_.Get(upid::kHomingVelocity) / kVelPerMmS, a, a};
    const double jog_v = params_.Get(upid::kJogVelocity) / kVelPerMmS;
    const Limits jog{jog_v, a, a};
    absl::Status s;
    switch (sm_.state()) {
      case MainState::kGoingToInitialPosition:
        s = axis_.MoveTo(params_.Get(upid::kInitialPosition) / kIncPerMm, go);
        break;
      case MainState::kGoingToPosition:
        s = axis_.MoveTo(params_.Get(upid::kGoToPositionTarget) / kIncPerMm, go);
        break;
      case MainState::kJoggingPlus:
        s = axis_.Jog(jog_v, jog, params_.Get(upid::kMaximalPosition) / kIncPerMm);
        break;
      case MainState::kJoggingMinus:
        s = axis_.Jog(-jog_v, jog, params_.Get(upid::kMinimalPosition) / kIncPerMm);
        break;
      default:
        break;
    }
    if (!s.ok()) {
      log::Warn("linmot_sim.procedure_refused",
                log::Fields().Add("drive", options_.name).Add("reason", s.message()));
    }
    target_ = ToInc(axis_.target());
    running_.reset();
  }
  if (fx.start_homing) {
    // D-39: a VAI move with the homing parameters to the configured position, which then
    // reads as Home Position 13C7h.
    homed_ = false;
    sim::motion::HomingConfig config;
    config.method = sim::motion::HomingMethod::kMoveToFeature;
    const double a = params_.Get(upid::kHomingAcceleration) / kAccPerMmS2;
    config.limits = Limits{params_.Get(upid::kHomingVelocity) / kVelPerMmS, a, a};
    config.feature_position_mm = params_.Get(upid::kHomingTargetPosition) / kIncPerMm;
    config.home_position_mm = params_.Get(upid::kHomePosition) / kIncPerMm;
    auto homing = sim::motion::Homing::Create(config);
    if (homing.ok() && homing->Start(axis_).ok()) {
      homing_ = std::move(*homing);
      running_.reset();
    } else {
      log::Warn("linmot_sim.homing_refused",
                log::Fields().Add("drive", options_.name).Add("reason", homing.status().message()));
    }
  }
}

void LinMotDevice::ApplyControlWord(uint16_t control_word) {
  Apply(sm_.SetControlWord(control_word, Inputs()));
}

// ---------------------------------------------------------------------------------------------
// Errors and monitoring.

absl::Status LinMotDevice::RaiseError(uint16_t code) {
  if (code == mc::kNoError || mc::FindErrorCode(code) == nullptr) {
    // D-33: the simulator raises only codes of the §10 table.
    return absl::InvalidArgumentError(
        absl::StrFormat("raise_error.code: 0x%04X is not in linmot-mc.md §10", code));
  }
  Raise(code);
  return absl::OkStatus();
}

void LinMotDevice::Raise(uint16_t code) {
  const mc::ErrorCode* e = mc::FindErrorCode(code);
  const bool fatal = e != nullptr && e->fatal;
  const mc::ErrorClass cls = e != nullptr ? e->error_class : mc::ErrorClass::kErr;
  log::Info("linmot_sim.error", log::Fields()
                                    .Add("drive", options_.name)
                                    .Add("code", absl::StrFormat("0x%04X", code))
                                    .Add("text", mc::ErrorText(code))
                                    .Add("state", int{sm_.main_state()}));
  if ((cls == mc::ErrorClass::kSetupErr || cls == mc::ErrorClass::kCfgErr) &&
      sm_.main_state() <= static_cast<uint8_t>(MainState::kReadyToSwitchOn)) {
    Apply(sm_.RaiseSetupError(code, fatal));  // D-03
    return;
  }
  // D-34: during motion quick stop through 14, except fatal and power-stage errors.
  const bool immediate = fatal || PowerStageError(code);
  const bool quick_stop_first = !immediate && sm_.powered() && Inputs().moving;
  Apply(sm_.RaiseError(code, fatal, quick_stop_first));
}

void LinMotDevice::Monitor() {
  if (!sm_.powered() || sm_.error_active()) return;
  // Position lag (§10 000Bh/000Ch against 1473h/1475h).
  const double lag_inc = std::abs(axis_.demand().position - actual_mm()) * kIncPerMm;
  const bool moving = axis_.motion_active();
  if (moving && lag_inc > params_.Get(upid::kPositionLagMovingMax)) {
    Raise(mc::kPosLagAlwaysTooBig);
    return;
  }
  if (!moving && lag_inc > params_.Get(upid::kPositionLagStandingMax)) {
    Raise(mc::kPosLagStandingTooBig);
    return;
  }
  // Position limits 146Eh/146Fh (0007h/0008h), checked on the demand position so that the
  // drive stops before the mechanical end: only with a valid reference (homed) and only while
  // moving further out, so that a drive outside its range can be moved back (decision 604).
  if (!homed_ || sm_.state() == MainState::kHoming) return;
  const double demand_inc = axis_.demand().position * kIncPerMm;
  const double v = axis_.demand().velocity;
  if (demand_inc < params_.Get(upid::kMinimalPosition) && v < 0) {
    Raise(mc::kMinPosUndershot);
  } else if (demand_inc > params_.Get(upid::kMaximalPosition) && v > 0) {
    Raise(mc::kMaxPosOvershot);
  }
}

// ---------------------------------------------------------------------------------------------
// Motion commands.

bool LinMotDevice::event_handler_active() const {
  return after_actual_.has_value() || trigger_move_.has_value() || transition_.has_value();
}

void LinMotDevice::StartMove(const VaiMove& m) {
  if (m.fire == Fire::kAfterActualCommand) {
    after_actual_ = m;  // §4.5: fires when set-point generation has finished (D-12)
    return;
  }
  if (m.fire == Fire::kRisingTrigger || m.fire == Fire::kFallingTrigger) {
    trigger_move_ = m;  // §4.5: re-fires on every edge until 008x
    return;
  }
  // §5.0 target computation.
  int64_t target = m.position;
  switch (m.rule) {
    case TargetRule::kAbsolute:
      break;
    case TargetRule::kIncrementDemand:
      target = ToInc(axis_.demand().position) + m.position;
      break;
    case TargetRule::kIncrementTarget:
      target = target_ + m.position;
      break;
    case TargetRule::kIncrementActual:
      target = ToInc(actual_mm()) + m.position;
      break;
    case TargetRule::kCmdTabVar1:
      target = params_.Get(upid::kCmdTabVar1);
      break;
    case TargetRule::kCmdTabVar2:
      target = params_.Get(upid::kCmdTabVar2);
      break;
    case TargetRule::kCapturedIncrement:
      target = params_.Get(upid::kCapturePosition) + m.position;
      break;
  }
  target = std::clamp<int64_t>(target, std::numeric_limits<int32_t>::min(),
                               std::numeric_limits<int32_t>::max());
  const Limits limits = ToLimits(m.velocity, m.acceleration, m.deceleration);
  curve_.reset();  // a new motion command aborts a running curve (decision 606)
  // D-42: zero limits hold the position with Motion Active = 1 until the next command.
  absl::Status s = axis_.MoveTo(target / kIncPerMm, limits, m.start, ZeroLimits::kHoldPosition);
  if (!s.ok()) {
    log::Warn("linmot_sim.move_refused",
              log::Fields().Add("drive", options_.name).Add("reason", s.message()));
    return;
  }
  target_ = target;
  started_targets_.push_back(target);
  running_ = Resumable{false, target / kIncPerMm, 1, limits};
  last_vai_ = running_;
}

void LinMotDevice::StartCurve(const action::RunCurve& command) {
  TimeCurvePlan plan =
      PlanTimeCurve(command, rtc_.FindCurve(command.curve_id), params_, axis_.demand().position);
  if (!plan.curve) {
    log::Info("linmot_sim.curve_refused",
              log::Fields().Add("drive", options_.name).Add("reason", plan.reason));
    Raise(plan.error);  // 0062h / 0089h (§7 L1007)
    return;
  }
  curve_ = std::move(plan.curve);
  // Motion Active from this telegram on (§7 L1010): hold the curve's start until the first tick.
  axis_.Start(sim::motion::Profile::Hold(curve_->At(0)));
  // §7 L1008: a freeze aborts the curve; its release goes to the last VAI target, or to the
  // initial position when no VAI command ran (with the predefined VAI limits).
  running_ = last_vai_;
  if (!running_) {
    running_ = Resumable{
        false, params_.Get(upid::kInitialPosition) / kIncPerMm, 1,
        ToLimits(params_.Get(upid::kPredefVelocity), params_.Get(upid::kPredefAcceleration),
                 params_.Get(upid::kPredefDeceleration))};
  }
}

void LinMotDevice::StepCurve(double dt_s) {
  TimeCurve& c = *curve_;
  using sim::motion::Profile;
  const double t0 = c.elapsed_s;
  const double t1 = t0 + dt_s;
  const double p0 = c.At(t0);
  if (t1 < c.duration_s - Profile::kEndTolerance) {
    // Constant velocity over this tick: the demand reaches y(t1) exactly at its end (D-29's
    // linear interpolation between ticks).
    axis_.Start(Profile::FromSegments({p0, (c.At(t1) - p0) / dt_s, 0}, {}, /*endless=*/true));
    c.elapsed_s = t1;
    return;
  }
  // The last piece: end exactly on the curve's end point, then stand (in target, D-10).
  const double end = c.end_mm();
  const double rest = c.duration_s - t0;
  if (rest > Profile::kEndTolerance) {
    axis_.Start(Profile::FromSegments({p0, (end - p0) / rest, 0}, {{rest, 0, 0}}, false, end));
  } else {
    axis_.Start(Profile::FromSegments({end, 0, 0}, {}, false, end));
  }
  target_ = ToInc(end);
  running_.reset();
  curve_.reset();
}

void LinMotDevice::FireEvents(double previous_demand_mm) {
  if (sm_.state() != MainState::kOperationEnabled) return;
  if (after_actual_ && !axis_.motion_active()) {
    VaiMove m = *after_actual_;
    after_actual_.reset();  // D-12: one-shot, self-clearing
    m.fire = Fire::kNow;
    StartMove(m);
  }
  if (transition_ && !curve_) {
    // §4.5: the *demand* position crossing the event position in the given direction.
    const double p = transition_->position / kIncPerMm;
    const double now = axis_.demand().position;
    const bool crossed = transition_->direction > 0 ? (previous_demand_mm < p && now >= p)
                                                    : (previous_demand_mm > p && now <= p);
    if (crossed && axis_.motion_active()) {
      const Limits l =
          ToLimits(transition_->velocity, transition_->acceleration, transition_->deceleration);
      if (running_ && running_->infinite) {
        if (axis_
                .Jog(running_->direction * l.max_velocity, l, std::nullopt, StartFrom::kDemand,
                     ZeroLimits::kHoldPosition)
                .ok()) {
          running_->limits = l;
        }
      } else if (axis_.MoveTo(axis_.target(), l, StartFrom::kDemand, ZeroLimits::kHoldPosition)
                     .ok()) {
        if (running_) running_->limits = l;  // target unchanged
      }
    }
  }
}

void LinMotDevice::SetTriggerInput(bool level) {
  const bool rising = level && !trigger_level_;
  const bool falling = !level && trigger_level_;
  trigger_level_ = level;
  // D-35 (reduced, decision 602): modes 1-4 pass the input through; mode 0 = no trigger.
  if (params_.Get(upid::kTriggerMode) == 0 || !trigger_move_) return;
  if (sm_.state() != MainState::kOperationEnabled) return;
  if ((rising && trigger_move_->fire == Fire::kRisingTrigger) ||
      (falling && trigger_move_->fire == Fire::kFallingTrigger)) {
    VaiMove m = *trigger_move_;
    m.fire = Fire::kNow;
    StartMove(m);
  }
}

void LinMotDevice::Execute(const Interpretation& in) {
  const uint16_t id = static_cast<uint16_t>(in.header.raw() >> 4);
  std::visit(Overloaded{
                 [&](const action::Nop&) {},
                 [&](const action::Ignored&) {
                   log::Debug("linmot_sim.mc_ignored", log::Fields()
                                                           .Add("drive", options_.name)
                                                           .Add("cmd", in.Describe())
                                                           .Add("state", int{sm_.main_state()}));
                 },
                 [&](const action::Move& a) {
                   ++mc_executed_;
                   StartMove(a.move);
                 },
                 [&](const action::Stop& a) {
                   ++mc_executed_;
                   curve_.reset();
                   if (axis_.Stop(a.deceleration / kAccPerMmS2, ZeroLimits::kHoldPosition).ok()) {
                     target_ = ToInc(axis_.target());
                     running_.reset();
                   }
                 },
                 [&](const action::Infinite& a) {
                   ++mc_executed_;
                   curve_.reset();
                   const Limits l = ToLimits(a.velocity, a.acceleration, a.deceleration);
                   if (axis_
                           .Jog(a.direction * l.max_velocity, l, std::nullopt, StartFrom::kDemand,
                                ZeroLimits::kHoldPosition)
                           .ok()) {
                     running_ = Resumable{true, 0, a.direction, l};
                   }
                 },
                 [&](const action::ChangeOnTransition& a) {
                   ++mc_executed_;
                   transition_ = a;
                 },
                 [&](const action::WriteControlWord& a) {
                   ++mc_executed_;
                   ApplyControlWord(a.control_word);
                 },
                 [&](const action::WriteLiveParameter& a) {
                   ++mc_executed_;
                   auto v = params_.FromLiveWrite(a.upid, a.raw);
                   absl::Status s = v.ok() ? params_.WriteRam(a.upid, *v) : v.status();
                   if (!s.ok()) {
                     // Decision 602: no MC error code exists for this; the write is dropped.
                     log::Warn(
                         "linmot_sim.live_parameter_refused",
                         log::Fields().Add("drive", options_.name).Add("reason", s.message()));
                   }
                 },
                 [&](const action::SelectControllerSet& a) {
                   ++mc_executed_;
                   if (!params_.WriteRam(upid::kActivePositionControllerSet, a.set).ok()) {
                     log::Warn("linmot_sim.controller_set_refused",
                               log::Fields().Add("drive", options_.name).Add("set", a.set));
                   }
                 },
                 [&](const action::ClearEvent&) {
                   ++mc_executed_;
                   after_actual_.reset();
                   trigger_move_.reset();
                   transition_.reset();
                 },
                 [&](const action::MasterHoming& a) {
                   // §5.1 009: 13C7h (RAM) := value, 13CAh computed, homed at the actual position
                   // without entering state 9.
                   ++mc_executed_;
                   curve_.reset();  // the curve's absolute positions lose their frame
                   params_.Set(upid::kHomePosition, a.home_position);
                   params_.Set(upid::kSliderHomePosition, ToInc(slider_mm_));
                   axis_.SetPosition(a.home_position / kIncPerMm);
                   target_ = ToInc(axis_.target());
                   homed_ = true;
                 },
                 [&](const action::ResetIController&) { ++mc_executed_; },
                 [&](const action::RunCurve& a) {
                   ++mc_executed_;
                   StartCurve(a);
                 },
                 [&](const action::Reset&) {
                   ++mc_executed_;
                   StartBoot();  // §4.3 rule 4: reboot, remembered count 0 afterwards
                 },
                 [&](const action::Raise& a) {
                   ++mc_rejected_;
                   log::Info("linmot_sim.mc_rejected", log::Fields()
                                                           .Add("drive", options_.name)
                                                           .Add("cmd", in.Describe())
                                                           .Add("state", int{sm_.main_state()}));
                   Raise(a.code);
                 },
                 [&](const action::Unsupported&) {
                   ++mc_executed_;
                   if (unsupported_logged_.insert(id).second) {
                     log::Warn("linmot_sim.mc_not_simulated",
                               log::Fields().Add("drive", options_.name).Add("cmd", in.Describe()));
                   }
                 },
             },
             in.action);
}

// ---------------------------------------------------------------------------------------------
// Telegrams.

std::optional<linudp::Reply> LinMotDevice::Handle(const linudp::Request& request) {
  if (booting_) return std::nullopt;
  if (!mc_stopped_) {
    // while MC is stopped its blocks are ignored; LinUDP keeps answering.
    if (request.control_word) ApplyControlWord(*request.control_word);
    if (request.motion_command) {
      auto in = interpreter_.Interpret(*request.motion_command, sm_.main_state(),
                                       !sm_.off3_stopping(), params_);
      if (in) {
        log::Debug("linmot_sim.mc", log::Fields()
                                        .Add("drive", options_.name)
                                        .Add("cmd", in->Describe())
                                        .Add("count", int{in->header.count}));
        Execute(*in);
        if (booting_) return std::nullopt;
      }
    }
  }
  std::optional<linudp::RtcReply> rtc;
  if (request.rtc || (request.response_definition & linudp::kRespRtc)) {
    // the RTC reply travels when request bit 2 or response bit 8 is set.
    RefreshVariables();
    RtcContext ctx{params_, error_log_, mc_stopped_, sim_time_};
    RtcResult r = rtc_.Handle(request.rtc, ctx);
    switch (r.effect) {
      case RtcEffect::kRestart:
        StartBoot();
        return std::nullopt;
      case RtcEffect::kStopMc:
        Apply(SmEffects{.power_off = sm_.powered()});
        sm_.PowerUp();
        interpreter_.PowerUp();
        mc_stopped_ = true;
        break;
      case RtcEffect::kStartMc:
        if (mc_stopped_) {
          // The MC SW restarts: RAM := ROM, state 0, count 0, not homed.
          params_.Boot();
          sm_.PowerUp();
          interpreter_.PowerUp();
          homed_ = !params_.Get(upid::kMotorRequiresHoming);
          mc_stopped_ = false;
        }
        break;
      case RtcEffect::kNone:
        break;
    }
    rtc = r.reply;
  }
  RefreshVariables();
  return ComposeReply(request, rtc);
}

linudp::Reply LinMotDevice::ComposeReply(const linudp::Request& request,
                                         const std::optional<linudp::RtcReply>& rtc) {
  linudp::Reply r;
  // request definition & 7; response definition & 1FFh, bit 8 forced with an RTC block.
  r.request_definition = linudp::RequestDefinitionOf(request) & linudp::kReqDefinedMask;
  uint32_t want = request.response_definition & linudp::kRespDefinedMask;
  if (request.rtc) want |= linudp::kRespRtc;
  r.response_definition = want;
  if (want & linudp::kRespStatusWord) r.status_word = status_word();
  if (want & linudp::kRespStateVar) r.state_var = state_var();
  if (want & linudp::kRespActualPosition) r.actual_position = actual_position();
  if (want & linudp::kRespDemandPosition) r.demand_position = demand_position();
  if (want & linudp::kRespCurrent) r.current = current_ma();
  if (want & linudp::kRespWarnWord) r.warn_word = warn_word();
  if (want & linudp::kRespErrorCode) r.error_code = error_code();
  if (want & linudp::kRespMonitoring) {
    // channel n carries the UPID configured in 20A8h + n - 1, sign/zero-extended.
    std::array<int32_t, 4> m{};
    for (int i = 0; i < 4; ++i) {
      const auto u = static_cast<uint16_t>(params_.Get(upid::kMonitoringChannel1 + i));
      m[i] = u == 0 ? 0 : static_cast<int32_t>(Parameters::ToWire(params_.Get(u)));
    }
    r.monitoring = m;
  }
  if (want & linudp::kRespRtc) r.rtc = rtc.value_or(rtc_.last_reply());
  return r;
}

void LinMotDevice::RefreshVariables() {
  params_.Set(upid::kOperatingSubHours, static_cast<int64_t>(operating_ms() % 3'600'000));
  params_.Set(upid::kDemandPosition, demand_position());
  params_.Set(upid::kDemandVelocity,
              static_cast<int64_t>(std::llround(axis_.demand().velocity * kVelPerMmS)));
  params_.Set(upid::kActualPosition, actual_position());
  params_.Set(upid::kActualVelocity,
              static_cast<int64_t>(std::llround(slider_velocity_ * kVelPerMmS)));
  params_.Set(upid::kDifferencePosition, int64_t{demand_position()} - actual_position());
  params_.Set(upid::kDemandCurrent, current_ma());
  params_.Set(upid::kControlWord, sm_.control_word());
}

// ---------------------------------------------------------------------------------------------
// Observation.

double LinMotDevice::actual_mm() const { return slider_mm_ + axis_.reference_offset(); }
double LinMotDevice::window_mm() const { return params_.Get(upid::kInTargetWindow) / kIncPerMm; }
bool LinMotDevice::motion_active() const { return sm_.powered() && axis_.motion_active(); }
bool LinMotDevice::in_target() const {
  // D-10: Motion Active = 0 and |actual - target| <= window (F000h).
  return sm_.powered() && !axis_.motion_active() &&
         std::abs(actual_mm() - axis_.target()) <= window_mm() + 1e-9;
}

int32_t LinMotDevice::actual_position() const { return ToInc(actual_mm()); }
int32_t LinMotDevice::demand_position() const { return ToInc(axis_.demand().position); }

int16_t LinMotDevice::current_ma() const {
  if (!sm_.powered()) return 0;
  // §6.8 option: demand current = moving mass x demand acceleration / force constant.
  const double amps = options_.moving_mass_kg * (axis_.demand().acceleration / 1000.0) /
                      options_.force_constant_n_per_a;
  return static_cast<int16_t>(std::clamp(std::nearbyint(amps * 1000.0), -32768.0, 32767.0));
}

uint16_t LinMotDevice::warn_word() const {
  uint16_t w = injected_warnings_;
  // D-41: Motor Not Homed while Homed = 0 and the motor model requires homing.
  if (!homed_ && params_.Get(upid::kMotorRequiresHoming)) w |= mc::WarnWord::kMotorNotHomed;
  if (sm_.powered() && std::abs(axis_.demand().position - actual_mm()) * kIncPerMm >
                           params_.Get(upid::kPositionLagWarnLimit)) {
    w |= mc::WarnWord::kPositionLagAlways;
  }
  return w;
}

uint16_t LinMotDevice::error_code() const { return sm_.error_active() ? sm_.error_code() : 0; }

uint16_t LinMotDevice::status_word() const {
  // linmot-mc.md §3.2; bits 1, 2, 4, 5 mirror control word bits 0, 3, 1, 2.
  using SW = mc::StatusWord;
  const uint16_t cw = sm_.control_word();
  const uint8_t main = sm_.main_state();
  return SW{}
      .With(SW::kOperationEnabled, main >= static_cast<uint8_t>(MainState::kOperationEnabled))
      .With(SW::kSwitchOnActive, cw & mc::kSwitchOn)
      .With(SW::kEnableOperation, cw & mc::kEnableOperation)
      .With(SW::kError, sm_.error_active())
      .With(SW::kVoltageEnable, cw & mc::kVoltageEnable)
      .With(SW::kQuickStopN, cw & mc::kQuickStopN)
      .With(SW::kSwitchOnLocked, sm_.switch_on_locked())
      .With(SW::kWarning, warn_word() != 0)
      .With(SW::kEventHandlerActive, event_handler_active())
      .With(SW::kSpecialMotionActive, StateMachine::Procedure(sm_.state()))  // D-40
      .With(SW::kInTargetPosition, in_target())
      .With(SW::kHomed, homed_)
      .With(SW::kFatalError, sm_.error_active() && sm_.fatal())
      .With(SW::kMotionActive, motion_active())
      .raw;
}

uint16_t LinMotDevice::state_var() const {
  if (sm_.state() == MainState::kOperationEnabled) {
    // §2.1: count echo and copies of status bits 8, 13, 10, 11.
    return mc::StateVar::OperationEnabled(interpreter_.count(), event_handler_active(),
                                          motion_active(), in_target(), homed_)
        .raw();
  }
  return mc::StateVar{sm_.main_state(), sm_.sub_state()}.raw();
}

DeviceSnapshot LinMotDevice::Snapshot() const {
  DeviceSnapshot s;
  s.sim_time = sim_time_;
  s.main_state = sm_.main_state();
  s.state_var = state_var();
  s.sub_state = static_cast<uint8_t>(s.state_var & 0xFF);
  s.status_word = status_word();
  s.warn_word = warn_word();
  s.control_word = sm_.control_word();
  s.error_code = error_code();
  s.actual_position = actual_position();
  s.demand_position = demand_position();
  s.actual_position_mm = actual_mm();
  s.demand_position_mm = axis_.demand().position;
  s.demand_velocity_mm_s = axis_.demand().velocity;
  s.current_ma = current_ma();
  s.homed = homed_;
  s.motion_active = motion_active();
  s.in_target = in_target();
  s.booting = booting_;
  s.mc_stopped = mc_stopped_;
  s.mc_count = interpreter_.count();
  s.rtc_count = rtc_.count();
  s.mc_commands_executed = mc_executed_;
  s.mc_commands_rejected = mc_rejected_;
  s.rtc_commands = rtc_.commands();
  s.boots = boots_;
  s.errors_occurred = error_log_.occurred();
  return s;
}

}  // namespace drivegw::sim::linmot
