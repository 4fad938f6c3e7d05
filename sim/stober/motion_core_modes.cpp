// MotionCore: MC_Home (§3.7, §4, §8.7), the cyclic commands with the fine interpolator
// (§3.8, §3.11, §8.8) and MC_TorqueControl (§3.10, §8.9).
#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "sim/motion/jerk_profile.h"
#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober {
namespace {

struct Method {
  int type = 0;  // I30: 1 reference input, 2 limit switch, 3 zero pulse, 4 stopper, 5 define
  int direction = 1;
  bool zero_pulse = false;
};

// A586 (CiA 402 homing methods) → the letter methods of Tab. 22 (G-22 [P], decision 1150).
std::optional<Method> CiaMethod(int a586) {
  switch (a586) {
    case 1:
      return Method{2, -1, true};  // A: negative limit switch + zero pulse
    case 2:
      return Method{2, +1, true};  // E: positive limit switch + zero pulse
    case 3:
    case 7:
      return Method{1, +1, true};  // F / I: reference switch, positive, zero pulse
    case 5:
    case 11:
      return Method{1, -1, true};  // B / K: reference switch, negative, zero pulse
    case 17:
      return Method{2, -1, false};  // C
    case 18:
      return Method{2, +1, false};  // G
    case 19:
    case 23:
      return Method{1, +1, false};  // H / J
    case 21:
    case 27:
      return Method{1, -1, false};  // D / L
    case 33:
      return Method{3, -1, true};  // M: zero pulse, negative
    case 34:
      return Method{3, +1, true};  // N: zero pulse, positive
    case 35:
    case 37:
      return Method{5, +1, false};  // O: set reference
    case -1:
      return Method{4, -1, false};  // R: torque/force stop, negative
    case -2:
      return Method{4, +1, false};  // P
    case -3:
      return Method{4, -1, true};  // S
    case -4:
      return Method{4, +1, true};  // Q
    default:
      return std::nullopt;
  }
}

}  // namespace

void MotionCore::StartHome() {
  Method method;
  if (std::optional<Method> m = CiaMethod(static_cast<int>(Get("A586")))) {
    method = *m;  // the CiA 402 method wins when set (decision 1150)
  } else {
    method = {static_cast<int>(Get("I30")), Get("I31") == 1 ? -1 : +1, Get("I35") == 1};
  }
  last_set_position_.reset();  // G-16
  if (method.type == 5) {
    // Define home: actual position := I34 at once, no motion, I89 stays 2 (L1212, L1278).
    const double delta = Get("I34") - actual_position_;
    offset_ += delta;
    actual_position_ += delta;
    set_.position += delta;
    profile_.Shift(delta);
    Set("I86", 1);
    done_ = true;  // masked in the start cycle (§2.7)
    homing_ = {};
    homing_.type = 5;
    homing_.phase = HomingPhase::kEnd;
    return;
  }
  homing_ = {};
  homing_.type = method.type;
  homing_.direction = method.direction;
  homing_.zero_pulse = method.zero_pulse && method.type != 4;
  homing_.last_machine = MachinePosition();
  Set("I86", 0);  // a new reference search drops the old reference
  ReleaseBrake();
  plc_ = PlcState::kHoming;
  if (method.type == 3) {
    homing_.phase = HomingPhase::kZeroPulse;
    homing_.zero_search_start = homing_.last_machine;
    HomingVelocity(homing_.direction * Get("I33"));
  } else {
    homing_.phase = HomingPhase::kSearch;
    HomingVelocity(homing_.direction * Get("I32"));
  }
}

void MotionCore::HomingVelocity(double velocity) {
  // I39 acceleration = deceleration, I44 jerk, limited by I10/I11/I16 without I190/I191
  // (L1201-1202); override applies (L1232). Zero speed/ramps: busy without motion (G-11).
  homing_.velocity = velocity;
  applied_override_ = OverrideFactor();
  const double acc = std::min(Get("I39"), Get("I11"));
  const double jerk = std::min(Get("I44"), Get("I16"));
  const double v =
      cmd_sign(velocity) * std::min(std::abs(velocity) * applied_override_, Get("I10"));
  if (acc <= 0 || jerk <= 0 || Get("I10") <= 0) {
    drive_ = Drive::kRest;
    return;
  }
  motion::JerkLimits limits{Get("I10"), acc, acc, jerk};
  absl::StatusOr<motion::JerkVelocityProfile> p =
      motion::JerkVelocityProfile::Plan(set_, v, limits);
  if (!p.ok()) {
    Cancel(Cause::kZeroProfileValue, std::string(p.status().message()));
    return;
  }
  profile_ = *p;
  t_ = 0;
  drive_ = Drive::kProfile;
}

void MotionCore::ReferenceAt(double machine_position) {
  // The actual position at the reference point becomes I34 (L1278), then the drive stops.
  const double delta = (Get("I34") - machine_position) - offset_;
  offset_ += delta;
  actual_position_ += delta;
  set_.position += delta;
  profile_.Shift(delta);
  Set("I86", 1);
  homing_.phase = HomingPhase::kStopAfterReference;
  const double acc = std::min(Get("I39"), Get("I11"));
  const double jerk = std::min(Get("I44"), Get("I16"));
  absl::StatusOr<motion::JerkVelocityProfile> stop =
      motion::JerkVelocityProfile::Stop(set_, acc, jerk);
  if (stop.ok()) {
    profile_ = *stop;
    t_ = 0;
    drive_ = Drive::kProfile;
  } else {
    drive_ = Drive::kRest;
    set_.velocity = set_.acceleration = 0;
  }
}

void MotionCore::StepHoming() {
  const double machine = MachinePosition();
  const double previous_machine = homing_.last_machine;
  homing_.last_machine = machine;
  const bool velocity_phase = homing_.phase == HomingPhase::kSearch ||
                              homing_.phase == HomingPhase::kReturn ||
                              homing_.phase == HomingPhase::kZeroPulse;
  if (velocity_phase && OverrideFactor() != applied_override_) HomingVelocity(homing_.velocity);
  const int dir = homing_.direction;
  auto feature_active = [&] {
    switch (homing_.type) {
      case 1:
        return ReferenceSwitchActive();
      case 2:
        return dir > 0 ? PositiveLimitActive() : NegativeLimitActive();
      default:
        return false;
    }
  };
  // Machine position of the edge where the feature is left towards the start side.
  auto edge_position = [&] {
    if (homing_.type == 1 && options_.reference_switch && !forced_reference_switch_) {
      return dir > 0 ? options_.reference_switch->first : options_.reference_switch->second;
    }
    if (homing_.type == 2 && dir > 0 && options_.positive_limit_switch && !forced_positive_limit_) {
      return *options_.positive_limit_switch;
    }
    if (homing_.type == 2 && dir < 0 && options_.negative_limit_switch && !forced_negative_limit_) {
      return *options_.negative_limit_switch;
    }
    return machine;
  };
  switch (homing_.phase) {
    case HomingPhase::kSearch: {
      if (homing_.type == 4) {
        // Torque/force stop: blocked at the end stop, the torque exceeds I28 for I29.
        const std::optional<double> stop =
            dir > 0 ? options_.positive_end_stop : options_.negative_end_stop;
        if (stop && (dir > 0 ? machine >= *stop : machine <= *stop)) {
          const double delta = *stop - machine;
          set_ = {set_.position + delta, 0, 0};
          actual_position_ += delta;
          actual_velocity_ = 0;
          drive_ = Drive::kRest;
          torque_ = dir > 0 ? Get("E65") : -Get("E66");
          ++homing_.blocked_cycles;
          if (std::abs(torque_) > Get("I28") &&
              homing_.blocked_cycles * Get("A150") >= Get("I29")) {
            torque_ = 0;
            ReferenceAt(*stop);
          }
        }
        break;
      }
      if (feature_active()) {
        homing_.phase = HomingPhase::kReturn;
        homing_.was_active = false;
        HomingVelocity(-dir * Get("I33"));
      }
      break;
    }
    case HomingPhase::kReturn: {
      const bool moving_back = set_.velocity * dir < 0;
      if (!moving_back) break;
      const bool active = feature_active();
      if (homing_.was_active && !active) {
        if (homing_.zero_pulse) {
          homing_.phase = HomingPhase::kZeroPulse;
          homing_.zero_search_start = machine;
        } else {
          ReferenceAt(edge_position());
        }
      }
      homing_.was_active = active;
      break;
    }
    case HomingPhase::kZeroPulse: {
      // Next zero pulse crossed between the previous and this cycle's machine position.
      const double spacing = options_.zero_pulse_spacing;
      if (spacing <= 0 || machine == previous_machine) break;
      const double lo = std::min(previous_machine, machine);
      const double hi = std::max(previous_machine, machine);
      const double k = std::ceil((lo - options_.zero_pulse_offset) / spacing);
      const double pulse = options_.zero_pulse_offset + k * spacing;
      const bool crossed =
          machine > previous_machine ? (pulse > lo && pulse <= hi) : (pulse >= lo && pulse < hi);
      if (crossed) {
        ReferenceAt(pulse);
      } else if (Get("I37") > 0 && std::abs(machine - homing_.zero_search_start) > Get("I37")) {
        // Index search distance I37 travelled without a zero pulse (L1162; decision 1150).
        Cancel(Cause::kZeroPulseNotFound, "zero pulse not found within index search distance I37");
      }
      break;
    }
    case HomingPhase::kStopAfterReference:
      if (!Moving()) {
        if (Get("I43") == 1) {  // travel to the reference position (L1278)
          homing_.phase = HomingPhase::kToReference;
          motion::JerkLimits limits{
              std::max(std::min(Get("I32"), Get("I10")), 1e-9), std::min(Get("I39"), Get("I11")),
              std::min(Get("I39"), Get("I11")), std::min(Get("I44"), Get("I16"))};
          absl::StatusOr<motion::JerkProfile> p =
              motion::JerkProfile::Plan(set_, Get("I34"), limits);
          if (p.ok()) {
            profile_ = *p;
            t_ = 0;
            drive_ = Drive::kProfile;
          } else {
            homing_.phase = HomingPhase::kEnd;
          }
        } else {
          homing_.phase = HomingPhase::kEnd;
        }
      }
      break;
    case HomingPhase::kToReference:
      if (!Moving()) homing_.phase = HomingPhase::kEnd;
      break;
    case HomingPhase::kEnd:
      break;
  }
  if (homing_.phase == HomingPhase::kEnd && !done_) {
    done_ = true;  // referencing completed (L1290)
    plc_ = PlcState::kStandstill;
  }
}

// --- Cyclic commands ------------------------------------------------------------------------

void MotionCore::StartCyclic(Command command) {
  last_set_position_.reset();
  ReleaseBrake();
  plc_ = PlcState::kCyclicMotion;
  cyclic_only_at_start_ = Get("I119") == 1;
  drive_ = command == Command::kCyclicSpeed ? Drive::kCyclicSpeed : Drive::kCyclicPosition;
  ResetInterpolator();
  // The values present at the edge are the first received set value (§2.2).
  OnCyclicSetValue(command == Command::kCyclicSpeed ? Get("I426") : Get("I421"));
}

void MotionCore::ResetInterpolator() {
  const double base = drive_ == Drive::kCyclicPosition ? set_.position : set_.velocity;
  interp_ = {};
  interp_.from = interp_.to = interp_.value = base;
  interp_.steps = std::max(1, static_cast<int>(std::lround(Get("A291") / Get("A150"))));
  interp_.step = interp_.steps;
}

void MotionCore::OnCyclicSetValue(double value) {
  if (!command_active_) return;
  if (drive_ == Drive::kCyclicPosition && Endless()) {
    // L1763: set positions in [0, I01) (G-33), else event 78 cause 2; unwrap by the smaller
    // step, counting revolutions internally (§8.8 [P]).
    const double length = Get("I01");
    if (value < 0 || value >= length) {
      events_.push_back({cycle_, 78, 2,
                         absl::StrCat("position limit cyclic: set position ", value,
                                      " outside revolution length I01 = ", length)});
      event78_warning_ = true;
      Cancel(Cause::kEvent78, "event 78 cause 2: cyclic set position outside 0..I01");
      return;
    }
    double step = value - Modulo(interp_.to);
    if (step > length / 2) step -= length;
    if (step < -length / 2) step += length;
    value = interp_.to + step;
  }
  cyclic_value_ = value;
  cyclic_fresh_ = true;
}

std::optional<double> MotionCore::Interpolate() {
  if (cyclic_fresh_) {
    cyclic_fresh_ = false;
    interp_.from = interp_.value;
    interp_.to = cyclic_value_;
    interp_.steps = std::max(1, static_cast<int>(std::lround(Get("A291") / Get("A150"))));
    interp_.step = 0;
    interp_.slope = (interp_.to - interp_.from) / interp_.steps;
    interp_.extrapolated = 0;
  }
  if (interp_.step < interp_.steps) {
    ++interp_.step;
    interp_.value = interp_.from + (interp_.to - interp_.from) * interp_.step / interp_.steps;
    return interp_.value;
  }
  if (cyclic_only_at_start_) return interp_.value;
  // Missing set values: linear extrapolation for at most I423, then event 78 cause 3 (L1344)
  // and the command is cancelled (G-31).
  ++interp_.extrapolated;
  if (interp_.extrapolated * Get("A150") > Get("I423") + 1e-9) {
    events_.push_back({cycle_, 78, 3, "position limit cyclic: extrapolation time I423 expired"});
    event78_warning_ = true;
    Cancel(Cause::kEvent78, "event 78 cause 3: extrapolation time I423 expired");
    return std::nullopt;
  }
  interp_.value += interp_.slope;
  interp_.to = interp_.value;
  return interp_.value;
}

void MotionCore::StepCyclicSpeed() {
  std::optional<double> value = Interpolate();
  if (!value) {  // cancelled: the quick-stop profile takes over in this cycle
    if (drive_ == Drive::kProfile) {
      t_ += dt();
      set_ = profile_.At(t_);
    }
    return;
  }
  double v = *value;
  bool filtered = false;
  if (!DirectionPermitted(cmd_sign(v)) ||
      (limit_blocked_direction_ != 0 && cmd_sign(v) == limit_blocked_direction_)) {
    v = 0;  // L1361, L1396-1398
    filtered = true;
  }
  override_limited_ = filtered;                         // I193 (L1365)
  v = cmd_sign(v) * std::min(std::abs(v), Get("I10"));  // L1358
  const double step = dt();
  set_.acceleration = (v - set_.velocity) / step;
  set_.velocity = v;
  set_.position += v * step;
}

void MotionCore::StepCyclicPosition() {
  std::optional<double> value = Interpolate();
  if (!value) {  // cancelled: the quick-stop profile takes over in this cycle
    if (drive_ == Drive::kProfile) {
      t_ += dt();
      set_ = profile_.At(t_);
    }
    return;
  }
  const double step_time = dt();
  double delta = *value - set_.position;
  const double s = cmd_sign(delta);
  bool filtered = false;
  if (!DirectionPermitted(s) || (limit_blocked_direction_ != 0 && s == limit_blocked_direction_)) {
    delta = 0;  // hold (L1786, L1820-1822)
    filtered = true;
  }
  position_limited_ = filtered;                    // I192
  override_limited_ = filtered;                    // I193
  const double max_step = Get("I10") * step_time;  // L1779
  delta = cmd_sign(delta) * std::min(std::abs(delta), max_step);
  const double v = delta / step_time;
  set_.acceleration = (v - set_.velocity) / step_time;
  set_.velocity = v;
  set_.position += delta;
}

// --- MC_TorqueControl -----------------------------------------------------------------------

void MotionCore::StartTorque() {
  last_set_position_.reset();
  ReleaseBrake();
  plc_ = PlcState::kContinuousMotion;
  drive_ = Drive::kTorque;
}

void MotionCore::StepTorque() {
  const double step = dt();
  // Set torque: I428 taken over cyclically (L1629), clamped to E65/E66 (G-34) with I194.
  double target = Get("I428");
  const double clamped = std::clamp(target, -Get("E66"), Get("E65"));
  torque_limited_ = clamped != target;
  target = clamped;
  if (!DirectionPermitted(cmd_sign(target)) ||
      (limit_blocked_direction_ != 0 && cmd_sign(target) == limit_blocked_direction_)) {
    target = 0;  // L1691-1693
  }
  // Ramps I430 (rise) / I431 (fall) in %/s; 0 = step (§8.9 [P]).
  const bool rising = std::abs(target) > std::abs(torque_) && target * torque_ >= 0;
  const double rate = rising ? Get("I430") : Get("I431");
  if (rate <= 0) {
    torque_ = target;
  } else {
    const double change = std::clamp(target - torque_, -rate * step, rate * step);
    torque_ += change;
  }
  // Mechanics J·dv/dt = T − T_load (§8.9 [P]).
  double v = set_.velocity;
  double load = options_.load_torque + options_.viscous_friction * v;
  double net = torque_ - load;
  if (v != 0) {
    net -= options_.coulomb_friction * cmd_sign(v);
  } else if (std::abs(net) <= options_.coulomb_friction) {
    net = 0;
  } else {
    net -= options_.coulomb_friction * cmd_sign(net);
  }
  const double a = options_.acceleration_per_torque * net;
  double v_next = v + a * step;
  // |v| <= I10 (L1690): the effective torque is reduced.
  v_next = std::clamp(v_next, -Get("I10"), Get("I10"));
  double x_next = set_.position + v_next * step;
  const double machine = x_next - offset_;
  if (options_.positive_end_stop && machine >= *options_.positive_end_stop) {
    x_next = *options_.positive_end_stop + offset_;
    v_next = 0;
  }
  if (options_.negative_end_stop && machine <= *options_.negative_end_stop) {
    x_next = *options_.negative_end_stop + offset_;
    v_next = 0;
  }
  set_ = {x_next, v_next, (v_next - v) / step};
  actual_position_ = x_next;
  actual_velocity_ = v_next;
}

}  // namespace drivegw::sim::stober
