// Axis mechanics: demand from the active profile, actual per D-10, stroke and in-target flags.
#include "sim/motion/axis.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::motion {
namespace {

// D-10 option: x' = (u − x) / tau, solved exactly for a polynomial input u of degree <= 3 over
// `h` seconds (one piece of a profile segment). With the particular solution
// x_p = u − tau·u' + tau²·u" − tau³·u"' the state is x(h) = x_p(h) + (x(0) − x_p(0))·e^(−h/tau).
// Position, velocity and acceleration are each lagged (their inputs are u, u', u").
void LagPiece(Kinematics& x, const Kinematics& u0, double jerk, double h, double tau) {
  const double e = std::exp(-h / tau);
  const Kinematics u1{
      u0.position + u0.velocity * h + u0.acceleration * h * h / 2 + jerk * h * h * h / 6,
      u0.velocity + u0.acceleration * h + jerk * h * h / 2, u0.acceleration + jerk * h};
  auto particular = [&](const Kinematics& u) {
    return Kinematics{
        u.position - tau * u.velocity + tau * tau * u.acceleration - tau * tau * tau * jerk,
        u.velocity - tau * u.acceleration + tau * tau * jerk, u.acceleration - tau * jerk};
  };
  const Kinematics p0 = particular(u0);
  const Kinematics p1 = particular(u1);
  x.position = p1.position + (x.position - p0.position) * e;
  x.velocity = p1.velocity + (x.velocity - p0.velocity) * e;
  x.acceleration = p1.acceleration + (x.acceleration - p0.acceleration) * e;
}

}  // namespace

absl::StatusOr<Axis> Axis::Create(const AxisConfig& config, double initial_position_mm) {
  if (std::isnan(config.min_position_mm) || std::isnan(config.max_position_mm) ||
      config.min_position_mm > config.max_position_mm) {
    return absl::InvalidArgumentError(
        absl::StrCat("axis.stroke: min_position_mm=", config.min_position_mm,
                     " max_position_mm=", config.max_position_mm, " must satisfy min <= max"));
  }
  if (!std::isfinite(config.in_target_window_mm) || config.in_target_window_mm < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "axis.in_target_window_mm: ", config.in_target_window_mm, " must be finite and >= 0"));
  }
  if (!std::isfinite(config.lag_time_constant_s) || config.lag_time_constant_s < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "axis.lag_time_constant_s: ", config.lag_time_constant_s, " must be finite and >= 0"));
  }
  if (!std::isfinite(initial_position_mm)) {
    return absl::InvalidArgumentError(
        absl::StrCat("axis.initial_position_mm: ", initial_position_mm, " is not finite"));
  }
  Axis axis;
  axis.config_ = config;
  axis.profile_ = Profile::Standstill(initial_position_mm);
  axis.demand_ = {initial_position_mm, 0, 0};
  axis.actual_ = axis.demand_;
  axis.UpdateStroke();
  return axis;
}

void Axis::Advance(double dt) {
  if (!(dt > 0)) return;
  const double t0 = profile_time_;
  const double t1 = t0 + dt;
  const double tau = config_.lag_time_constant_s;
  if (tau == 0) {
    // linmot-mc.md §6.8 D-10: actual = demand delayed by one simulator tick.
    actual_ = demand_;
  } else {
    // D-10 option: integrate the lag exactly, piece by piece between segment boundaries, so
    // many small ticks and few large ones give the same actual values.
    double ta = t0;
    double segment_start = 0;
    for (const Segment& segment : profile_.segments()) {
      const double segment_end = segment_start + segment.duration;
      if (segment_end > ta && ta < t1) {
        const double tb = std::min(segment_end, t1);
        const double jerk = profile_.Active(ta) ? segment.jerk : 0;
        LagPiece(actual_, profile_.At(ta), jerk, tb - ta, tau);
        ta = tb;
      }
      segment_start = segment_end;
    }
    // After the last segment: the end state (finite) or cruising (endless), no jerk.
    if (ta < t1) LagPiece(actual_, profile_.At(ta), 0, t1 - ta, tau);
  }
  profile_time_ = t1;
  demand_ = profile_.At(profile_time_);
  UpdateStroke();
}

Kinematics Axis::StartState(StartFrom from) const {
  switch (from) {
    case StartFrom::kDemand:
      return demand_;
    case StartFrom::kActualWithActualVelocity:
      return {actual_.position, actual_.velocity, actual_.acceleration};
    case StartFrom::kActualWithZeroVelocity:
      return {actual_.position, 0, 0};
  }
  return demand_;
}

void Axis::Start(Profile profile) {
  profile_ = std::move(profile);
  profile_time_ = 0;
  demand_ = profile_.At(0);
  UpdateStroke();
}

absl::Status Axis::MoveTo(double target_mm, const Limits& limits, StartFrom from,
                          ZeroLimits zero_limits) {
  auto profile = VaProfile::Plan(StartState(from), target_mm, limits, zero_limits);
  if (!profile.ok()) return profile.status();
  Start(*std::move(profile));
  return absl::OkStatus();
}

absl::Status Axis::Stop(double deceleration, ZeroLimits zero_limits) {
  auto profile = StopProfile::Plan(demand_, deceleration, zero_limits);
  if (!profile.ok()) return profile.status();
  Start(*std::move(profile));
  return absl::OkStatus();
}

absl::Status Axis::Jog(double velocity, const Limits& limits, std::optional<double> bound_mm,
                       StartFrom from, ZeroLimits zero_limits) {
  auto profile = JogProfile::Plan(StartState(from), velocity, limits, bound_mm, zero_limits);
  if (!profile.ok()) return profile.status();
  Start(*std::move(profile));
  return absl::OkStatus();
}

void Axis::Halt() {
  // Set-point generation stops at once and the slider stays where it is (power off): demand
  // takes the actual position so that re-enabling does not jump.
  actual_.velocity = 0;
  actual_.acceleration = 0;
  demand_ = {actual_.position, 0, 0};
  profile_ = Profile::Standstill(actual_.position);
  profile_time_ = 0;
  UpdateStroke();
}

void Axis::SetPosition(double position_mm) {
  const double offset = position_mm - actual_.position;
  actual_.position = position_mm;
  demand_.position += offset;
  profile_.Shift(offset);
  reference_offset_ += offset;
  // The stroke is physical; a frame change cannot cross it.
}

bool Axis::in_target() const {
  return !motion_active() && std::abs(actual_.position - target()) <= config_.in_target_window_mm;
}

bool Axis::WithinStroke(double position_mm) const {
  const double physical = position_mm - reference_offset_;
  return physical >= config_.min_position_mm && physical <= config_.max_position_mm;
}

std::optional<LimitEvent> Axis::TakeLimitEvent() {
  std::optional<LimitEvent> event = pending_event_;
  pending_event_.reset();
  return event;
}

void Axis::UpdateStroke() {
  // Sampled once per tick, as a drive evaluates its limits once per cycle (D-23).
  const double physical = demand_.position - reference_offset_;
  StrokeLimit level = StrokeLimit::kNone;
  if (physical < config_.min_position_mm) level = StrokeLimit::kMin;
  if (physical > config_.max_position_mm) level = StrokeLimit::kMax;
  if (level != StrokeLimit::kNone && level != stroke_limit_ && !pending_event_.has_value()) {
    pending_event_ = LimitEvent{level, demand_.position};
  }
  stroke_limit_ = level;
}

}  // namespace drivegw::sim::motion
