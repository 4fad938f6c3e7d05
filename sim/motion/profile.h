// Motion profiles as pure functions of time: the D-21 VA interpolator, stop and jog profiles.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace drivegw::sim::motion {

// Units throughout sim/motion: mm, mm/s, mm/s², seconds; families convert their wire units.

// Motion limits of one command. `acceleration` applies whenever |v| increases, `deceleration`
// whenever |v| decreases (linmot-mc.md §6.1 D-21). All three must be > 0 (see ZeroLimits).
struct Limits {
  double max_velocity = 0;  // mm/s
  double acceleration = 0;  // mm/s²
  double deceleration = 0;  // mm/s²
};

// Demand (or actual) state of an axis at one instant.
struct Kinematics {
  double position = 0;      // mm
  double velocity = 0;      // mm/s, signed
  double acceleration = 0;  // mm/s², signed
};

// One piece of a profile: for `duration` seconds the acceleration starts at `acceleration` and
// changes at the constant rate `jerk`. VA profiles use jerk = 0; jerk-limited S-curves (D-22,
// stober-motion.md §8.2) fit the same representation.
struct Segment {
  double duration = 0;      // s, >= 0
  double acceleration = 0;  // mm/s² at the start of the segment
  double jerk = 0;          // mm/s³
};

// How a planner treats a limit that is 0 (linmot-mc.md §15.1 item 9, D-42). Negative or
// non-finite limits are always InvalidArgument.
enum class ZeroLimits {
  // Gateway side (D-42): InvalidArgument naming the field, e.g. "va_profile.limits.acceleration".
  kReject,
  // Simulator side (D-42): hold the start position (velocity 0 at once) with the motion
  // "active" (endless profile) until the next command replaces it.
  kHoldPosition,
};

// A trajectory: a start state, a list of segments and what happens after the last one. Finite
// profiles end at target() with v = a = 0; endless ones (jog, infinite motion, D-42 hold)
// continue at their final velocity for ever. A value type; every planner below returns one.
class Profile {
 public:
  // Standing still at 0; not active.
  Profile() = default;

  // Standing still at `position` (duration 0, not active).
  static Profile Standstill(double position);
  // Holds `position` with v = 0 for ever (motion active; ZeroLimits::kHoldPosition).
  static Profile Hold(double position);
  // Generic constructor for planners: segments are integrated from `start`. A finite profile's
  // target() is `target` if given (planners snap to the exact commanded target so rounding
  // cannot drift), else the integrated end position; an endless one continues at the end
  // velocity, from `target` if given (a pass through a target, JerkProfile::PlanPass).
  static Profile FromSegments(Kinematics start, std::vector<Segment> segments, bool endless,
                              std::optional<double> target = std::nullopt);

  // State `t` seconds after the profile start; t < 0 reads as 0, t >= duration() gives the end
  // state (finite: target, v = a = 0; endless: coasting at the final velocity, a = 0). A time
  // within kEndTolerance of the end counts as the end, so summed segment durations and summed
  // ticks that differ only by rounding agree on when a motion finishes.
  Kinematics At(double t) const;
  // Time at which the motion is finished; +infinity for an endless profile.
  double duration() const;
  // End position; for endless profiles +/-infinity in the direction of travel (or the held
  // position for Hold()).
  double target() const { return target_; }
  bool endless() const { return endless_; }
  // True while set-point generation runs at time t (linmot-mc.md §6: Motion Active).
  bool Active(double t) const { return endless_ || t < segments_end_ - kEndTolerance; }

  // 1 ns: the resolution of drivegw::Clock, far below any simulator tick.
  static constexpr double kEndTolerance = 1e-9;

  const Kinematics& start() const { return start_; }
  const std::vector<Segment>& segments() const { return segments_; }

  // Moves the whole profile by `offset` mm (reference change while moving, Axis::SetPosition).
  void Shift(double offset);

 private:
  Kinematics start_;
  std::vector<Segment> segments_;
  std::vector<Kinematics> knots_;   // state at the start of each segment
  std::vector<double> knot_times_;  // start time of each segment
  double segments_end_ = 0;         // end time of the last segment
  Kinematics end_;                  // state after the last segment
  double target_ = 0;
  bool endless_ = false;
};

// VA interpolator, linmot-mc.md §6.1 reference model D-21: time-optimal, closed form, ends at
// the target with v = 0, |v| <= max_velocity; reverse-direction braking (step 2), overshoot
// when it cannot stop in time (step 3), over-speed braking (step 4), triangle/trapezoid
// (step 5). The start acceleration is ignored (VAI is not jerk-limited, step 7).
class VaProfile : public Profile {
 public:
  static absl::StatusOr<VaProfile> Plan(Kinematics start, double target, Limits limits,
                                        ZeroLimits zero_limits = ZeroLimits::kReject);

 private:
  explicit VaProfile(Profile profile) : Profile(std::move(profile)) {}
};

// Decelerates from a moving state to v = 0 with `deceleration` (linmot-mc.md §5.2 `017`, `027`;
// stober-motion.md §8.6 without jerk). From standstill: duration 0.
class StopProfile : public Profile {
 public:
  static absl::StatusOr<StopProfile> Plan(Kinematics start, double deceleration,
                                          ZeroLimits zero_limits = ZeroLimits::kReject);

 private:
  explicit StopProfile(Profile profile) : Profile(std::move(profile)) {}
};

// Constant-velocity motion: ramps from the start velocity to `velocity` (signed; its magnitude
// is clipped to limits.max_velocity) with acceleration/deceleration, through 0 if the sign
// changes, then cruises for ever (linmot-mc.md §5.3 `02E`/`02F` infinite motion, jogging in
// states 16/17; trinamic-sixpack.md §5.5 `$25`; stober-motion.md §8.5 MoveVelocity).
// With `bound`, it stops exactly at the bound instead (jog towards the maximal position): a VA
// move to `bound` at |velocity|; a bound not ahead in the direction of `velocity` means stop
// with the deceleration. velocity = 0 is a stop with the deceleration.
class JogProfile : public Profile {
 public:
  static absl::StatusOr<JogProfile> Plan(Kinematics start, double velocity, Limits limits,
                                         std::optional<double> bound = std::nullopt,
                                         ZeroLimits zero_limits = ZeroLimits::kReject);
  // True if |velocity| was clipped to limits.max_velocity (stober-motion.md §2.10 I190).
  bool velocity_limited() const { return velocity_limited_; }

 private:
  JogProfile(Profile profile, bool velocity_limited)
      : Profile(std::move(profile)), velocity_limited_(velocity_limited) {}
  bool velocity_limited_ = false;
};

}  // namespace drivegw::sim::motion
