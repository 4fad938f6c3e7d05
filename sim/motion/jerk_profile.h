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
  // True if the profile passes through an intermediate stop before heading for the target.
  bool intermediate_stop() const { return intermediate_stop_; }

 private:
  JerkProfile(Profile profile, bool intermediate_stop)
      : Profile(std::move(profile)), intermediate_stop_(intermediate_stop) {}
  bool intermediate_stop_ = false;
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
