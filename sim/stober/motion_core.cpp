// MotionCore: parameters, the cycle order, status evaluation and publication
// (stober-motion.md §2, §8.1; decisions 1141-1169). Command starts live in
// motion_core_commands.cpp, homing/cyclic/torque in motion_core_modes.cpp.
#include "sim/stober/motion_core.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "sim/motion/jerk_profile.h"

namespace drivegw::sim::stober {
namespace {

constexpr double kVelocityEpsilon = 1e-9;

bool IsCyclicSetValue(ParamId id) {
  static const ParamId kIds[] = {P("I421"), P("I426"), P("I428"), P("A601"),
                                 P("A592"), P("A638"), P("A558"), P("A593")};
  for (const ParamId& c : kIds) {
    if (c == id) return true;
  }
  return false;
}

// A541 (+ A515.6, A621.0-1) → I401 (§5.1 A541 row, §3.2-3.4 selection tables).
int CommandForMode(int mode, uint16_t control_word, int option_code) {
  switch (mode) {
    case 1:
      if ((control_word & cw::kRelative) == 0) return 1;  // MoveAbsolute
      return (option_code & 0x3) == 0x2 ? 2 : 3;          // A621.0 = 0, A621.1 = 1 → Relative
    case 3:
      return 8;
    case 4:
    case 10:
      return 9;
    case 6:
      return 6;
    case 7:
    case 8:
      return 10;
    case 9:
      return 7;
    default:
      return 0;
  }
}

}  // namespace

MotionCore::MotionCore(MotionCoreOptions options)
    : options_(std::move(options)), power_(options_.start_operation_enabled) {
  for (const ParamInfo& info : Catalogue()) values_[info.id] = info.default_value;
  was_enabled_ = power_.operation_enabled();
  if (was_enabled_) control_word_ = cw::kEnableOperationWord;
  values_[P("A515")] = control_word_;
  plc_ = was_enabled_ ? PlcState::kStandstill : PlcState::kDisabled;
  brake_engaged_ = Get("F00") == 1;
  profile_ = motion::Profile::Standstill(0);
  Publish();
}

double MotionCore::Get(ParamId id) const {
  auto it = values_.find(id);
  return it == values_.end() ? 0 : it->second;
}
double MotionCore::Get(const char* id) const { return Get(P(id)); }
void MotionCore::Set(const char* id, double value) { values_[P(id)] = value; }
double MotionCore::dt() const { return Get("A150") / 1000.0; }

absl::StatusOr<double> MotionCore::Read(ParamId id) const {
  if (FindParam(id) == nullptr) {
    return absl::NotFoundError(
        absl::StrCat("parameter ", ToString(id), " is not exposed by the simulated STOBER axis"));
  }
  return Get(id);
}

absl::Status MotionCore::Write(ParamId id, double value) {
  const ParamInfo* info = FindParam(id);
  const std::string name = ToString(id);
  if (info == nullptr) {
    return absl::NotFoundError(
        absl::StrCat("parameter ", name, " is not exposed by the simulated STOBER axis"));
  }
  if (info->access == Access::kReadOnly) {
    return absl::FailedPreconditionError(
        absl::StrCat(name, " (", std::string(info->name), ") is read-only"));
  }
  if (!std::isfinite(value)) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": value must be finite"));
  }
  if (info->type != ParamType::kReal && value != std::floor(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, " (", std::string(info->name), "): ", value, " is not an integer"));
  }
  if (value < info->min) {
    return absl::OutOfRangeError(absl::StrCat(name, " (", std::string(info->name), ") = ", value,
                                              " below minimum ", info->min));
  }
  if (value > info->max) {
    return absl::OutOfRangeError(absl::StrCat(name, " (", std::string(info->name), ") = ", value,
                                              " above maximum ", info->max));
  }
  // A lost cyclic telegram never reaches the drive (fault injection, §8.8).
  if (drop_cyclic_ && IsCyclicSetValue(id)) return absl::OkStatus();
  values_[id] = value;
  ApplySourceWrite(id, value);
  return absl::OkStatus();
}

// CiA 402 sources feed the motion-core inputs when they are written (§3 source columns;
// decision 1147 "write-through").
void MotionCore::ApplySourceWrite(ParamId id, double value) {
  const int mode = static_cast<int>(Get("A541"));
  auto recompute_command = [&] {
    Set("I401", CommandForMode(mode, control_word_, static_cast<int>(Get("A621"))));
  };
  if (id == P("A515")) {
    control_word_ = static_cast<uint16_t>(value);
    Set("I402", (control_word_ & cw::kExecute) != 0 ? 1 : 0);
    if (mode != 0) recompute_command();
  } else if (id == P("A541")) {
    recompute_command();
  } else if (id == P("A621")) {
    if (mode != 0) recompute_command();
  } else if (id == P("A567")) {
    Set("I403", value);
    if (mode == 8) (void)Write(P("I421"), value);  // CSP: cyclic set position (L1755)
  } else if (id == P("A601")) {
    (void)Write(P("I421"), value);
  } else if (id == P("A574")) {
    Set("I404", value);
  } else if (id == P("A576")) {
    Set("I405", value);
    Set("I216", value);
  } else if (id == P("A577")) {
    Set("I406", value);
    Set("I217", value);
  } else if (id == P("A590")) {
    Set("I407", value);
  } else if (id == P("A592") || id == P("A638")) {
    (void)Write(P("I426"), Get("A592") + Get("A638"));
  } else if (id == P("A558") || id == P("A593")) {
    Set("I428", Get("A558") + Get("A593"));
  } else if (id == P("A561")) {
    Set("I430", value);
    Set("I431", value);
  } else if (id == P("A569")) {
    Set("I34", value);
  } else if (id == P("A587[0]")) {
    Set("I32", value);
  } else if (id == P("A587[1]")) {
    Set("I33", value);
  } else if (id == P("A588")) {
    Set("I39", value);
  } else if (id == P("A340")) {
    Set("I230", value);
  } else if (id == P("I421") && command_ == Command::kCyclicPosition) {
    OnCyclicSetValue(value);
  } else if (id == P("I426") && command_ == Command::kCyclicSpeed) {
    OnCyclicSetValue(value);
  }
}

void MotionCore::Advance(int cycles) {
  for (int i = 0; i < cycles; ++i) Step();
}

void MotionCore::Step() {
  ++cycle_;
  StepPower();
  const bool execute = Get("I402") != 0;
  const bool edge = execute && !previous_execute_;
  previous_execute_ = execute;
  if (edge) {
    const auto command = static_cast<Command>(static_cast<int>(Get("I401")));
    // MC_DoNothing: no motion, no status, motion ID unchanged (L135); a running command
    // continues (G-12, decision 1148). Others start at once or are buffered (I409, 1162).
    if (command != Command::kDoNothing) {
      ++execute_edges_;
      OnExecuteEdge(command);
    }
  }
  UpdateContinuousInputs();
  Integrate();
  CheckLimitSwitches();
  EvaluateStatus();
  Publish();
}

void MotionCore::StepPower() {
  power_.Step(control_word_, !Moving());
  // G-04 [P]: the fault reset (control word bit 7) also leaves 7: Error stop at standstill.
  if (power_.fault_reset_edge() && plc_ == PlcState::kErrorStop && !Moving()) {
    plc_ = PlcState::kStandstill;
    error_ = false;
    cause_ = Cause::kNone;
    error_text_.clear();
  }
  const bool enabled = power_.operation_enabled();
  if (was_enabled_ && !enabled) {
    // Enable-off (G-18, decision 1146): cancel the running command without error, I89 = 0;
    // a buffered block is dropped with it (decision 1162).
    command_active_ = false;
    buffered_.reset();
    passing_ = false;
    plc_ = PlcState::kDisabled;
    if (power_.stopping() || !options_.enable_off_stops_immediately) {
      QuickStop();
    } else {
      drive_ = Drive::kRest;
      set_ = {actual_position_, 0, 0};
      actual_velocity_ = 0;
      torque_ = 0;
    }
    // §3.4.6 (L747-751): the set position stays the MoveAdditive base only if the axis had
    // reached the window I22 around it and stayed there.
    if (!(window_reached_ && !window_left_)) last_set_position_.reset();
  }
  if (!was_enabled_ && enabled) plc_ = PlcState::kStandstill;  // G-18: enable-on → 2
  if (!power_.power_stage_on() && !quick_stopping_) {
    if (drive_ != Drive::kRest) {
      drive_ = Drive::kRest;
      set_ = {actual_position_, 0, 0};
      actual_velocity_ = 0;
    }
    if (Get("F00") == 1) brake_engaged_ = true;
    brake_release_cycles_ = 0;
  }
  was_enabled_ = enabled;
}

void MotionCore::UpdateContinuousInputs() {
  if (!command_active_ || quick_stopping_) return;
  switch (command_) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive:
      // Override is taken over continuously (L357-359, G-25).
      if (OverrideFactor() != applied_override_ && !done_latched_) PlanPositioning();
      break;
    case Command::kMoveVelocity:
      if (drive_ == Drive::kProfile && OverrideFactor() != applied_override_) {
        PlanVelocity(cmd_velocity_, cmd_acceleration_, cmd_deceleration_, cmd_jerk_);
      }
      break;
    case Command::kMoveSpeed:
      UpdateMoveSpeed();
      break;
    default:
      break;
  }
}

void MotionCore::Integrate() {
  const double step = dt();
  const double previous_velocity = set_.velocity;
  if (brake_release_cycles_ > 0) {
    // The brake is still opening: the set values wait (decision 1157).
    if (--brake_release_cycles_ == 0) brake_engaged_ = false;
    set_.velocity = 0;
    set_.acceleration = 0;
  } else if (limit_stop_) {
    limit_stop_time_ += step;
    set_ = limit_stop_profile_.At(limit_stop_time_);
    if (!limit_stop_profile_.Active(limit_stop_time_)) {
      limit_stop_ = false;
      ResetInterpolator();
    }
  } else {
    switch (drive_) {
      case Drive::kRest:
        set_.velocity = 0;
        set_.acceleration = 0;
        break;
      case Drive::kProfile: {
        t_ += step;
        // §2.5: a pass at the End velocity, or the end of a block with a buffered successor,
        // inside this cycle (decisions 1161, 1162).
        const double end = passing_ ? pass_time_ : ramp_end_;
        const bool block_end = passing_ || (buffered_ && !stop_held_by_override_);
        if (block_end && t_ >= end - motion::Profile::kEndTolerance) {
          EndOfBlock(end);
        } else {
          set_ = profile_.At(t_);
        }
        break;
      }
      case Drive::kCyclicTakeover: {
        // I113 = cyclical takeover: the set velocity jumps, no ramps (L859).
        const double v =
            cmd_sign(Get("I404")) * std::min(std::abs(Get("I404")) * OverrideFactor(), Get("I10"));
        set_.acceleration = (v - previous_velocity) / step;
        set_.velocity = v;
        set_.position += v * step;
        velocity_target_ = v;
        break;
      }
      case Drive::kCyclicSpeed:
        StepCyclicSpeed();
        break;
      case Drive::kCyclicPosition:
        StepCyclicPosition();
        break;
      case Drive::kTorque:
        StepTorque();
        break;
    }
  }
  if (drive_ != Drive::kTorque || limit_stop_) {
    // Following model (§8.1 [P], G-28): first-order lag, 0 = ideal.
    const double tau = options_.following_time_constant_ms / 1000.0;
    if (tau <= 0) {
      actual_position_ = set_.position;
      actual_velocity_ = set_.velocity;
    } else {
      const double next =
          actual_position_ + (set_.position - actual_position_) * (1 - std::exp(-step / tau));
      actual_velocity_ = (next - actual_position_) / step;
      actual_position_ = next;
    }
  }
  if (quick_stopping_ && !Moving()) {
    quick_stopping_ = false;
    drive_ = Drive::kRest;
  }
  if (command_active_ && command_ == Command::kHome) StepHoming();
}

double MotionCore::cmd_sign(double v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); }

void MotionCore::CheckLimitSwitches() {
  const bool positive = PositiveLimitActive();
  const bool negative = NegativeLimitActive();
  Set("I441", positive ? 1 : 0);
  Set("I442", negative ? 1 : 0);
  if (limit_blocked_direction_ > 0 && !positive) limit_blocked_direction_ = 0;
  if (limit_blocked_direction_ < 0 && !negative) limit_blocked_direction_ = 0;
  if (!command_active_ || quick_stopping_) return;
  const double s = cmd_sign(set_.velocity);
  const bool hit = (positive && s > 0) || (negative && s < 0);
  if (!hit) return;
  const std::string which =
      s > 0 ? "positive hardware limit switch I441" : "negative hardware limit switch I442";
  switch (command_) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive:
    case Command::kMoveVelocity:
      // Limit-switch fault cancels the command (G-20): I91 = 1, I89 = 7, quick stop.
      Cancel(Cause::kLimitSwitchFault, absl::StrCat("limit-switch fault: ", which, " reached"));
      break;
    case Command::kHome:
      // The limit switch is the reference feature of type 2 (§4.2); for the others it is a
      // fault.
      if (homing_.type != 2) {
        Cancel(Cause::kLimitSwitchFault, absl::StrCat("limit-switch fault: ", which, " reached"));
      }
      break;
    case Command::kCyclicSpeed:
    case Command::kMoveSpeed:
    case Command::kTorqueControl:
    case Command::kCyclicPosition:
      // 7-10: quick stop by limit-switch fault, then set values towards the switch are ignored
      // and those away from it followed (L1360, L1396, L1507, L1650; CT-63; decision 1153).
      if (limit_blocked_direction_ == 0) {
        limit_blocked_direction_ = static_cast<int>(s);
        StartLimitStop();
      }
      break;
    default:
      break;
  }
}

void MotionCore::StartLimitStop() {
  DropForeignAcceleration();
  const double dec =
      options_.quick_stop_deceleration > 0 ? options_.quick_stop_deceleration : Get("I11");
  const double jerk = options_.quick_stop_jerk > 0 ? options_.quick_stop_jerk : Get("I16");
  absl::StatusOr<motion::JerkVelocityProfile> stop =
      motion::JerkVelocityProfile::Stop(set_, dec, jerk);
  if (!stop.ok()) {
    set_.velocity = 0;
    set_.acceleration = 0;
    ResetInterpolator();
    return;
  }
  limit_stop_profile_ = *stop;
  limit_stop_time_ = 0;
  limit_stop_ = true;
  torque_ = 0;
}

void MotionCore::EvaluateStatus() {
  const double window = Get("I22");
  // MoveAdditive base history (§3.4.6): window around the last valid set position.
  if (last_set_position_) {
    if (std::abs(actual_position_ - *last_set_position_) <= window) {
      window_reached_ = true;
    } else if (window_reached_) {
      window_left_ = true;
    }
  }
  standstill_ = !Moving() && std::abs(actual_velocity_) <= Get("C40");
  profile_done_ = false;
  speed_reached_ = false;
  in_window_ = false;
  if (brake_timer_) {
    if (--*brake_timer_ <= 0) {
      brake_timer_.reset();
      if (Get("F00") == 1) brake_engaged_ = true;
    }
  }
  if (!command_active_) return;
  const double c40 = Get("C40");
  const bool after_start = cycle_ > start_cycle_;
  bool done_now = false;
  switch (command_) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive: {
      profile_done_ = drive_ == Drive::kProfile && !stop_held_by_override_ &&
                      !profile_.Active(t_) && set_.position == target_;
      in_window_ = std::abs(actual_position_ - target_) <= window;  // G-14: instantaneous
      window_cycles_ = in_window_ ? window_cycles_ + 1 : 0;
      // G-13 (a): I183 while the profile cruises at the commanded velocity.
      const double cruise = std::min(cmd_velocity_ * OverrideFactor(), Get("I10"));
      speed_reached_ = drive_ == Drive::kProfile && profile_.Active(t_) && cruise > 0 &&
                       std::abs(std::abs(set_.velocity) - cruise) <= 1e-9 * cruise &&
                       std::abs(set_.acceleration) <= 1e-6 &&
                       std::abs(actual_velocity_ - set_.velocity) <= c40;
      // Done: I85 and I180 held for I87 (L390; G-14).
      const double held_ms = (window_cycles_ - 1) * Get("A150");
      done_now = profile_done_ && window_cycles_ >= 1 && held_ms >= Get("I87") - 1e-9;
      if (done_latched_ || (done_now && after_start)) {
        if (!done_latched_) {
          done_latched_ = true;
          plc_ = PlcState::kStandstill;  // G-03
          velocity_limited_ = dynamics_limited_ = override_limited_ = false;
          ArmBrake();
        }
        done_ = true;
      }
      break;
    }
    case Command::kMoveVelocity:
    case Command::kMoveSpeed: {
      if (drive_ == Drive::kCyclicTakeover) {
        profile_done_ = true;
      } else {
        profile_done_ =
            drive_ == Drive::kProfile && t_ >= ramp_end_ - motion::Profile::kEndTolerance;
      }
      speed_reached_ = profile_done_ && std::abs(actual_velocity_ - set_.velocity) <= c40 &&
                       std::abs(set_.velocity - velocity_target_) <= c40;
      done_ = profile_done_ && speed_reached_ && after_start;
      break;
    }
    case Command::kStop:
    case Command::kHalt: {
      profile_done_ = !Moving() && set_.velocity == 0;
      speed_reached_ = std::abs(actual_velocity_) <= c40;  // G-13 (c)
      const bool was_done = done_;
      done_ = profile_done_ && standstill_ && after_start;
      if (done_ && !was_done) ArmBrake();
      // Stop: 6 until standstill and Execute = 0 (L1043); Halt: 3 likewise (L1918); then 2.
      if (standstill_ && Get("I402") == 0 &&
          (plc_ == PlcState::kStopping || plc_ == PlcState::kDiscreteMotion)) {
        plc_ = PlcState::kStandstill;
      }
      break;
    }
    case Command::kHome:
      break;  // StepHoming sets done_; I183 and I85 stay 0 (L1299)
    case Command::kCyclicSpeed:
    case Command::kCyclicPosition:
    case Command::kTorqueControl:
      // G-32: Done from cycle k+2; I183/I85 unused (L1421, L1713, L1847).
      done_ = cycle_ >= start_cycle_ + 2;
      break;
    default:
      break;
  }
}

void MotionCore::ArmBrake() {
  // Engage brake at the end (I410) after I42; Done comes first (L372-373, L390).
  if (!brake_at_end_ || Get("F00") != 1) return;
  brake_timer_ = static_cast<int>(std::lround(Get("I42") / Get("A150")));
  if (*brake_timer_ <= 0) {
    brake_timer_.reset();
    brake_engaged_ = true;
  }
}

void MotionCore::Publish() {
  // §2.7: at every start I91 = 0, I90 = 0 and I92 = 0 for at least one cycle, and I183 drops.
  const bool start_cycle = command_started_ && cycle_ == start_cycle_;
  const bool torque = command_ == Command::kTorqueControl;
  Set("I91", (!start_cycle && error_ && !torque) ? 1 : 0);
  Set("I90", (!start_cycle && error_ && !torque) ? static_cast<int>(cause_) : 0);
  Set("I92", (!start_cycle && done_) ? 1 : 0);
  Set("I85", profile_done_ ? 1 : 0);
  Set("I183", (!start_cycle && speed_reached_) ? 1 : 0);
  Set("I180", in_window_ ? 1 : 0);
  Set("I199", standstill_ ? 1 : 0);
  Set("I89", static_cast<int>(plc_));
  // G-08 (decision 1163): 0 no block moving, 1 a block running, 2 running with a buffered
  // subsequent block.
  Set("I83", buffered_ ? 2 : (command_active_ && Moving() ? 1 : 0));
  Set("I190", velocity_limited_ ? 1 : 0);
  Set("I191", dynamics_limited_ ? 1 : 0);
  Set("I192", position_limited_ ? 1 : 0);
  Set("I193", override_limited_ ? 1 : 0);
  Set("I194", torque_limited_ ? 1 : 0);
  Set("I195", acceleration_limited_ ? 1 : 0);
  const double shown_actual = Endless() ? Modulo(actual_position_) : actual_position_;
  Set("I80", shown_actual);
  Set("A545", shown_actual);
  Set("I96", Endless() ? Modulo(set_.position) : set_.position);
  Set("E07", set_.velocity);
  Set("I88", actual_velocity_);
  Set("E90", torque_);
  Set("A542", Get("A541"));
  StatusWordInputs in;
  const int mode = static_cast<int>(Get("A541"));
  in.warning = event78_warning_ || Get("I441") != 0 || Get("I442") != 0;
  in.target_reached = Get("I92") != 0;
  in.internal_limit_active = velocity_limited_ || dynamics_limited_ || position_limited_ ||
                             override_limited_ || torque_limited_ || acceleration_limited_ ||
                             Get("I441") != 0 || Get("I442") != 0;
  const bool accepted = command_started_ && command_active_ && !error_;
  switch (mode) {
    case 1:  // profile position: 12 set-point acknowledge, 13 following error (decision 1144)
      in.op_mode_bit12 = accepted && Get("I402") != 0;
      in.op_mode_bit13 = Get("I91") != 0;
      break;
    case 3:  // profile velocity: 12 speed = 0
      in.op_mode_bit12 = standstill_;
      in.op_mode_bit13 = Get("I91") != 0;
      break;
    case 6:  // homing: 12 homing attained, 13 homing error
      in.op_mode_bit12 = Get("I86") != 0 && command_ == Command::kHome && done_;
      in.op_mode_bit13 = command_ == Command::kHome && Get("I91") != 0;
      break;
    case 4:
    case 7:
    case 8:
    case 9:
    case 10:  // cyclic/torque modes: 12 drive follows the command value
      in.op_mode_bit12 = accepted;
      break;
    default:
      break;
  }
  Set("A516", power_.StatusWord(in));
}

// --- Helpers -------------------------------------------------------------------------------

bool MotionCore::Moving() const {
  if (limit_stop_) return true;
  switch (drive_) {
    case Drive::kRest:
      return false;
    case Drive::kProfile:
      return profile_.Active(t_) || set_.velocity != 0;
    default:
      return true;
  }
}

double MotionCore::Modulo(double x) const {
  const double length = Get("I01");
  double m = std::fmod(x, length);
  if (m < 0) m += length;
  if (m >= length) m = 0;  // G-33: reported range [0, I01)
  return m;
}

bool MotionCore::SoftwareLimitsUsed() const {
  // §2.11: only on a limited axis; I50 <= I51 reads as "no software limits" (decision 1149).
  return !Endless() && Get("I50") > Get("I51");
}

bool MotionCore::DirectionPermitted(double direction) const {
  // I04 (G-21 [P]): 0 both, 1 positive only, 2 negative only; applies to endless axes for the
  // denials of 1-4 (L228) and to the cyclic/torque set values on any axis (L1361).
  const int permitted = static_cast<int>(Get("I04"));
  if (direction > 0) return permitted != 2;
  if (direction < 0) return permitted != 1;
  return true;
}

bool MotionCore::PositiveLimitActive() const {
  if (forced_positive_limit_) return *forced_positive_limit_;
  return options_.positive_limit_switch && MachinePosition() >= *options_.positive_limit_switch;
}

bool MotionCore::NegativeLimitActive() const {
  if (forced_negative_limit_) return *forced_negative_limit_;
  return options_.negative_limit_switch && MachinePosition() <= *options_.negative_limit_switch;
}

bool MotionCore::ReferenceSwitchActive() const {
  if (forced_reference_switch_) return *forced_reference_switch_;
  if (!options_.reference_switch) return false;
  const double x = MachinePosition();
  return x >= options_.reference_switch->first && x <= options_.reference_switch->second;
}

void MotionCore::ForceLimitSwitch(bool positive, std::optional<bool> active) {
  (positive ? forced_positive_limit_ : forced_negative_limit_) = active;
  Set("I441", PositiveLimitActive() ? 1 : 0);
  Set("I442", NegativeLimitActive() ? 1 : 0);
}

void MotionCore::ForceReferenceSwitch(std::optional<bool> active) {
  forced_reference_switch_ = active;
}

void MotionCore::InjectFault() { power_.RaiseFault(); }

void MotionCore::AbortConnection(int option, uint16_t emcy_code, const std::string& reason) {
  const char* reaction = "no action";
  switch (option) {
    case 1:
      reaction = "fault";
      power_.RaiseFault();
      break;
    case 2:
      reaction = "disable voltage";
      power_.LocalCommand(cw::kDisableVoltageWord);
      break;
    case 3:
      reaction = "quick stop";
      power_.LocalCommand(cw::kQuickStopWord);
      break;
    default:
      break;
  }
  events_.push_back({cycle_, 0, emcy_code,
                     absl::StrCat(reason, ": 6007h = ", option, " ", reaction, " at position ",
                                  actual_position_, ", velocity ", actual_velocity_)});
}

void MotionCore::SetReferenced(bool referenced) {
  Set("I86", referenced ? 1 : 0);
  Publish();
}

void MotionCore::SetActualPosition(double position) {
  // Commissioning at rest: the machine position moves with it (the sensors stay put).
  set_ = {position, 0, 0};
  actual_position_ = position;
  actual_velocity_ = 0;
  drive_ = Drive::kRest;
  profile_ = motion::Profile::Standstill(position);
  last_set_position_.reset();
  Publish();
}

}  // namespace drivegw::sim::stober
