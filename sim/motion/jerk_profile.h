// Jerk-limited ("S-curve") profiles: point-to-point and velocity planners that re-plan from any
// state (position, velocity, acceleration) without an acceleration step (stober-motion.md §8.2,
// §2.4 "start from motion"). Method and rounding: docs/decisions/302-sim-motion-jerk-profiles.md.
#pragma once

#include <utility>

#include "absl/status/statusor.h"
#include "sim/motion/profile.h"

namespace drivegw::sim::motion {

// Limits of one jerk-limited command (stober-motion.md §8.2, L236-241: the family passes the
// already clipped values, e.g. min(Acceleration, I11)). `acceleration` bounds |a| while |v| grows,
// `deceleration` while |v| shrinks. All must be finite and > 0, except `jerk` = +infinity, which
// means "no jerk limit": the planners then delegate to VaProfile / JogProfile / StopProfile
// (acceleration steps allowed, the start acceleration is ignored as in linmot-mc.md D-21 step 7).
struct JerkLimits {
  double max_velocity = 0;  // mm/s
  double acceleration = 0;  // mm/s²
  double deceleration = 0;  // mm/s²
  double jerk = 0;          // mm/s³, or +infinity
};

// Point-to-point S-curve from any start state to `target`, ending there with v = a = 0.
// |v| <= max_velocity (a faster start first decelerates to it), |a| within acceleration /
// deceleration, |jerk| <= jerk, acceleration continuous at the start. When the target lies behind
// the direction of motion, or cannot be reached without exceeding deceleration/jerk, the profile
// first stops (v = 0 with a = 0) and then moves back: the intermediate stop of stober-motion.md
// §8.2 (L304-306). Short moves reach neither max_velocity nor the acceleration limits.
// A start acceleration beyond the limits is brought back with the full jerk (never stepped).
class JerkProfile : public Profile {
 public:
  static absl::StatusOr<JerkProfile> Plan(Kinematics start, double target, JerkLimits limits);
  // Point-to-point S-curve that passes `target` at the End velocity `end_velocity` (a magnitude
  // >= 0, stober-motion.md §3.2 Target L364-373, I429) instead of stopping there: it arrives
  // with v = ±end_velocity (the sign is the direction of the final approach, §8.2 [P]) and
  // a = 0, so a following block continues without an acceleration step. The profile is endless:
  // after pass_time() it coasts at pass_velocity() until the caller replaces it (the motion core
  // decides what follows, decision 1161). Rules of decision 1161:
  //  - end_velocity is clipped to max_velocity;
  //  - when the target lies behind the motion, or the axis cannot slow to end_velocity before
  //    it, the profile first stops (intermediate stop, as Plan) and approaches from there;
  //  - when the distance is too short to reach end_velocity, the target is passed at the
  //    highest velocity reachable (accelerating all the way, a = 0 at the pass);
  //  - at rest on the target there is nothing to pass: a standstill profile (passes() false).
  // end_velocity == 0 is Plan(). Infinite jerk is InvalidArgument (no VA form of a pass).
  static absl::StatusOr<JerkProfile> PlanPass(Kinematics start, double target, double end_velocity,
                                              JerkLimits limits);
  // True if the profile passes through an intermediate stop before heading for the target.
  bool intermediate_stop() const { return intermediate_stop_; }
  // PlanPass: true if the target is passed with v != 0; pass_time() is then the time of the
  // pass (the end of the segments), pass_velocity() the signed velocity there and
  // pass_position() the target (At(pass_time()) returns exactly that state).
  bool passes() const { return passes_; }
  double pass_time() const { return pass_time_; }
  double pass_velocity() const { return pass_velocity_; }
  double pass_position() const { return pass_position_; }

 private:
  JerkProfile(Profile profile, bool intermediate_stop)
      : Profile(std::move(profile)), intermediate_stop_(intermediate_stop) {}
  bool intermediate_stop_ = false;
  bool passes_ = false;
  double pass_time_ = 0;
  double pass_velocity_ = 0;
  double pass_position_ = 0;
};

// Velocity S-curve (stober-motion.md §8.5 MoveVelocity/MoveSpeed, §8.6 Stop/Halt): from any state
// to the signed `velocity` (magnitude clipped to max_velocity, velocity_limited() says so, I190)
// with a = 0. A sign change goes through v = 0 with a = 0 (L917-919). Endless (coasting at the
// target velocity) when velocity != 0; finite, ending at rest, when velocity == 0.
class JerkVelocityProfile : public Profile {
 public:
  static absl::StatusOr<JerkVelocityProfile> Plan(Kinematics start, double velocity,
                                                  JerkLimits limits);
  // Stop / Halt: decelerate to rest with `deceleration` and `jerk` only (L1024-1025). Its target()
  // is the rest position, so target() - start.position is the stopping distance (used to pick
  // the number of revolutions on an endless axis, §8.3 L308).
  static absl::StatusOr<JerkVelocityProfile> Stop(Kinematics start, double deceleration,
                                                  double jerk);
  // True if |velocity| was clipped to limits.max_velocity (stober-motion.md §2.10 I190).
  bool velocity_limited() const { return velocity_limited_; }

 private:
  JerkVelocityProfile(Profile profile, bool velocity_limited)
      : Profile(std::move(profile)), velocity_limited_(velocity_limited) {}
  bool velocity_limited_ = false;
};

}  // namespace drivegw::sim::motion
