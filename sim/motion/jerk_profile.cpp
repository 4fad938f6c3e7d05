// Jerk-limited planners (stober-motion.md §8.2-8.6). Method: every profile is a chain of
// closed-form velocity ramps (Ramp below); the one free value of a point-to-point move (the peak
// velocity, or the reduced deceleration when braking has to begin at once) is found by
// bisection, and the end is snapped to the exact target. docs/decisions/302.
#include "sim/motion/jerk_profile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace drivegw::sim::motion {
namespace {

double Sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

absl::Status CheckFinite(const char* where, const char* field, double value) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(where, ".", field, ": ", value, " is not finite"));
}

absl::Status CheckStart(const char* where, const Kinematics& start) {
  if (auto s = CheckFinite(where, "start.position", start.position); !s.ok()) return s;
  if (auto s = CheckFinite(where, "start.velocity", start.velocity); !s.ok()) return s;
  return CheckFinite(where, "start.acceleration", start.acceleration);
}

// A limit must be finite and > 0; `jerk` may also be +infinity (no jerk limit).
absl::Status CheckLimit(const char* where, const char* field, double value,
                        bool infinity_allowed = false) {
  if (infinity_allowed && value == std::numeric_limits<double>::infinity()) {
    return absl::OkStatus();
  }
  if (std::isfinite(value) && value > 0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      where, ".", field, ": ", value,
      infinity_allowed ? " must be > 0 (finite or +infinity)" : " must be finite and > 0"));
}

absl::Status CheckLimits(const char* where, const JerkLimits& l) {
  if (auto s = CheckLimit(where, "limits.max_velocity", l.max_velocity); !s.ok()) return s;
  if (auto s = CheckLimit(where, "limits.acceleration", l.acceleration); !s.ok()) return s;
  if (auto s = CheckLimit(where, "limits.deceleration", l.deceleration); !s.ok()) return s;
  return CheckLimit(where, "limits.jerk", l.jerk, /*infinity_allowed=*/true);
}

Limits VaLimits(const JerkLimits& l) { return {l.max_velocity, l.acceleration, l.deceleration}; }

// Collects constant-jerk segments from a start state and tracks the state after them. Each
// segment starts with the acceleration the previous one ended with, so the acceleration is
// continuous by construction (§8.2 L300: never an acceleration step).
class Builder {
 public:
  explicit Builder(Kinematics start) : state_(start) {}

  void Add(double duration, double jerk) {
    if (!(duration > 0)) return;  // also drops NaN; rounding can make a phase "-0"
    segments_.push_back({duration, state_.acceleration, jerk});
    const double t = duration;
    const Kinematics& k = state_;
    state_ = {k.position + k.velocity * t + k.acceleration * t * t / 2 + jerk * t * t * t / 6,
              k.velocity + k.acceleration * t + jerk * t * t / 2, k.acceleration + jerk * t};
  }
  void Append(const Builder& other) {
    segments_.insert(segments_.end(), other.segments_.begin(), other.segments_.end());
    state_ = other.state_;
  }
  // After a ramp to rest: the residue is rounding (~1e-16), so call it rest exactly; otherwise a
  // residual sign could be read as "still moving the other way".
  void SettleAtRest() { state_.velocity = state_.acceleration = 0; }
  // After a ramp to `velocity`: the same for a moving state. Needed where the ramp is followed
  // by another one at speed (a pass, decision 1161): a residual acceleration of rounding size
  // would otherwise add or drop a correction ramp of ~1e-9 s, which at speed moves ~1e-6 mm.
  void SettleAt(double velocity) {
    state_.velocity = velocity;
    state_.acceleration = 0;
  }

  const Kinematics& state() const { return state_; }
  std::vector<Segment> Take() { return std::move(segments_); }

 private:
  Kinematics state_;
  std::vector<Segment> segments_;
};

// Velocity the motion reaches when its acceleration is brought to 0 with the full jerk: the
// velocity the axis is heading for, and the one a ramp passes with a = 0.
double ZeroingVelocity(const Kinematics& k, double jerk) {
  return k.velocity + k.acceleration * std::abs(k.acceleration) / (2 * jerk);
}

// Direction of motion for the intermediate-stop rule (§8.2 L304): the sign of the velocity, or
// of the acceleration when starting from rest; 0 at rest.
double MotionDirection(const Kinematics& k) {
  return k.velocity != 0 ? Sign(k.velocity) : Sign(k.acceleration);
}

// True if the state is already turning round towards `dir`: moving against `dir`, but the
// acceleration is so large that v changes sign even when it is taken out with the full jerk
// (only after a limit change or from an arbitrary start state; a profile planned with these
// limits always reaches v = 0 with a = 0). A stop would have to swing back; the planners go
// through v = 0 instead. The velocity would cross 0 with |a| = sqrt(2j·|v_z|); below 1e-6 of
// the smaller acceleration limit that is rounding (a state sampled at the very end of a stop
// ramp, where v and a|a|/2j cancel), and the ordinary intermediate stop applies.
bool TurningTowards(const Kinematics& k, double dir, const JerkLimits& l) {
  const double negligible_a = 1e-6 * std::min(l.acceleration, l.deceleration);
  return k.velocity * dir < 0 &&
         dir * ZeroingVelocity(k, l.jerk) > negligible_a * negligible_a / (2 * l.jerk);
}

// Appends the time-optimal ramp from the builder's (v, a) to velocity `vt` with a = 0 at the
// end: acceleration towards a peak (the full jerk), hold at the peak if it reaches the limit,
// back to 0 (the full jerk). The peak is bounded by `acceleration` when the ramp drives |v| away
// from 0 (vt beyond the zeroing velocity in vt's direction), else by `deceleration`. A start
// acceleration beyond that bound is first reduced with the full jerk. Callers split sign
// changes at v = 0 (intermediate stop), so the bound is the one of the whole ramp.
void Ramp(Builder& b, double vt, const JerkLimits& l) {
  const double jerk = l.jerk;
  const Kinematics& k = b.state();
  const double s = Sign(vt - ZeroingVelocity(k, jerk));
  if (s == 0) {
    b.Add(std::abs(k.acceleration) / jerk, -Sign(k.acceleration) * jerk);
    return;
  }
  // Crossing v = 0 (a start state already turning round, see TurningTowards): the bound is
  // the deceleration before and the acceleration after the crossing; use the smaller one for
  // the whole ramp rather than place the crossing exactly (conservative, rare).
  const double amax = k.velocity * vt < 0 ? std::min(l.acceleration, l.deceleration)
                      : vt * s > 0        ? l.acceleration
                                          : l.deceleration;
  // Mirrored so that the ramp raises the velocity: a0 start acceleration, dv > a0|a0|/2j.
  const double a0 = s * k.acceleration;
  const double dv = s * (vt - k.velocity);
  // Peak without a hold: (peak² - a0²)/2j up, peak²/2j down. Always >= max(a0, 0).
  const double peak = std::sqrt(std::max(0.0, jerk * dv + a0 * a0 / 2));
  if (peak <= amax) {
    b.Add((peak - a0) / jerk, s * jerk);
    b.Add(peak / jerk, -s * jerk);
    return;
  }
  double hold_dv = 0;  // velocity change left for the hold at amax
  if (a0 <= amax) {
    b.Add((amax - a0) / jerk, s * jerk);
    hold_dv = dv - (amax * amax - a0 * a0) / (2 * jerk) - amax * amax / (2 * jerk);
  } else {
    b.Add((a0 - amax) / jerk, -s * jerk);  // over the limit: reduce first (no step)
    hold_dv = dv - a0 * a0 / (2 * jerk);
  }
  b.Add(std::max(0.0, hold_dv / amax), 0);
  b.Add(amax / jerk, -s * jerk);
}

// Bisection for f(x) = goal on [lo, hi] with f(lo) <= goal <= f(hi) (f non-decreasing), or the
// mirror when `decreasing`. Runs until the interval cannot be split any more in doubles, so it
// is deterministic and as exact as the arithmetic; returns the side with f <= goal (the end is
// snapped onto the target afterwards, a jump of rounding size).
template <typename F>
double Bisect(F f, double lo, double hi, double goal, bool decreasing = false) {
  for (int i = 0; i < 2000; ++i) {
    const double mid = lo + (hi - lo) / 2;
    if (!(mid > lo && mid < hi)) break;
    const bool short_of_goal = f(mid) < goal;
    if (short_of_goal != decreasing) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return decreasing ? hi : lo;
}

// Appends a move to `target` in direction `dir` (the motion is not heading the other way, or is
// already turning round towards it, and the fastest stop does not reach the target). Families, in
// this order:
//  1. ramp to ±max_velocity, cruise, ramp to rest (long move; also the over-speed case: the
//     first ramp then decelerates to max_velocity);
//  2. ramp to a peak u in [u_z, max_velocity] and at once to rest (short move; u by bisection);
//  3. brake at once with a reduced deceleration d' in (0, deceleration] (the target lies
//     before "take the acceleration out, then brake": an axis already braking eases off, an
//     over-speed axis brakes gently; d' by bisection).
void MoveTowards(Builder& b, double dir, double target, const JerkLimits& l) {
  const Kinematics k = b.state();
  const double dist = dir * (target - k.position);
  const double vmax = l.max_velocity;
  // Distance covered by "ramp to peak speed u, then ramp to rest".
  const auto reach = [&](double u) {
    Builder t(k);
    Ramp(t, dir * u, l);
    Ramp(t, 0, l);
    return dir * (t.state().position - k.position);
  };
  const double reach_vmax = reach(vmax);
  if (dist >= reach_vmax) {
    Ramp(b, dir * vmax, l);
    b.Add((dist - reach_vmax) / vmax, 0);
    Ramp(b, 0, l);
    return;
  }
  // u_z: the speed towards the target once the acceleration is out. Below 0 (moving towards the
  // target, but braking so hard that v would turn) the fastest stop, reach(0), bounds from below.
  const double uz = dir * ZeroingVelocity(k, l.jerk);
  const double u_lo = std::max(uz, 0.0);
  if (u_lo < vmax && (uz <= 0 || dist >= reach(u_lo))) {
    const double u = Bisect(reach, u_lo, vmax, dist);
    Ramp(b, dir * u, l);
    Ramp(b, 0, l);
    return;
  }
  // Stopping distance with deceleration d': d' = deceleration is the fastest stop (<= dist);
  // it grows without bound as d' -> 0 (the hold at -d' lasts u_z/d').
  const auto brake = [&](double d) {
    Builder t(k);
    JerkLimits reduced = l;
    reduced.deceleration = d;
    Ramp(t, 0, reduced);
    return dir * (t.state().position - k.position);
  };
  double lo = l.deceleration;
  for (int i = 0; i < 2000 && brake(lo) < dist; ++i) lo /= 2;
  JerkLimits reduced = l;
  reduced.deceleration = Bisect(brake, lo, l.deceleration, dist, /*decreasing=*/true);
  Ramp(b, 0, reduced);
}

// Positions closer than this are the same (1e-12 relative, like VaProfile's Slack): a re-plan
// from a state exactly on a braking curve must not turn into an intermediate stop by rounding.
double Slack(double a, double b) { return 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}); }

// Appends an approach that passes `target` in direction `dir` at the speed ve > 0 with a = 0
// (JerkProfile::PlanPass, decision 1161). The motion is not heading the other way (or is already
// turning round towards it). Families, in this order, mirroring MoveTowards with "ramp to rest"
// replaced by "ramp to ve":
//  1. ramp to max_velocity, cruise, ramp to ve;
//  2. ramp to a peak u in [max(u_z, ve), max_velocity], then to ve (u by bisection);
//  3. approaching faster than ve and too close for 2: slow to ve at once with a reduced
//     deceleration d' in (0, deceleration] (d' by bisection);
//  4. approaching slower than ve and too close to reach it: pass at the highest speed u in
//     [max(u_z, 0), ve] that a single ramp reaches within the distance.
// Returns the pass speed, or nullopt when none of them fits (the target is too close to slow
// down to ve, or to take the acceleration out, before it): the caller stops first.
std::optional<double> PassTowards(Builder& b, double dir, double target, double ve,
                                  const JerkLimits& l) {
  const Kinematics k = b.state();
  const double dist = dir * (target - k.position);
  const double vmax = l.max_velocity;
  const auto distance_of = [&](const Builder& t) {
    return dir * (t.state().position - k.position);
  };
  // "Ramp to u, then to ve", each ramp settled on its velocity (Builder::SettleAt).
  const auto up_and_down = [&](Builder& t, double u, double cruise) {
    Ramp(t, dir * u, l);
    t.SettleAt(dir * u);
    t.Add(cruise, 0);
    Ramp(t, dir * ve, l);
    t.SettleAt(dir * ve);
  };
  const auto reach = [&](double u) {
    Builder t(k);
    up_and_down(t, u, 0);
    return distance_of(t);
  };
  const double reach_vmax = reach(vmax);
  if (dist >= reach_vmax) {
    up_and_down(b, vmax, (dist - reach_vmax) / vmax);
    return ve;
  }
  const double uz = dir * ZeroingVelocity(k, l.jerk);
  const double u_lo = std::max(uz, ve);
  if (u_lo < vmax && dist >= reach(u_lo)) {
    up_and_down(b, Bisect(reach, u_lo, vmax, dist), 0);
    return ve;
  }
  if (uz > ve) {
    const auto brake = [&](double d) {
      Builder t(k);
      JerkLimits reduced = l;
      reduced.deceleration = d;
      Ramp(t, dir * ve, reduced);
      return distance_of(t);
    };
    if (brake(l.deceleration) > dist + Slack(target, k.position)) return std::nullopt;
    double lo = l.deceleration;
    for (int i = 0; i < 2000 && brake(lo) < dist; ++i) lo /= 2;
    JerkLimits reduced = l;
    reduced.deceleration = Bisect(brake, lo, l.deceleration, dist, /*decreasing=*/true);
    Ramp(b, dir * ve, reduced);
    b.SettleAt(dir * ve);
    return ve;
  }
  const auto one = [&](double u) {
    Builder t(k);
    Ramp(t, dir * u, l);
    return distance_of(t);
  };
  const double lo = std::max(uz, 0.0);
  if (one(lo) > dist + Slack(target, k.position)) return std::nullopt;
  const double u = Bisect(one, lo, ve, dist);
  Ramp(b, dir * u, l);
  b.SettleAt(dir * u);
  return u;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// JerkProfile

absl::StatusOr<JerkProfile> JerkProfile::Plan(Kinematics start, double target, JerkLimits l) {
  constexpr const char* kWhere = "jerk_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckFinite(kWhere, "target", target); !s.ok()) return s;
  if (auto s = CheckLimits(kWhere, l); !s.ok()) return s;

  if (std::isinf(l.jerk)) {
    // No jerk limit: exactly the VA interpolator (linmot-mc.md D-21), acceleration steps allowed.
    auto va = VaProfile::Plan(start, target, VaLimits(l));
    if (!va.ok()) return va.status();
    const double v = start.velocity;
    const double rest = target - start.position;
    const bool behind = v != 0 && Sign(v) != Sign(rest);
    const bool too_close = v * v / (2 * l.deceleration) > std::abs(rest) + Slack(rest, 0);
    return JerkProfile(*std::move(va), behind || too_close);
  }
  if (start.position == target && start.velocity == 0 && start.acceleration == 0) {
    return JerkProfile(Standstill(target), false);
  }

  Builder b(start);
  bool intermediate_stop = false;
  // At most two passes: an intermediate stop, then the move from rest.
  for (int pass = 0; pass < 2; ++pass) {
    Builder stop(b.state());
    Ramp(stop, 0, l);  // the fastest stop from here
    const double rest = target - stop.state().position;
    if (std::abs(rest) <= Slack(target, stop.state().position)) {
      b.Append(stop);  // the fastest stop ends on the target
      break;
    }
    const double dir = Sign(rest);
    const double moving = MotionDirection(b.state());
    if (pass == 0 && moving != 0 && moving != dir && !TurningTowards(b.state(), dir, l)) {
      // stober-motion.md §8.2 (L304-306): target behind the motion, or not reachable within
      // deceleration and jerk: decelerate to 0 (acceleration back to 0), then head for it.
      b.Append(stop);
      b.SettleAtRest();
      intermediate_stop = true;
      continue;
    }
    MoveTowards(b, dir, target, l);
    break;
  }
  // The ramps end on the target with v = a = 0 up to rounding; snap to the exact target.
  return JerkProfile(FromSegments(start, b.Take(), /*endless=*/false, target), intermediate_stop);
}

absl::StatusOr<JerkProfile> JerkProfile::PlanPass(Kinematics start, double target,
                                                  double end_velocity, JerkLimits l) {
  constexpr const char* kWhere = "jerk_pass_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckFinite(kWhere, "target", target); !s.ok()) return s;
  if (!std::isfinite(end_velocity) || end_velocity < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(kWhere, ".end_velocity: ", end_velocity, " must be finite and >= 0"));
  }
  if (auto s = CheckLimits(kWhere, l); !s.ok()) return s;
  if (end_velocity == 0) return Plan(start, target, l);
  if (std::isinf(l.jerk)) {
    return absl::InvalidArgumentError(
        absl::StrCat(kWhere, ".limits.jerk: +infinity is not supported with an end velocity"));
  }
  const double ve = std::min(end_velocity, l.max_velocity);
  Builder b(start);
  bool intermediate_stop = false;
  std::optional<double> pass_speed;
  double dir = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const Kinematics k = b.state();
    const double rest = target - k.position;
    const bool at_rest = k.velocity == 0 && k.acceleration == 0;
    if (at_rest && std::abs(rest) <= Slack(target, k.position)) break;  // nothing to pass
    dir = rest != 0 ? Sign(rest) : MotionDirection(k);
    const double moving = MotionDirection(k);
    const bool behind = moving != 0 && moving != dir && !TurningTowards(k, dir, l);
    if (!behind) {
      Builder approach(k);
      pass_speed = PassTowards(approach, dir, target, ve, l);
      if (pass_speed) {
        b.Append(approach);
        break;
      }
    }
    // §8.2 (L304-306): behind the motion, or the axis cannot slow to ve before the target:
    // stop (a back to 0), then approach from rest (always possible from rest).
    Builder stop(k);
    Ramp(stop, 0, l);
    b.Append(stop);
    b.SettleAtRest();
    intermediate_stop = true;
  }
  // At rest on the target there is nothing to pass: the ordinary move that ends there.
  if (!pass_speed) return Plan(start, target, l);
  std::vector<Segment> segments = b.Take();
  double pass_time = 0;
  for (const Segment& s : segments) pass_time += s.duration;
  JerkProfile p(FromSegments(start, std::move(segments), /*endless=*/true, target),
                intermediate_stop);
  p.passes_ = true;
  p.pass_time_ = pass_time;
  p.pass_velocity_ = dir * *pass_speed;
  p.pass_position_ = target;
  return p;
}

// ---------------------------------------------------------------------------------------------
// JerkVelocityProfile

absl::StatusOr<JerkVelocityProfile> JerkVelocityProfile::Plan(Kinematics start, double velocity,
                                                              JerkLimits l) {
  constexpr const char* kWhere = "jerk_velocity_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckFinite(kWhere, "velocity", velocity); !s.ok()) return s;
  if (auto s = CheckLimits(kWhere, l); !s.ok()) return s;

  if (std::isinf(l.jerk)) {
    auto jog = JogProfile::Plan(start, velocity, VaLimits(l));
    if (!jog.ok()) return jog.status();
    const bool limited = jog->velocity_limited();
    return JerkVelocityProfile(*std::move(jog), limited);
  }
  const bool limited = std::abs(velocity) > l.max_velocity;
  const double vt = std::clamp(velocity, -l.max_velocity, l.max_velocity);
  if (vt == 0 && start.velocity == 0 && start.acceleration == 0) {
    return JerkVelocityProfile(Standstill(start.position), limited);
  }
  Builder b(start);
  const double moving = MotionDirection(start);
  if (vt != 0 && moving != 0 && moving != Sign(vt) && !TurningTowards(start, Sign(vt), l)) {
    // Sign change via zero (stober-motion.md §8.5, L917-919): stop with a = 0, then ramp up.
    Ramp(b, 0, l);
    b.SettleAtRest();
  }
  Ramp(b, vt, l);
  return JerkVelocityProfile(FromSegments(start, b.Take(), /*endless=*/vt != 0), limited);
}

absl::StatusOr<JerkVelocityProfile> JerkVelocityProfile::Stop(Kinematics start, double deceleration,
                                                              double jerk) {
  constexpr const char* kWhere = "jerk_stop_profile";
  if (auto s = CheckStart(kWhere, start); !s.ok()) return s;
  if (auto s = CheckLimit(kWhere, "deceleration", deceleration); !s.ok()) return s;
  if (auto s = CheckLimit(kWhere, "jerk", jerk, /*infinity_allowed=*/true); !s.ok()) return s;
  if (std::isinf(jerk)) {
    auto stop = StopProfile::Plan(start, deceleration);
    if (!stop.ok()) return stop.status();
    return JerkVelocityProfile(*std::move(stop), false);
  }
  if (start.velocity == 0 && start.acceleration == 0) {
    return JerkVelocityProfile(Standstill(start.position), false);
  }
  // A ramp to 0 only ever uses the deceleration bound; the other limits are placeholders.
  const JerkLimits l{std::numeric_limits<double>::infinity(), deceleration, deceleration, jerk};
  Builder b(start);
  Ramp(b, 0, l);
  return JerkVelocityProfile(FromSegments(start, b.Take(), /*endless=*/false), false);
}

}  // namespace drivegw::sim::motion
