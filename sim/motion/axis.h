// Simulated axis mechanics: active profile, demand and lagging actual state, stroke, in-target.
#pragma once

#include <limits>
#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "sim/motion/profile.h"

namespace drivegw::sim::motion {

// Which state a new motion starts from (linmot-mc.md §5.0 start rules).
enum class StartFrom {
  kDemand,                    // demand position and velocity: no jump (`010`, `011`, `017`, ...)
  kActualWithActualVelocity,  // actual position and velocity (`013`, "after a press command")
  kActualWithZeroVelocity,    // actual position, demand velocity forced to 0 (`014`, `016`)
};

// Which end of the stroke the demand position is beyond.
enum class StrokeLimit { kNone, kMin, kMax };

struct AxisConfig {
  // Mechanical stroke in the physical frame (the reported frame before any SetPosition). A
  // demand beyond it raises a limit event; the axis itself keeps moving (the family decides).
  double min_position_mm = -std::numeric_limits<double>::infinity();
  double max_position_mm = std::numeric_limits<double>::infinity();
  // In Target Position window, linmot-mc.md §6.8 D-10: default 100 × 0.1 µm.
  double in_target_window_mm = 0.01;
  // 0: actual = demand delayed by one Advance() tick (D-10). > 0: actual follows demand through
  // a first-order lag with this time constant (D-10 option; stober-motion.md §8.1).
  double lag_time_constant_s = 0;
};

// Stroke-limit event: the demand crossed from inside the stroke to beyond `limit`.
struct LimitEvent {
  StrokeLimit limit = StrokeLimit::kNone;
  double demand_position_mm = 0;  // reported frame, at the tick that detected it
};

// The mechanics a simulated drive runs its motion commands on. Pure computation: the caller
// advances time with Advance(dt) once per simulator tick (D-23); no clock reads, no threads.
// Positions are in the reported frame: physical position + reference_offset().
class Axis {
 public:
  // Default configuration, standing at 0.
  Axis() = default;
  // InvalidArgument for non-finite or inverted stroke, negative window or time constant.
  static absl::StatusOr<Axis> Create(const AxisConfig& config, double initial_position_mm = 0);

  // Advances the simulated time by `dt` seconds (<= 0: no-op): demand from the profile, actual
  // per D-10, stroke check at the end of the tick.
  void Advance(double dt);

  // Start state of a new motion per §5.0; kDemand includes the demand acceleration.
  Kinematics StartState(StartFrom from) const;

  // Replaces the active motion with `profile` (planned from StartState(...)), starting now at
  // profile time 0. The demand jumps to profile.At(0) (continuous when planned from kDemand).
  void Start(Profile profile);
  // Plans a VaProfile (D-21) from StartState(from) to `target_mm` and starts it.
  absl::Status MoveTo(double target_mm, const Limits& limits, StartFrom from = StartFrom::kDemand,
                      ZeroLimits zero_limits = ZeroLimits::kReject);
  // Decelerates from the demand state to standstill (`017`, `027`, quick stop).
  absl::Status Stop(double deceleration, ZeroLimits zero_limits = ZeroLimits::kReject);
  // Plans a JogProfile from StartState(from) and starts it.
  absl::Status Jog(double velocity, const Limits& limits, std::optional<double> bound_mm,
                   StartFrom from = StartFrom::kDemand,
                   ZeroLimits zero_limits = ZeroLimits::kReject);
  // Immediate stop, power off: set-point generation ends at once, velocity and acceleration 0,
  // the position stays where the actual position is (demand := actual; linmot-mc.md T9, D-05).
  void Halt();
  // Redefines the reported frame so that the actual position reads `position_mm` (homing,
  // `009` Master Homing, trinamic `$27`). Demand, target and a running profile move with it;
  // the following error is kept.
  void SetPosition(double position_mm);

  const Kinematics& demand() const { return demand_; }
  const Kinematics& actual() const { return actual_; }
  // Demand − actual position (linmot-mc.md §6.8: Difference Position 1B90h).
  double following_error() const { return demand_.position - actual_.position; }
  // End position of the active (or last) profile, reported frame.
  double target() const { return profile_.target(); }
  // Set-point generation running (status bit 13).
  bool motion_active() const { return profile_.Active(profile_time_); }
  // !motion_active and |actual − target| <= window (D-10; status bit 10).
  bool in_target() const;

  const Profile& profile() const { return profile_; }
  // Seconds since the active profile started.
  double profile_time() const { return profile_time_; }

  // reported = physical + reference_offset().
  double reference_offset() const { return reference_offset_; }
  double physical_position() const { return actual_.position - reference_offset_; }
  // Whether a reported-frame position lies inside the mechanical stroke.
  bool WithinStroke(double position_mm) const;

  // Which stroke end the demand is beyond now (level).
  StrokeLimit stroke_limit() const { return stroke_limit_; }
  // The oldest untaken crossing into a limit since the last call (edge, latched once).
  std::optional<LimitEvent> TakeLimitEvent();

  const AxisConfig& config() const { return config_; }

 private:
  void UpdateStroke();

  AxisConfig config_;
  Profile profile_;
  double profile_time_ = 0;
  Kinematics demand_;
  Kinematics actual_;
  double reference_offset_ = 0;
  StrokeLimit stroke_limit_ = StrokeLimit::kNone;
  std::optional<LimitEvent> pending_event_;
};

}  // namespace drivegw::sim::motion
