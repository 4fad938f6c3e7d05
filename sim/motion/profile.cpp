// Profile evaluation and the VA, stop and jog planners (linmot-mc.md §6.1 D-21).
#include "sim/motion/profile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace drivegw::sim::motion {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double Sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

// Relative slack for closed-form comparisons: a re-plan from a state that lies exactly on a
// braking curve must not be mistaken for "cannot stop in time" because of rounding.
double Slack(double magnitude) { return 1e-12 * std::max(1.0, magnitude); }

absl::Status CheckFinite(const char* where, const char* field, double value) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(where, ".", field, ": ", value, " is not finite"));
}

absl::Status CheckStart(const char* where, const Kinematics& start) {
  if (auto s = CheckFinite(where, "start.position", start.position); !s.ok()) return s;
  if (auto s = CheckFinite(where, "start.velocity", start.velocity); !s.ok()) return s;
  return CheckFinite(where, "start.acceleration", start.acceleration);
}

// Validates one limit. Returns OK with *zero = true when the value is 0 and the policy is
// kHoldPosition (D-42); InvalidArgument when negative, non-finite, or 0 under kReject.
absl::Status CheckLimit(const char* where, const char* field, double value, ZeroLimits policy,
                        bool* zero) {
  if (!std::isfinite(value) || value < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".", field, ": ", value, " must be finite and > 0"));
  }
  if (value == 0) {
    // linmot-mc.md D-42: the gateway rejects zero limits; the simulator holds position.
    if (policy == ZeroLimits::kReject) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".", field, ": 0 must be > 0"));
    }
    *zero = true;
  }
  return absl::OkStatus();
}

absl::Status CheckLimits(const char* where, const Limits& limits, ZeroLimits policy, bool* zero) {
  if (auto s = CheckLimit(where, "limits.max_velocity", limits.max_velocity, policy, zero);
      !s.ok()) {
    return s;
  }
  if (auto s = CheckLimit(where, "limits.acceleration", limits.acceleration, policy, zero);
      !s.ok()) {
    return s;
  }
  return CheckLimit(where, "limits.deceleration", limits.deceleration, policy, zero);
}

// Collects constant-acceleration segments, dropping empty ones.
class SegmentBuilder {
 public:
  void Add(double duration, double acceleration) {
    if (duration > 0) segments_.push_back({duration, acceleration, 0});
  }
  std::vector<Segment> Take() { return std::move(segments_); }

 private:
  std::vector<Segment> segments_;
};

// linmot-mc.md §6.1 D-21 step 5: from speed u = |v| <= vmax in direction `dir`, distance D to go.
void PlanFromSpeed(SegmentBuilder& b, double dir, double u, double distance, const Limits& l) {
  const double a = l.acceleration;
  const double d = l.deceleration;
  const double vmax = l.max_velocity;
  // Rounding can leave D a hair below the braking distance u²/2d; brake at once in that case.
  distance = std::max(distance, u * u / (2 * d));
  const double vp = std::sqrt((2 * a * d * distance + d * u * u) / (a + d));
  if (vp <= vmax) {
    // Triangle: accelerate u -> vp at a, decelerate vp -> 0 at d.
    b.Add((vp - u) / a, dir * a);
    b.Add(vp / d, -dir * d);
    return;
  }
  // Trapezoid: accelerate to vmax, cruise, decelerate at d.
  const double accel_distance = (vmax * vmax - u * u) / (2 * a);
  const double decel_distance = vmax * vmax / (2 * d);
  b.Add((vmax - u) / a, dir * a);
  b.Add(std::max(0.0, (distance - accel_distance - decel_distance) / vmax), 0);
  b.Add(vmax / d, -dir * d);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Profile

Profile Profile::Standstill(double position) {
  return FromSegments({position, 0, 0}, {}, /*endless=*/false, position);
}

Profile Profile::Hold(double position) {
  return FromSegments({position, 0, 0}, {}, /*endless=*/true);
}

Profile Profile::FromSegments(Kinematics start, std::vector<Segment> segments, bool endless,
                              std::optional<double> target) {
  Profile p;
  p.start_ = start;
  p.endless_ = endless;
  p.knots_.reserve(segments.size());
  p.knot_times_.reserve(segments.size());
  double t = 0;
  double pos = start.position;
  double vel = start.velocity;
  for (const Segment& s : segments) {
    p.knots_.push_back({pos, vel, s.acceleration});
    p.knot_times_.push_back(t);
    const double tau = s.duration;
    pos += vel * tau + s.acceleration * tau * tau / 2 + s.jerk * tau * tau * tau / 6;
    vel += s.acceleration * tau + s.jerk * tau * tau / 2;
    t += tau;
  }
  p.segments_ = std::move(segments);
  p.segments_end_ = t;
  if (endless) {
    p.end_ = {target.value_or(pos), vel, 0};
    p.target_ = vel > 0 ? kInf : (vel < 0 ? -kInf : pos);
  } else {
    p.target_ = target.value_or(pos);
    p.end_ = {p.target_, 0, 0};
  }
  return p;
}

Kinematics Profile::At(double t) const {
  if (!(t > 0)) t = 0;
  if (!endless_ && t >= segments_end_ - kEndTolerance) return end_;
  if (t >= segments_end_) {
    return {end_.position + end_.velocity * (t - segments_end_), end_.velocity, 0};
  }
  // Few segments (<= 7 for an S-curve): a linear scan from the back is cheapest.
  size_t i = knots_.size() - 1;
  while (i > 0 && knot_times_[i] > t) --i;
  const Kinematics& k = knots_[i];
  const double jerk = segments_[i].jerk;
  const double tau = t - knot_times_[i];
  return {
      k.position + k.velocity * tau + k.acceleration * tau * tau / 2 + jerk * tau * tau * tau / 6,
      k.velocity + k.acceleration * tau + jerk * tau * tau / 2, k.acceleration + jerk * tau};
}

double Profile::duration() const { return endless_ ? kInf : segments_end_; }

void Profile::Shift(double offset) {
  start_.position += offset;
  for (Kinematics& k : knots_) k.position += offset;
  end_.position += offset;
  target_ += offset;  // +/-infinity stays
}

// ---------------------------------------------------------------------------------------------
// VaProfile: linmot-mc.md §6.1 D-21

absl::StatusOr<VaProfile> VaProfile::Plan(Kinematics start, double target, Limits limits,
                                          ZeroLimits zero_limits) {
  constexpr const char* kWhere = "va_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckFinite(kWhere, "target", target); !s.ok()) return s;
  bool zero = false;
  if (auto s = CheckLimits(kWhere, limits, zero_limits, &zero); !s.ok()) return s;
  if (zero) return VaProfile(Hold(start.position));  // D-42 simulator behaviour

  const double d = limits.deceleration;
  double p = start.position;
  double v = start.velocity;
  double s = target - p;
  // Step 1: nothing to do; Motion Active stays 0.
  if (s == 0 && v == 0) return VaProfile(Standstill(target));

  SegmentBuilder b;
  const double stop_distance = v * v / (2 * d);
  // Step 2: moving away from the target (or standing on it while moving): brake to 0 first,
  // travelling v²/2d further away. Step 3: cannot stop in time: brake to 0, overshooting.
  if ((v != 0 && Sign(v) != Sign(s)) || stop_distance > std::abs(s) + Slack(std::abs(s))) {
    b.Add(std::abs(v) / d, -Sign(v) * d);
    p += Sign(v) * stop_distance;
    v = 0;
    s = target - p;
  }
  const double dir = Sign(s);
  double u = std::abs(v);
  double distance = std::abs(s);
  if (distance > 0) {
    // Step 4: faster than vmax: brake to vmax at d, then continue with step 5.
    if (u > limits.max_velocity) {
      const double vmax = limits.max_velocity;
      b.Add((u - vmax) / d, -dir * d);
      distance -= (u * u - vmax * vmax) / (2 * d);
      u = vmax;
    }
    PlanFromSpeed(b, dir, u, distance, limits);
  }
  // The closed form ends at the target with v = 0; snap the end to the exact target.
  return VaProfile(FromSegments({start.position, start.velocity, 0}, b.Take(), false, target));
}

// ---------------------------------------------------------------------------------------------
// StopProfile

absl::StatusOr<StopProfile> StopProfile::Plan(Kinematics start, double deceleration,
                                              ZeroLimits zero_limits) {
  constexpr const char* kWhere = "stop_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  bool zero = false;
  if (auto s = CheckLimit(kWhere, "deceleration", deceleration, zero_limits, &zero); !s.ok()) {
    return s;
  }
  if (zero) return StopProfile(Hold(start.position));  // D-42
  const double v = start.velocity;
  if (v == 0) return StopProfile(Standstill(start.position));
  const double end = start.position + Sign(v) * v * v / (2 * deceleration);
  return StopProfile(FromSegments({start.position, v, 0},
                                  {{std::abs(v) / deceleration, -Sign(v) * deceleration, 0}}, false,
                                  end));
}

// ---------------------------------------------------------------------------------------------
// JogProfile

absl::StatusOr<JogProfile> JogProfile::Plan(Kinematics start, double velocity, Limits limits,
                                            std::optional<double> bound, ZeroLimits zero_limits) {
  constexpr const char* kWhere = "jog_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckFinite(kWhere, "velocity", velocity); !s.ok()) return s;
  if (bound.has_value()) {
    if (auto s = CheckFinite(kWhere, "bound", *bound); !s.ok()) return s;
  }
  bool zero = false;
  if (auto s = CheckLimits(kWhere, limits, zero_limits, &zero); !s.ok()) return s;
  if (zero) return JogProfile(Hold(start.position), false);  // D-42

  const bool limited = std::abs(velocity) > limits.max_velocity;
  const double vt = std::clamp(velocity, -limits.max_velocity, limits.max_velocity);
  const double a = limits.acceleration;
  const double d = limits.deceleration;

  const bool stop = vt == 0 || (bound.has_value() && Sign(*bound - start.position) != Sign(vt));
  if (stop) {
    auto p = StopProfile::Plan(start, d, zero_limits);
    if (!p.ok()) return p.status();
    return JogProfile(*std::move(p), limited);
  }
  if (bound.has_value()) {
    // Towards the bound at |vt|: exactly a VA move that stops on the bound (D-21).
    auto p = VaProfile::Plan(start, *bound, {std::abs(vt), a, d}, zero_limits);
    if (!p.ok()) return p.status();
    return JogProfile(*std::move(p), limited);
  }
  const double v0 = start.velocity;
  SegmentBuilder b;
  if (v0 != 0 && Sign(v0) != Sign(vt)) {
    b.Add(std::abs(v0) / d, -Sign(v0) * d);  // brake through 0 with the deceleration
    b.Add(std::abs(vt) / a, Sign(vt) * a);
  } else if (std::abs(vt) > std::abs(v0)) {
    b.Add((std::abs(vt) - std::abs(v0)) / a, Sign(vt) * a);
  } else {
    b.Add((std::abs(v0) - std::abs(vt)) / d, -Sign(vt) * d);
  }
  Profile p = FromSegments({start.position, v0, 0}, b.Take(), /*endless=*/true);
  return JogProfile(std::move(p), limited);
}

}  // namespace drivegw::sim::motion
