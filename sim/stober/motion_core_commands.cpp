// MotionCore: command start, denial rules and profile planning of the commands 1-5, 8, 11
// (stober-motion.md §2.4, §2.8, §3.2-3.6, §3.9, §3.12, §8.2-8.6).
#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "sim/motion/jerk_profile.h"
#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober {
namespace {

template <typename T>
absl::StatusOr<motion::Profile> AsProfile(absl::StatusOr<T> planned) {
  if (!planned.ok()) return planned.status();
  return static_cast<motion::Profile>(*std::move(planned));
}

double PositiveModulo(double x, double length) {
  double m = std::fmod(x, length);
  if (m < 0) m += length;
  if (m >= length) m = 0;
  return m;
}

}  // namespace

void MotionCore::StartCommand(Command command) {
  // An aborting start cancels the running block and a buffered one (§2.5, decision 1162).
  buffered_.reset();
  passing_ = false;
  end_velocity_ = 0;
  command_ = command;
  command_started_ = true;
  command_active_ = true;
  start_cycle_ = cycle_;
  error_ = false;
  cause_ = Cause::kNone;
  error_text_.clear();
  done_ = false;
  done_latched_ = false;
  window_cycles_ = 0;
  velocity_limited_ = dynamics_limited_ = override_limited_ = false;
  position_limited_ = acceleration_limited_ = torque_limited_ = false;
  stop_held_by_override_ = false;
  event78_warning_ = false;
  brake_timer_.reset();     // a start within I42 restarts without engaging (L373)
  Set("I82", Get("I400"));  // motion ID (L187)
  DropForeignAcceleration();

  if (!power_.operation_enabled()) {
    Deny(Cause::kNotEnabled, "axis not enabled (CiA 402 state is not Operation enabled)");
    return;
  }
  if (plc_ == PlcState::kErrorStop) {
    Deny(Cause::kErrorStopActive, "error stop active (I89 = 7): fault reset required (G-04)");
    return;
  }
  if (plc_ == PlcState::kStopping) {
    // L1059: every command started during an active MC_Stop is denied; the stop continues and
    // I89 stays 6 (G-29, G-30).
    error_ = true;
    cause_ = Cause::kStopActive;
    error_text_ = "command started during an active MC_Stop (I89 = 6)";
    command_active_ = false;
    return;
  }
  if (std::optional<std::pair<Cause, std::string>> denial = CheckDenial(command)) {
    Deny(denial->first, std::move(denial->second));
    return;
  }
  switch (command) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive:
      StartPositioning(command);
      break;
    case Command::kMoveVelocity:
      StartMoveVelocity();
      break;
    case Command::kStop:
    case Command::kHalt:
      StartStopOrHalt(command);
      break;
    case Command::kHome:
      StartHome();
      break;
    case Command::kCyclicSpeed:
    case Command::kCyclicPosition:
      StartCyclic(command);
      break;
    case Command::kMoveSpeed:
      StartMoveSpeed();
      break;
    case Command::kTorqueControl:
      StartTorque();
      break;
    case Command::kDoNothing:
      break;
  }
}

std::optional<std::pair<Cause, std::string>> MotionCore::CheckDenial(Command command) {
  using Denial = std::pair<Cause, std::string>;
  const double velocity = Get("I404");
  const double acceleration = Get("I405");
  const double deceleration = Get("I406");
  const double jerk = Get("I407");
  const bool positioning = command == Command::kMoveAbsolute || command == Command::kMoveRelative ||
                           command == Command::kMoveAdditive;
  auto zero_maxima = [&]() -> std::optional<Denial> {
    if (Get("I11") == 0) return Denial{Cause::kZeroMaximumValue, "maximum acceleration I11 = 0"};
    if (Get("I16") == 0) return Denial{Cause::kZeroMaximumValue, "maximum jerk I16 = 0"};
    return std::nullopt;
  };
  auto direction_checks = [&](double direction) -> std::optional<Denial> {
    if (Endless() && !DirectionPermitted(direction)) {
      return Denial{Cause::kPermittedDirection,
                    "travel direction blocked by permitted direction I04"};
    }
    if (direction > 0 && PositiveLimitActive()) {
      return Denial{Cause::kHardwareLimit,
                    "hardware limit switch active in travel direction (positive, I441)"};
    }
    if (direction < 0 && NegativeLimitActive()) {
      return Denial{Cause::kHardwareLimit,
                    "hardware limit switch active in travel direction (negative, I442)"};
    }
    return std::nullopt;
  };
  if (positioning) {
    // L231-232, L471-472, L661-662.
    if (velocity == 0) return Denial{Cause::kZeroProfileValue, "velocity I404 = 0"};
    if (acceleration == 0) return Denial{Cause::kZeroProfileValue, "acceleration I405 = 0"};
    if (deceleration == 0) return Denial{Cause::kZeroProfileValue, "deceleration I406 = 0"};
    if (jerk == 0) return Denial{Cause::kZeroProfileValue, "jerk I407 = 0"};
    if (auto d = zero_maxima()) return d;
    const bool referenced = Get("I86") == 1;
    if (command == Command::kMoveAbsolute && !referenced) {
      return Denial{Cause::kNotReferenced, "MoveAbsolute needs a referenced axis (I86 = 0, G-10)"};
    }
    if (command != Command::kMoveAbsolute && SoftwareLimitsUsed() && !referenced) {
      return Denial{Cause::kNotReferenced,
                    "software limit switches I50/I51 in use and axis not referenced (I86 = 0)"};
    }
    if (auto d = ComputeTarget(command)) return d;
    if (SoftwareLimitsUsed() && (target_ > Get("I50") || target_ < Get("I51"))) {
      return Denial{Cause::kSoftwareLimit, "position outside software limits I50..I51"};
    }
    return direction_checks(cmd_sign(target_ - set_.position));
  }
  switch (command) {
    case Command::kMoveVelocity:  // L873-878; velocity 0 is no denial [D]
      if (acceleration == 0) return Denial{Cause::kZeroProfileValue, "acceleration I405 = 0"};
      if (deceleration == 0) return Denial{Cause::kZeroProfileValue, "deceleration I406 = 0"};
      if (jerk == 0) return Denial{Cause::kZeroProfileValue, "jerk I407 = 0"};
      if (auto d = zero_maxima()) return d;
      return direction_checks(cmd_sign(velocity));
    case Command::kStop:
    case Command::kHalt: {
      // L1013-1018, L1890-1895: zero deceleration/jerk is no denial at standstill (I89 = 2).
      if (plc_ != PlcState::kStandstill) {
        if (deceleration == 0) return Denial{Cause::kZeroProfileValue, "deceleration I406 = 0"};
        if (jerk == 0) return Denial{Cause::kZeroProfileValue, "jerk I407 = 0"};
      }
      return zero_maxima();
    }
    case Command::kHome: {
      if (plc_ != PlcState::kStandstill) {
        return Denial{Cause::kNotStandstill, "MC_Home needs standstill (I89 = 2)"};
      }
      if (Get("I30") == 0 && Get("A586") == 0) {
        return Denial{Cause::kReferencingInactive, "referencing type inactive (I30 = 0, A586 = 0)"};
      }
      return std::nullopt;  // zero speeds, acceleration or jerk are no denial (L1188)
    }
    case Command::kMoveSpeed:  // L1492-1493
      if (jerk == 0) return Denial{Cause::kZeroProfileValue, "jerk I407 = 0"};
      if (Get("I16") == 0) return Denial{Cause::kZeroMaximumValue, "maximum jerk I16 = 0"};
      return std::nullopt;
    default:
      return std::nullopt;  // 7, 9, 10 are never denied (L1352, L1643, L1771)
  }
}

// Target of 1-3 into target_ (§8.3, §8.4); a denial for MoveAbsolute outside I01.
std::optional<std::pair<Cause, std::string>> MotionCore::ComputeTarget(Command command) {
  const double position = Get("I403");
  if (command == Command::kMoveRelative) {
    target_ = actual_position_ + position;  // actual position at command start (L413)
    return std::nullopt;
  }
  if (command == Command::kMoveAdditive) {
    // Base = last valid set position, else the actual position (L741-751, G-15, G-16).
    target_ = last_set_position_.value_or(actual_position_) + position;
    return std::nullopt;
  }
  if (!Endless()) {
    target_ = position;
    return std::nullopt;
  }
  const double length = Get("I01");
  if (position < 0 || position >= length) {  // G-33: [0, I01)
    return std::pair{Cause::kRevolutionLength,
                     std::string("position outside revolution length I01")};
  }
  const double x = Modulo(set_.position);
  double shortest = PositiveModulo(position - x + length / 2, length) - length / 2;
  if (shortest == -length / 2) shortest = length / 2;  // tie → positive (G-33)
  const int mode = static_cast<int>(Get("I411"));
  const bool moving = std::abs(set_.velocity) > 1e-9;
  double distance = shortest;
  if (!moving) {
    // L263-271: 0/3 shortest; 1/2 forced direction unless within the window I22.
    const bool in_window = std::abs(shortest) <= Get("I22");
    if (mode == 1 && !in_window) distance = PositiveModulo(position - x, length);
    if (mode == 2 && !in_window) distance = -PositiveModulo(x - position, length);
  } else {
    // L293-298: 0/3 keep the current direction, 1/2 forced; whole revolutions to brake (L308).
    const double s = cmd_sign(set_.velocity);
    if (mode == 1) {
      distance = PositiveModulo(position - x, length);
    } else if (mode == 2) {
      distance = -PositiveModulo(x - position, length);
    } else {
      distance = s * PositiveModulo(s * (position - x), length);
    }
    if (cmd_sign(distance) == s || distance == 0) {
      const double dec = std::min(Get("I406"), Get("I11"));
      const double jerk = std::min(Get("I407"), Get("I16"));
      absl::StatusOr<motion::JerkVelocityProfile> stop =
          motion::JerkVelocityProfile::Stop(set_, dec, jerk);
      if (stop.ok()) {
        const double braking = std::abs(stop->target() - set_.position);
        while (std::abs(distance) < braking) distance += s * length;
      }
    }
  }
  target_ = set_.position + distance;
  return std::nullopt;
}

void MotionCore::Deny(Cause cause, std::string text) {
  buffered_.reset();  // a denied or cancelled chain ends here (decision 1163)
  passing_ = false;
  error_ = true;
  cause_ = cause;
  error_text_ = std::move(text);
  command_active_ = false;
  if (!power_.operation_enabled()) return;
  plc_ = PlcState::kErrorStop;
  if (Moving()) QuickStop();  // L310: a denial from motion stops by quick stop
}

void MotionCore::Cancel(Cause cause, std::string text) { Deny(cause, std::move(text)); }

// The acceleration of the cyclic, torque and cyclical-takeover modes is a difference quotient of
// set-value jumps, not a profile state: a following profile starts from a = 0 (jerk-free
// continuation is not guaranteed there, L324, L859; decision 1153).
void MotionCore::DropForeignAcceleration() {
  if (drive_ != Drive::kProfile && drive_ != Drive::kRest) set_.acceleration = 0;
}

// §2.12: released at every start from standstill (L255); with a release time the motion waits
// for it (§8.10 [P], decision 1157).
void MotionCore::ReleaseBrake() {
  if (brake_engaged_ && Get("F00") == 1 && options_.brake_release_ms > 0) {
    brake_release_cycles_ =
        std::max(1, static_cast<int>(std::lround(options_.brake_release_ms / Get("A150"))));
    return;
  }
  brake_engaged_ = false;
}

void MotionCore::QuickStop() {
  DropForeignAcceleration();
  // G-20: configurable quick-stop deceleration (default I11) and jerk (default I16).
  const double dec =
      options_.quick_stop_deceleration > 0 ? options_.quick_stop_deceleration : Get("I11");
  const double jerk = options_.quick_stop_jerk > 0 ? options_.quick_stop_jerk : Get("I16");
  limit_stop_ = false;
  quick_stopping_ = true;
  absl::StatusOr<motion::JerkVelocityProfile> stop =
      motion::JerkVelocityProfile::Stop(set_, dec, jerk);
  if (dec <= 0 || jerk <= 0 || !stop.ok()) {
    drive_ = Drive::kRest;  // no ramp possible: hold at once
    set_.velocity = 0;
    set_.acceleration = 0;
    quick_stopping_ = false;
    return;
  }
  profile_ = *stop;
  t_ = 0;
  drive_ = Drive::kProfile;
}

bool MotionCore::SetProfile(absl::StatusOr<motion::Profile> profile) {
  if (!profile.ok()) {
    Cancel(Cause::kZeroProfileValue, std::string(profile.status().message()));
    return false;
  }
  profile_ = *std::move(profile);
  t_ = 0;
  ramp_end_ = 0;
  for (const motion::Segment& s : profile_.segments()) ramp_end_ += s.duration;
  drive_ = Drive::kProfile;
  return true;
}

void MotionCore::StartPositioning(Command command) {
  (void)command;
  cmd_velocity_ = std::abs(Get("I404"));
  cmd_acceleration_ = Get("I405");
  cmd_deceleration_ = Get("I406");
  cmd_jerk_ = Get("I407");
  brake_at_end_ = Get("I410") != 0;
  end_velocity_ = Get("I429");  // latched with the other inputs (L183)
  // Only 1-3 produce a valid set position (L745, G-16).
  last_set_position_ = target_;
  started_targets_.push_back(target_);
  window_reached_ = window_left_ = false;
  ReleaseBrake();
  plc_ = PlcState::kDiscreteMotion;
  PlanPositioning();
}

void MotionCore::PlanPositioning() {
  passing_ = false;
  const double factor = OverrideFactor();
  applied_override_ = factor;
  const double vmax_abs = Get("I10");
  // §8.2 limits and flags (L236-247).
  velocity_limited_ = cmd_velocity_ > vmax_abs;
  override_limited_ = !velocity_limited_ && cmd_velocity_ * factor > vmax_abs;
  dynamics_limited_ =
      cmd_acceleration_ > Get("I11") || cmd_deceleration_ > Get("I11") || cmd_jerk_ > Get("I16");
  motion::JerkLimits limits{
      std::min(cmd_velocity_ * factor, vmax_abs), std::min(cmd_acceleration_, Get("I11")),
      std::min(cmd_deceleration_, Get("I11")), std::min(cmd_jerk_, Get("I16"))};
  if (limits.max_velocity <= 0) {
    // Override 0: the axis decelerates and waits until the override is raised (L359, G-25).
    stop_held_by_override_ = true;
    SetProfile(
        AsProfile(motion::JerkVelocityProfile::Stop(set_, limits.deceleration, limits.jerk)));
    return;
  }
  stop_held_by_override_ = false;
  if (end_velocity_ > 0) {
    // End velocity ≠ 0: the target is passed at it (L368), scaled by the override like every
    // velocity of the block and clipped to its velocity limit (decision 1161).
    absl::StatusOr<motion::JerkProfile> pass = motion::JerkProfile::PlanPass(
        set_, target_, std::min(end_velocity_ * factor, limits.max_velocity), limits);
    const bool passes = pass.ok() && pass->passes();
    const double at = passes ? pass->pass_time() : 0;
    if (SetProfile(AsProfile(std::move(pass))) && passes) {
      passing_ = true;
      pass_time_ = at;
    }
    return;
  }
  SetProfile(AsProfile(motion::JerkProfile::Plan(set_, target_, limits)));
}

void MotionCore::StartMoveVelocity() {
  cmd_velocity_ = Get("I404");
  cmd_acceleration_ = Get("I405");
  cmd_deceleration_ = Get("I406");
  cmd_jerk_ = Get("I407");
  last_set_position_.reset();  // G-16
  ReleaseBrake();
  plc_ = PlcState::kContinuousMotion;
  velocity_limited_ = std::abs(cmd_velocity_) > Get("I10");
  override_limited_ = !velocity_limited_ && std::abs(cmd_velocity_) * OverrideFactor() > Get("I10");
  if (Get("I113") == 1) {
    drive_ = Drive::kCyclicTakeover;  // L859: ramps ignored
    velocity_target_ =
        cmd_sign(cmd_velocity_) * std::min(std::abs(cmd_velocity_) * OverrideFactor(), Get("I10"));
    return;
  }
  dynamics_limited_ =
      cmd_acceleration_ > Get("I11") || cmd_deceleration_ > Get("I11") || cmd_jerk_ > Get("I16");
  PlanVelocity(cmd_velocity_, cmd_acceleration_, cmd_deceleration_, cmd_jerk_);
}

void MotionCore::PlanVelocity(double velocity, double acceleration, double deceleration,
                              double jerk) {
  applied_override_ = OverrideFactor();
  const double vmax = std::max(Get("I10"), 1e-9);
  velocity_target_ =
      cmd_sign(velocity) * std::min(std::abs(velocity) * applied_override_, Get("I10"));
  motion::JerkLimits limits{vmax, std::min(acceleration, Get("I11")),
                            std::min(deceleration, Get("I11")), std::min(jerk, Get("I16"))};
  SetProfile(AsProfile(motion::JerkVelocityProfile::Plan(set_, velocity_target_, limits)));
}

void MotionCore::StartStopOrHalt(Command command) {
  brake_at_end_ = Get("I410") != 0;
  plc_ = command == Command::kStop ? PlcState::kStopping : PlcState::kDiscreteMotion;
  if (!Moving()) {
    // At standstill: success, the brake follows the brake-at-end setting (L1037, L1101).
    drive_ = Drive::kRest;
    set_.velocity = 0;
    set_.acceleration = 0;
    return;
  }
  const double dec = Get("I406");
  const double jerk = Get("I407");
  dynamics_limited_ = dec > Get("I11") || jerk > Get("I16");
  // Override ignored (L1068, L1941).
  SetProfile(AsProfile(motion::JerkVelocityProfile::Stop(set_, std::min(dec, Get("I11")),
                                                         std::min(jerk, Get("I16")))));
}

void MotionCore::StartMoveSpeed() {
  last_set_position_.reset();
  ReleaseBrake();
  plc_ = PlcState::kContinuousMotion;
  cyclic_only_at_start_ = Get("I119") == 1;
  movespeed_target_ = Get("I426");
  cmd_jerk_ = Get("I407");
  if (cyclic_only_at_start_) {
    // G-17 [P]: I405/I406 apply when the cyclic values are taken over only at start.
    movespeed_acceleration_ = Get("I405");
    movespeed_deceleration_ = Get("I406");
  } else {
    // Cyclic acceleration/deceleration 0: the last value is kept (L1497); before any, I11.
    if (Get("I216") > 0) movespeed_acceleration_ = Get("I216");
    if (Get("I217") > 0) movespeed_deceleration_ = Get("I217");
    if (movespeed_acceleration_ <= 0) movespeed_acceleration_ = Get("I11");
    if (movespeed_deceleration_ <= 0) movespeed_deceleration_ = Get("I11");
  }
  PlanMoveSpeed();
}

void MotionCore::UpdateMoveSpeed() {
  bool changed = OverrideFactor() != applied_override_;
  if (!cyclic_only_at_start_) {
    if (Get("I426") != movespeed_target_) {
      movespeed_target_ = Get("I426");
      changed = true;
    }
    if (Get("I216") > 0 && Get("I216") != movespeed_acceleration_) {
      movespeed_acceleration_ = Get("I216");
      changed = true;
    }
    if (Get("I217") > 0 && Get("I217") != movespeed_deceleration_) {
      movespeed_deceleration_ = Get("I217");
      changed = true;
    }
  }
  if (limit_blocked_direction_ != 0 && cmd_sign(movespeed_target_) == limit_blocked_direction_ &&
      velocity_target_ != 0) {
    changed = true;
  }
  if (changed && !limit_stop_) PlanMoveSpeed();
}

void MotionCore::PlanMoveSpeed() {
  double v = movespeed_target_;
  bool filtered = false;
  // L1507-1508, L1556: impermissible direction or towards an active limit switch → 0.
  if (!DirectionPermitted(cmd_sign(v)) ||
      (limit_blocked_direction_ != 0 && cmd_sign(v) == limit_blocked_direction_)) {
    v = 0;
    filtered = true;
  }
  const double factor = OverrideFactor();
  override_limited_ = filtered || std::abs(v) * factor > Get("I10");  // I193 (L1512)
  acceleration_limited_ =
      movespeed_acceleration_ > Get("I11") || movespeed_deceleration_ > Get("I11");  // I195
  dynamics_limited_ = cmd_jerk_ > Get("I16");                                        // I191
  PlanVelocity(v, movespeed_acceleration_, movespeed_deceleration_, cmd_jerk_);
}

}  // namespace drivegw::sim::stober
