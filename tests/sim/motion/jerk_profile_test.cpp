// Tests for sim/motion/jerk_profile: jerk-limited point-to-point and velocity profiles
// (stober-motion.md §8.2-8.6, §2.4 start from motion; docs/decisions/302).
#include "sim/motion/jerk_profile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::motion {
namespace {

using ::testing::HasSubstr;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// 1 m/s, 10 m/s² up, 5 m/s² down, 200 m/s³, in mm.
constexpr JerkLimits kLimits{1000, 10000, 5000, 200000};

// Full precision, so a failing random case can be replayed.
std::string Str(const Kinematics& k) {
  return absl::StrFormat("{p=%.17g v=%.17g a=%.17g}", k.position, k.velocity, k.acceleration);
}

std::string Str(const JerkLimits& l) {
  return absl::StrFormat("{vmax=%.17g acc=%.17g dec=%.17g jerk=%.17g}", l.max_velocity,
                         l.acceleration, l.deceleration, l.jerk);
}

// End time of the segments (the finite duration, or where an endless profile starts coasting).
double SegmentsEnd(const Profile& p) {
  double t = 0;
  for (const Segment& s : p.segments()) t += s.duration;
  return t;
}

// The state the segments integrate to, before the planner's snap onto the target.
Kinematics Integrated(const Profile& p) {
  Kinematics k = p.start();
  for (const Segment& s : p.segments()) {
    const double t = s.duration;
    k = {k.position + k.velocity * t + s.acceleration * t * t / 2 + s.jerk * t * t * t / 6,
         k.velocity + s.acceleration * t + s.jerk * t * t / 2, s.acceleration + s.jerk * t};
  }
  return k;
}

// Checks a profile against the limits by fine sampling and at every knot:
//  - starts exactly at the start state (no position, velocity or acceleration step);
//  - continuity of position, velocity and acceleration at every knot;
//  - |jerk| <= jerk (difference quotient of the acceleration between samples);
//  - |a| <= acceleration while |v| grows, <= deceleration while |v| shrinks (a start beyond the
//    limits may keep its excess, never grow it);
//  - |v| <= max_velocity, or for an over-speed start never above the start and, once at or
//    below max_velocity, staying there;
//  - a finite profile ends at its target with v = a = 0, and the segments themselves end there
//    up to rounding (the snap is no visible jump).
void ExpectWithinLimits(const Profile& p, const JerkLimits& l, const std::string& ctx,
                        int samples = 4000) {
  const Kinematics s = p.start();
  const double vz0 = s.velocity + s.acceleration * std::abs(s.acceleration) / (2 * l.jerk);
  const double vscale = std::max({l.max_velocity, std::abs(s.velocity), std::abs(vz0)});
  const double ascale = std::max({l.acceleration, l.deceleration, std::abs(s.acceleration)});
  const double vtol = 1e-9 * vscale;
  const double atol = 1e-9 * ascale;
  const double seg_end = SegmentsEnd(p);
  const double pscale = std::max({1.0, std::abs(s.position), vscale * seg_end});
  const double ptol = 1e-9 * pscale;

  const Kinematics at0 = p.At(0);
  EXPECT_EQ(at0.position, s.position) << ctx;
  EXPECT_EQ(at0.velocity, s.velocity) << ctx;
  if (!p.segments().empty()) {
    EXPECT_EQ(at0.acceleration, s.acceleration) << ctx << " a step at 0";
  }

  // Continuity at the knots: the end of segment i against the start of segment i + 1.
  // The time of a knot is a rounded sum: allow what a few ulps of it make at the largest jerk,
  // acceleration and velocity.
  double t = 0;
  for (size_t i = 0; i + 1 < p.segments().size(); ++i) {
    t += p.segments()[i].duration;
    const Kinematics before = p.At(std::nextafter(t, 0.0));
    const Kinematics after = p.At(t);
    const double dt_round = 8 * std::numeric_limits<double>::epsilon() * t;
    EXPECT_NEAR(before.position, after.position, ptol + vscale * dt_round) << ctx << " knot " << i;
    EXPECT_NEAR(before.velocity, after.velocity, vtol + ascale * dt_round) << ctx << " knot " << i;
    EXPECT_NEAR(before.acceleration, after.acceleration, atol + l.jerk * dt_round)
        << ctx << " knot " << i;
  }
  if (!p.endless()) {
    const Kinematics end = Integrated(p);
    EXPECT_NEAR(end.position, p.target(), ptol) << ctx << " snap jump";
    EXPECT_NEAR(end.velocity, 0, vtol) << ctx << " end velocity";
    EXPECT_NEAR(end.acceleration, 0, atol) << ctx << " end acceleration";
    const Kinematics fin = p.At(p.duration());
    EXPECT_EQ(fin.position, p.target()) << ctx;
    EXPECT_EQ(fin.velocity, 0) << ctx;
    EXPECT_EQ(fin.acceleration, 0) << ctx;
  }

  // Sampling stops short of the last kEndTolerance of a finite profile: At() reports the
  // snapped end state there (checked above), which is no jerk of the profile.
  const double horizon =
      p.endless() ? seg_end * 1.1 + 1e-3 : seg_end - 1.5 * Profile::kEndTolerance;
  if (horizon <= 0) return;
  const double dt = horizon / samples;
  // A start heading above max_velocity (|v| or the velocity once the acceleration is out) is
  // over-speed: bounded by vscale until it is back within max_velocity.
  bool within_vmax = std::max(std::abs(s.velocity), std::abs(vz0)) <= l.max_velocity + vtol;
  int failures = 0;
  Kinematics prev = at0;
  for (int i = 1; i <= samples && failures < 3; ++i) {
    const double ti = i == samples ? horizon : i * dt;
    const Kinematics k = p.At(ti);
    const double h = ti - (i - 1) * dt;
    const double v = k.velocity;
    const double a = k.acceleration;
    // Jerk: a is piecewise linear, so the quotient never exceeds the largest slope.
    if (std::abs(a - prev.acceleration) > l.jerk * h * (1 + 1e-9) + atol) {
      ADD_FAILURE() << ctx << " jerk at t=" << ti << ": " << (a - prev.acceleration) / h;
      ++failures;
    }
    // Velocity.
    const double vabs = std::abs(v);
    if (within_vmax ? vabs > l.max_velocity + vtol : vabs > vscale + vtol) {
      ADD_FAILURE() << ctx << " |v| at t=" << ti << ": " << v;
      ++failures;
    }
    const double vz = v + a * std::abs(a) / (2 * l.jerk);
    within_vmax = within_vmax || std::max(vabs, std::abs(vz)) <= l.max_velocity + vtol;
    // Acceleration bound by the direction of |v|; within a sample of v = 0 either bound.
    double bound = v * a > 0 ? l.acceleration : l.deceleration;
    if (vabs <= std::abs(a) * dt + vtol) bound = std::max(l.acceleration, l.deceleration);
    bound = std::max(bound, std::abs(s.acceleration));
    if (std::abs(a) > bound + atol) {
      ADD_FAILURE() << ctx << " |a| at t=" << ti << ": " << a << " v=" << v;
      ++failures;
    }
    // Position consistent with the velocity (no hidden jump inside a segment).
    const double mid_v = (prev.velocity + v) / 2;
    if (std::abs((k.position - prev.position) - mid_v * h) > ascale * h * h + ptol) {
      ADD_FAILURE() << ctx << " position jump at t=" << ti;
      ++failures;
    }
    prev = k;
  }
}

JerkProfile PlanOrDie(Kinematics start, double target, JerkLimits limits = kLimits) {
  auto p = JerkProfile::Plan(start, target, limits);
  EXPECT_TRUE(p.ok()) << p.status();
  return *std::move(p);
}

JerkVelocityProfile VelocityOrDie(Kinematics start, double velocity, JerkLimits limits = kLimits) {
  auto p = JerkVelocityProfile::Plan(start, velocity, limits);
  EXPECT_TRUE(p.ok()) << p.status();
  return *std::move(p);
}

// Counts sign changes of the velocity (ignoring exact zeros) and returns the largest |a| seen
// within one sample of a change.
int VelocitySignChanges(const Profile& p, double* a_at_change, int samples = 20000) {
  const double horizon = SegmentsEnd(p);
  int changes = 0;
  double last = 0;
  *a_at_change = 0;
  for (int i = 0; i <= samples; ++i) {
    const Kinematics k = p.At(horizon * i / samples);
    if (k.velocity == 0) continue;
    if (last != 0 && (k.velocity > 0) != (last > 0)) {
      ++changes;
      *a_at_change = std::max(*a_at_change, std::abs(k.acceleration));
    }
    last = k.velocity;
  }
  return changes;
}

// ---------------------------------------------------------------------------------------------
// Validation

TEST(JerkProfileTest, Plan_InvalidLimit_NamesTheField) {
  const struct {
    JerkLimits limits;
    const char* field;
  } cases[] = {
      {{0, 1, 1, 1}, "jerk_profile.limits.max_velocity"},
      {{-1, 1, 1, 1}, "jerk_profile.limits.max_velocity"},
      {{kInf, 1, 1, 1}, "jerk_profile.limits.max_velocity"},
      {{1, 0, 1, 1}, "jerk_profile.limits.acceleration"},
      {{1, kNan, 1, 1}, "jerk_profile.limits.acceleration"},
      {{1, 1, -2, 1}, "jerk_profile.limits.deceleration"},
      {{1, 1, kInf, 1}, "jerk_profile.limits.deceleration"},
      {{1, 1, 1, 0}, "jerk_profile.limits.jerk"},
      {{1, 1, 1, -kInf}, "jerk_profile.limits.jerk"},
      {{1, 1, 1, kNan}, "jerk_profile.limits.jerk"},
  };
  for (const auto& c : cases) {
    auto p = JerkProfile::Plan({0, 0, 0}, 10, c.limits);
    ASSERT_FALSE(p.ok()) << c.field;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(p.status().message(), HasSubstr(c.field));
  }
}

TEST(JerkProfileTest, Plan_NonFiniteStartOrTarget_IsInvalidArgument) {
  EXPECT_THAT(JerkProfile::Plan({kNan, 0, 0}, 1, kLimits).status().message(),
              HasSubstr("jerk_profile.start.position"));
  EXPECT_THAT(JerkProfile::Plan({0, kInf, 0}, 1, kLimits).status().message(),
              HasSubstr("jerk_profile.start.velocity"));
  EXPECT_THAT(JerkProfile::Plan({0, 0, kNan}, 1, kLimits).status().message(),
              HasSubstr("jerk_profile.start.acceleration"));
  EXPECT_THAT(JerkProfile::Plan({0, 0, 0}, kInf, kLimits).status().message(),
              HasSubstr("jerk_profile.target"));
}

TEST(JerkProfileTest, VelocityAndStop_InvalidLimit_NamesTheField) {
  auto v = JerkVelocityProfile::Plan({0, 0, 0}, 10, {1, 0, 1, 1});
  EXPECT_EQ(v.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(v.status().message(), HasSubstr("jerk_velocity_profile.limits.acceleration"));
  EXPECT_THAT(JerkVelocityProfile::Plan({0, 0, 0}, kNan, kLimits).status().message(),
              HasSubstr("jerk_velocity_profile.velocity"));
  EXPECT_THAT(JerkVelocityProfile::Stop({0, 1, 0}, 0, 1).status().message(),
              HasSubstr("jerk_stop_profile.deceleration"));
  EXPECT_THAT(JerkVelocityProfile::Stop({0, 1, 0}, 1, -1).status().message(),
              HasSubstr("jerk_stop_profile.jerk"));
}

// ---------------------------------------------------------------------------------------------
// Point to point from rest

TEST(JerkProfileTest, Plan_AtTargetAtRest_IsStandstill) {
  const JerkProfile p = PlanOrDie({12.5, 0, 0}, 12.5);
  EXPECT_EQ(p.duration(), 0);
  EXPECT_FALSE(p.Active(0));
  EXPECT_EQ(p.At(1).position, 12.5);
}

TEST(JerkProfileTest, Plan_LongMoveFromRest_MatchesClosedFormDuration) {
  // Trapezoidal acceleration both ways and a cruise: T = D/v + (v/A + A/J)/2 + (v/D + D/J)/2.
  for (const double dist : {500.0, 1e5}) {
    const JerkProfile p = PlanOrDie({0, 0, 0}, dist);
    const JerkLimits& l = kLimits;
    const double expected = dist / l.max_velocity +
                            (l.max_velocity / l.acceleration + l.acceleration / l.jerk) / 2 +
                            (l.max_velocity / l.deceleration + l.deceleration / l.jerk) / 2;
    EXPECT_NEAR(p.duration(), expected, 1e-12 * expected) << dist;
    EXPECT_FALSE(p.intermediate_stop());
    EXPECT_EQ(p.segments().size(), 7u);
    EXPECT_EQ(p.At(p.duration()).position, dist);
    // Cruise at exactly max_velocity half way.
    EXPECT_NEAR(p.At(p.duration() / 2).velocity, l.max_velocity, 1e-9);
    ExpectWithinLimits(p, l, absl::StrCat("long ", dist));
  }
}

TEST(JerkProfileTest, Plan_ShortMove_ReachesNeitherVelocityNorAcceleration) {
  // 1 µm: pure jerk phases, T = 4 (D / 2J)^(1/3), peak a = J tau, peak v = J tau².
  const JerkProfile p = PlanOrDie({3, 0, 0}, 3.001);
  const double tau = std::cbrt(0.001 / (2 * kLimits.jerk));
  EXPECT_NEAR(p.duration(), 4 * tau, 1e-9 * tau);
  EXPECT_NEAR(p.At(2 * tau).velocity, kLimits.jerk * tau * tau, 1e-6);
  EXPECT_NEAR(p.At(tau).acceleration, kLimits.jerk * tau, 1e-6);
  EXPECT_EQ(p.At(p.duration()).position, 3.001);
  ExpectWithinLimits(p, kLimits, "1 um");
  // Position never leaves [3, 3.001].
  for (int i = 0; i <= 1000; ++i) {
    const double x = p.At(p.duration() * i / 1000).position;
    EXPECT_GE(x, 3 - 1e-15);
    EXPECT_LE(x, 3.001 + 1e-15);
  }
}

TEST(JerkProfileTest, Plan_MediumMove_TriangularVelocityWithReducedPeak) {
  // 60 mm: vmax (1000) is not reached, so no cruise; the peak stays below vmax.
  const JerkProfile p = PlanOrDie({0, 0, 0}, -60);
  double peak = 0;
  for (int i = 0; i <= 4000; ++i) {
    peak = std::max(peak, std::abs(p.At(p.duration() * i / 4000).velocity));
  }
  EXPECT_LT(peak, kLimits.max_velocity * 0.99);
  EXPECT_GT(peak, 100);
  EXPECT_EQ(p.At(p.duration()).position, -60);
  ExpectWithinLimits(p, kLimits, "triangle");
}

TEST(JerkProfileTest, Plan_FromRest_NoSlowerThanVaAndAtMostTheJerkPenalty) {
  // Jerk limitation only costs the ramp-in/ramp-out of the acceleration: T_va <= T <= T_va +
  // (A + D)/J (equality at the upper end for a trapezoid with cruise).
  for (const double dist : {1e-4, 0.01, 1.0, 30.0, 100.0, 250.0, 1000.0, 1e4}) {
    const JerkProfile p = PlanOrDie({0, 0, 0}, dist);
    auto va = VaProfile::Plan({0, 0, 0}, dist, {1000, 10000, 5000});
    ASSERT_TRUE(va.ok());
    EXPECT_GE(p.duration(), va->duration() * (1 - 1e-12)) << dist;
    EXPECT_LE(p.duration(),
              va->duration() + (kLimits.acceleration + kLimits.deceleration) / kLimits.jerk + 1e-12)
        << dist;
  }
}

// ---------------------------------------------------------------------------------------------
// Start from motion (§2.4, §8.2 L300)

TEST(JerkProfileTest, Plan_FromMotionWithAcceleration_ContinuesWithoutStep) {
  // Both directions, accelerating and decelerating, target ahead and far.
  for (const double dir : {1.0, -1.0}) {
    for (const double a0 : {6000.0, -3000.0, 0.0}) {
      const Kinematics start{10 * dir, 400 * dir, a0 * dir};
      const JerkProfile p = PlanOrDie(start, start.position + 800 * dir);
      const std::string ctx = absl::StrCat("dir=", dir, " a0=", a0);
      EXPECT_FALSE(p.intermediate_stop()) << ctx;
      EXPECT_EQ(p.At(0).acceleration, start.acceleration) << ctx;
      // The acceleration changes at most with the jerk right after the start.
      EXPECT_LE(std::abs(p.At(1e-4).acceleration - start.acceleration), kLimits.jerk * 1e-4 + 1e-6)
          << ctx;
      // Monotone towards the target: no reversal.
      double a_at_change = 0;
      EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 0) << ctx;
      ExpectWithinLimits(p, kLimits, ctx);
    }
  }
}

TEST(JerkProfileTest, Plan_MirroredStart_GivesMirroredProfile) {
  const Kinematics start{5, 300, -2500};
  const JerkProfile p = PlanOrDie(start, 40);
  const JerkProfile m = PlanOrDie({-5, -300, 2500}, -40);
  ASSERT_EQ(p.duration(), m.duration());
  for (int i = 0; i <= 100; ++i) {
    const double t = p.duration() * i / 100;
    EXPECT_EQ(p.At(t).position, -m.At(t).position) << t;
    EXPECT_EQ(p.At(t).velocity, -m.At(t).velocity) << t;
    EXPECT_EQ(p.At(t).acceleration, -m.At(t).acceleration) << t;
  }
}

TEST(JerkProfileTest, Plan_ReplanChain_StaysWithinLimitsAndContinuous) {
  // A move re-targeted three times while accelerating, cruising and braking.
  JerkProfile p = PlanOrDie({0, 0, 0}, 300);
  ExpectWithinLimits(p, kLimits, "leg 0");
  const double targets[] = {350, 320, 20};
  const double at[] = {0.05, 0.3, 0.12};
  for (int i = 0; i < 3; ++i) {
    const Kinematics k = p.At(at[i]);
    p = PlanOrDie(k, targets[i]);
    ExpectWithinLimits(p, kLimits, absl::StrCat("leg ", i + 1, " from ", Str(k)));
    EXPECT_EQ(p.At(p.duration()).position, targets[i]);
  }
}

// ---------------------------------------------------------------------------------------------
// Intermediate stop (§8.2 L304-306)

TEST(JerkProfileTest, Plan_TargetBehind_StopsWithZeroAccelerationThenReturns) {
  for (const double dir : {1.0, -1.0}) {
    const Kinematics start{0, 500 * dir, 2000 * dir};
    const JerkProfile p = PlanOrDie(start, -50 * dir);
    const std::string ctx = absl::StrCat("dir=", dir);
    EXPECT_TRUE(p.intermediate_stop()) << ctx;
    double a_at_change = 0;
    EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 1) << ctx;
    // The reversal happens at rest: the acceleration is back to 0 there (within one sample).
    EXPECT_LE(a_at_change, kLimits.jerk * SegmentsEnd(p) / 20000 * 2) << ctx;
    // It turns where the fastest jerk-limited stop ends.
    auto stop = JerkVelocityProfile::Stop(start, kLimits.deceleration, kLimits.jerk);
    ASSERT_TRUE(stop.ok());
    double extreme = 0;
    for (int i = 0; i <= 20000; ++i) {
      extreme = std::max(extreme, dir * p.At(SegmentsEnd(p) * i / 20000).position);
    }
    EXPECT_NEAR(extreme, dir * stop->target(), 1e-6) << ctx;
    EXPECT_EQ(p.At(p.duration()).position, -50 * dir);
    ExpectWithinLimits(p, kLimits, ctx);
  }
}

TEST(JerkProfileTest, Plan_CannotBrakeInTime_OvershootsThenReturns) {
  // Moving at vmax towards a target 10 mm ahead; the stop needs ~100 mm + jerk ramps.
  const Kinematics start{0, 1000, 0};
  const JerkProfile p = PlanOrDie(start, 10);
  EXPECT_TRUE(p.intermediate_stop());
  double far = 0;
  for (int i = 0; i <= 20000; ++i) far = std::max(far, p.At(SegmentsEnd(p) * i / 20000).position);
  auto stop = JerkVelocityProfile::Stop(start, kLimits.deceleration, kLimits.jerk);
  ASSERT_TRUE(stop.ok());
  EXPECT_GT(stop->target(), 100);
  EXPECT_NEAR(far, stop->target(), 1e-6);
  EXPECT_EQ(p.At(p.duration()).position, 10);
  ExpectWithinLimits(p, kLimits, "overshoot");
}

TEST(JerkProfileTest, Plan_TargetJustBeyondTheFastestStop_BrakesWithoutOvershoot) {
  // Braking at full deceleration; the new target lies a little beyond where that stop ends:
  // the planner eases the deceleration (no intermediate stop, no reversal, no overshoot).
  const Kinematics start{0, 600, -5000};
  auto stop = JerkVelocityProfile::Stop(start, kLimits.deceleration, kLimits.jerk);
  ASSERT_TRUE(stop.ok());
  for (const double extra : {0.0, 1e-9, 1e-3, 1.0, 5.0}) {
    const double target = stop->target() + extra;
    const JerkProfile p = PlanOrDie(start, target);
    const std::string ctx = absl::StrCat("extra=", extra);
    EXPECT_FALSE(p.intermediate_stop()) << ctx;
    double a_at_change = 0;
    EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 0) << ctx;
    for (int i = 0; i <= 2000; ++i) {
      EXPECT_LE(p.At(p.duration() * i / 2000).position, target + 1e-9) << ctx;
    }
    ExpectWithinLimits(p, kLimits, ctx);
  }
  // Just before the fastest stop's end: unreachable, so an intermediate stop.
  EXPECT_TRUE(PlanOrDie(start, stop->target() - 1e-6).intermediate_stop());
}

TEST(JerkProfileTest, Plan_MovingAtTheTarget_StopsAndComesBack) {
  const JerkProfile p = PlanOrDie({100, -200, 0}, 100);
  EXPECT_TRUE(p.intermediate_stop());
  EXPECT_EQ(p.At(p.duration()).position, 100);
  ExpectWithinLimits(p, kLimits, "at target moving");
}

// Largest |a| while the velocity has the sign of `dir` and |v| grows.
double MaxAccelerationTowards(const Profile& p, double dir, int samples = 20000) {
  double peak = 0;
  for (int i = 0; i <= samples; ++i) {
    const Kinematics k = p.At(SegmentsEnd(p) * i / samples);
    if (k.velocity * dir > 0 && k.acceleration * dir > 0) {
      peak = std::max(peak, std::abs(k.acceleration));
    }
  }
  return peak;
}

TEST(JerkProfileTest, Replan_AtTheTailOfAStop_FinishesTheStopThenUsesTheFullAcceleration) {
  // States at the very end of a stop ramp: v and a|a|/2j cancel up to rounding. A command the
  // other way finishes the stop (|a| <= deceleration while v keeps its sign) and then ramps up
  // with the full acceleration (far above the deceleration here), not with min(acc, dec) as
  // for a state that is really turning round.
  const JerkLimits l{1000, 10000, 714, 581000};
  auto stop = JerkVelocityProfile::Stop({0, 6, 0}, l.deceleration, l.jerk);
  ASSERT_TRUE(stop.ok());
  const double end = SegmentsEnd(*stop);
  for (int i = 1; i <= 100; ++i) {
    const Kinematics k = stop->At(end * (1 - 1e-3 * i / 100));
    const std::string ctx = absl::StrCat("state ", Str(k));
    const JerkVelocityProfile v = VelocityOrDie(k, -500, l);
    ExpectWithinLimits(v, l, ctx + " velocity -500");
    EXPECT_NEAR(MaxAccelerationTowards(v, -1), l.acceleration, 1e-6) << ctx;
    const JerkProfile p = PlanOrDie(k, k.position - 300, l);
    ExpectWithinLimits(p, l, ctx + " target behind");
    EXPECT_NEAR(MaxAccelerationTowards(p, -1), l.acceleration, 1e-6) << ctx;
  }
}

TEST(JerkProfileTest, Plan_AfterIntermediateStop_ReturnUsesTheFullAcceleration) {
  // The return leg starts from rest exactly (no rounding residue of the old direction that
  // would be taken for a reversal through v = 0 and limit the ramp to min(acc, dec)).
  for (const double dir : {1.0, -1.0}) {
    for (int i = 0; i < 20; ++i) {
      const Kinematics start{0.1 * i, (300 + 37.3 * i) * dir, (-2000 + 211.7 * i) * dir};
      const JerkProfile p = PlanOrDie(start, -400 * dir);
      ASSERT_TRUE(p.intermediate_stop());
      EXPECT_NEAR(MaxAccelerationTowards(p, -dir), kLimits.acceleration, 1e-6) << Str(start);
    }
  }
}

TEST(JerkProfileTest, Plan_StateAlreadyTurningRound_CrossesRestWithinBothLimits) {
  // Moving away at 200 mm/s but accelerating towards the target so hard (0.9 x dec, small jerk)
  // that the velocity turns anyway: no stop-and-swing-back; through v = 0 with |a| <= dec before
  // and <= acc after the crossing (here dec < acc).
  const JerkLimits l{1000, 10000, 5000, 20000};
  for (const double dir : {1.0, -1.0}) {
    const Kinematics start{0, -200 * dir, 4500 * dir};
    const JerkProfile p = PlanOrDie(start, 300 * dir, l);
    const std::string ctx = absl::StrCat("dir=", dir);
    EXPECT_FALSE(p.intermediate_stop()) << ctx;
    double a_at_change = 0;
    EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 1) << ctx;
    ExpectWithinLimits(p, l, ctx);
    const JerkVelocityProfile v = VelocityOrDie(start, 600 * dir, l);
    EXPECT_EQ(VelocitySignChanges(v, &a_at_change), 1) << ctx;
    ExpectWithinLimits(v, l, ctx + " velocity");
  }
}

// ---------------------------------------------------------------------------------------------
// Over-speed and over-limit starts

TEST(JerkProfileTest, Plan_OverSpeed_DeceleratesToMaxVelocityAndCruises) {
  const Kinematics start{0, -3000, 0};  // 3 x vmax, target far in the direction of motion
  const JerkProfile p = PlanOrDie(start, -5000);
  EXPECT_FALSE(p.intermediate_stop());
  ExpectWithinLimits(p, kLimits, "over-speed");
  // Half way it cruises at exactly -vmax.
  EXPECT_NEAR(p.At(p.duration() / 2).velocity, -1000, 1e-9);
  // |v| never grows above the start and decreases monotonically to vmax first.
  double prev = 3000;
  for (int i = 0; i <= 400; ++i) {
    const double v = std::abs(p.At(0.6 * i / 400).velocity);
    EXPECT_LE(v, prev + 1e-9);
    prev = std::max(v, 1000.0);
  }
}

TEST(JerkProfileTest, Plan_OverSpeedCloseTarget_BrakesGentlyWithoutReversal) {
  // 3 x vmax and the target lies between "fastest stop" and "slow to vmax, then stop".
  const Kinematics start{0, 3000, 0};
  auto stop = JerkVelocityProfile::Stop(start, kLimits.deceleration, kLimits.jerk);
  ASSERT_TRUE(stop.ok());
  const JerkProfile p = PlanOrDie(start, stop->target() + 20);
  EXPECT_FALSE(p.intermediate_stop());
  double a_at_change = 0;
  EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 0);
  ExpectWithinLimits(p, kLimits, "over-speed close");
}

TEST(JerkProfileTest, Plan_StartAccelerationBeyondLimits_ReducedWithFullJerk) {
  // A previous command allowed 30 m/s²; the new limits allow 10: no step, slope = -jerk.
  const Kinematics start{0, 200, 30000};
  const JerkProfile p = PlanOrDie(start, 500);
  EXPECT_EQ(p.At(0).acceleration, 30000);
  EXPECT_NEAR(p.At(1e-3).acceleration, 30000 - kLimits.jerk * 1e-3, 1e-6);
  ExpectWithinLimits(p, kLimits, "over-limit acceleration");
}

// ---------------------------------------------------------------------------------------------
// No jerk limit: the VA interpolator

TEST(JerkProfileTest, Plan_InfiniteJerk_IsTheVaProfile) {
  const JerkLimits l{1000, 10000, 5000, kInf};
  const struct {
    Kinematics start;
    double target;
  } cases[] = {{{0, 0, 0}, 200}, {{50, 1000, 0}, 60}, {{0, -300, 0}, 100}, {{0, 2500, 0}, 900}};
  for (const auto& c : cases) {
    const JerkProfile p = PlanOrDie(c.start, c.target, l);
    auto va = VaProfile::Plan(c.start, c.target, {1000, 10000, 5000});
    ASSERT_TRUE(va.ok());
    ASSERT_EQ(p.duration(), va->duration());
    for (int i = 0; i <= 50; ++i) {
      const double t = p.duration() * i / 50;
      EXPECT_EQ(p.At(t).position, va->At(t).position);
      EXPECT_EQ(p.At(t).velocity, va->At(t).velocity);
    }
  }
  EXPECT_TRUE(PlanOrDie({50, 1000, 0}, 60, l).intermediate_stop());
  EXPECT_TRUE(PlanOrDie({0, -300, 0}, 100, l).intermediate_stop());
  EXPECT_FALSE(PlanOrDie({0, 0, 0}, 200, l).intermediate_stop());
}

TEST(JerkProfileTest, Plan_HugeJerk_ApproachesTheVaDuration) {
  const JerkLimits l{1000, 10000, 5000, 1e12};
  const JerkProfile p = PlanOrDie({0, 0, 0}, 200, l);
  EXPECT_NEAR(p.duration(), 0.35 + 15000 / 2e12, 1e-9);  // linmot-mc.md §6.1 case A + ramps
  ExpectWithinLimits(p, l, "huge jerk");
}

// ---------------------------------------------------------------------------------------------
// Velocity profiles (§8.5, §8.6)

TEST(JerkVelocityProfileTest, Plan_FromRest_RampsToVelocityAndCoasts) {
  const JerkVelocityProfile p = VelocityOrDie({0, 0, 0}, 800);
  EXPECT_TRUE(p.endless());
  EXPECT_FALSE(p.velocity_limited());
  const double ramp = 800 / kLimits.acceleration + kLimits.acceleration / kLimits.jerk;
  EXPECT_NEAR(SegmentsEnd(p), ramp, 1e-12);
  EXPECT_NEAR(p.At(ramp + 1).velocity, 800, 1e-9);
  EXPECT_EQ(p.At(ramp + 1).acceleration, 0);
  EXPECT_TRUE(p.Active(1e6));
  ExpectWithinLimits(p, kLimits, "velocity from rest");
}

TEST(JerkVelocityProfileTest, Plan_ClipsToMaxVelocity) {
  const JerkVelocityProfile p = VelocityOrDie({0, 0, 0}, -5000);
  EXPECT_TRUE(p.velocity_limited());
  EXPECT_NEAR(p.At(10).velocity, -1000, 1e-9);
  ExpectWithinLimits(p, kLimits, "clipped");
}

TEST(JerkVelocityProfileTest, Plan_SignReversal_PassesRestWithZeroAcceleration) {
  for (const double dir : {1.0, -1.0}) {
    const Kinematics start{0, 300 * dir, 4000 * dir};
    const JerkVelocityProfile p = VelocityOrDie(start, -200 * dir);
    const std::string ctx = absl::StrCat("dir=", dir);
    double a_at_change = 0;
    EXPECT_EQ(VelocitySignChanges(p, &a_at_change), 1) << ctx;
    EXPECT_LE(a_at_change, kLimits.jerk * SegmentsEnd(p) / 20000 * 2) << ctx;
    EXPECT_NEAR(p.At(100).velocity, -200 * dir, 1e-9) << ctx;
    ExpectWithinLimits(p, kLimits, ctx);
  }
}

TEST(JerkVelocityProfileTest, Plan_SlowerSameDirection_DeceleratesWithDeceleration) {
  const JerkVelocityProfile p = VelocityOrDie({0, 900, 0}, 100);
  double min_a = 0;
  for (int i = 0; i <= 1000; ++i) {
    min_a = std::min(min_a, p.At(SegmentsEnd(p) * i / 1000).acceleration);
  }
  EXPECT_NEAR(min_a, -kLimits.deceleration, 1e-6);  // the deceleration plateau is reached
  EXPECT_NEAR(p.At(100).velocity, 100, 1e-9);
  ExpectWithinLimits(p, kLimits, "slower");
}

TEST(JerkVelocityProfileTest, Plan_ZeroVelocity_IsAFiniteStop) {
  const JerkVelocityProfile p = VelocityOrDie({7, -400, -3000}, 0);
  EXPECT_FALSE(p.endless());
  EXPECT_TRUE(std::isfinite(p.duration()));
  EXPECT_FALSE(p.Active(p.duration()));
  EXPECT_EQ(p.At(p.duration()).velocity, 0);
  auto stop = JerkVelocityProfile::Stop({7, -400, -3000}, kLimits.deceleration, kLimits.jerk);
  ASSERT_TRUE(stop.ok());
  EXPECT_EQ(stop->target(), p.target());
  EXPECT_EQ(stop->duration(), p.duration());
  ExpectWithinLimits(p, kLimits, "stop");
  // From rest: nothing to do.
  EXPECT_EQ(VelocityOrDie({7, 0, 0}, 0).duration(), 0);
}

TEST(JerkVelocityProfileTest, Stop_AcceleratingAway_TakesAccelerationOutFirst) {
  // Accelerating at +8 m/s² at 100 mm/s: the velocity keeps growing while a ramps down.
  const Kinematics start{0, 100, 8000};
  auto stop = JerkVelocityProfile::Stop(start, 5000, kLimits.jerk);
  ASSERT_TRUE(stop.ok());
  const double vz = 100 + 8000.0 * 8000 / (2 * kLimits.jerk);
  EXPECT_NEAR(stop->At(8000 / kLimits.jerk).velocity, vz, 1e-9);
  EXPECT_EQ(stop->At(stop->duration()).velocity, 0);
  ExpectWithinLimits(*stop, kLimits, "stop accelerating");
}

TEST(JerkVelocityProfileTest, InfiniteJerk_IsTheJogAndStopProfile) {
  const JerkLimits l{1000, 10000, 5000, kInf};
  const JerkVelocityProfile p = VelocityOrDie({0, 300, 0}, -2000, l);
  auto jog = JogProfile::Plan({0, 300, 0}, -2000, {1000, 10000, 5000});
  ASSERT_TRUE(jog.ok());
  EXPECT_TRUE(p.velocity_limited());
  EXPECT_EQ(p.At(0.1).velocity, jog->At(0.1).velocity);
  auto stop = JerkVelocityProfile::Stop({0, 300, 0}, 5000, kInf);
  ASSERT_TRUE(stop.ok());
  EXPECT_EQ(stop->target(), 9);  // 300² / (2 · 5000)
}

// ---------------------------------------------------------------------------------------------
// Properties over random commands and states (deterministic seed)

// A random limit set spanning slow/fast, soft/stiff axes.
JerkLimits RandomLimits(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const auto log_uniform = [&](double lo_exp, double hi_exp) {
    return std::pow(10.0, lo_exp + (hi_exp - lo_exp) * u(rng));
  };
  return {log_uniform(0, 3.5), log_uniform(1.5, 5), log_uniform(1.5, 5), log_uniform(2, 7)};
}

// Chains of commands, each started from the state of the previous profile at a random time
// (the way a drive re-plans "from motion"): random targets near and far, velocity commands with
// and without sign change, stops. Every profile must satisfy ExpectWithinLimits.
TEST(JerkProfilePropertyTest, RandomCommandChains_StayWithinLimits) {
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> u(0, 1);
  int intermediate_stops = 0;
  for (int chain = 0; chain < 250; ++chain) {
    const JerkLimits l = RandomLimits(rng);
    const double scale = l.max_velocity * l.max_velocity / l.deceleration + 1;  // typical stop
    Kinematics state{(u(rng) - 0.5) * 200, 0, 0};
    for (int step = 0; step < 8 && !HasFailure(); ++step) {
      std::string ctx =
          absl::StrCat("chain ", chain, " step ", step, " limits ", Str(l), " start ", Str(state));
      const double pick = u(rng);
      Profile p;
      if (pick < 0.6) {
        // Targets from 1 µm to many stopping distances away, both sides.
        const double mag = pick < 0.1 ? 1e-3 : std::pow(10.0, -3 + 5 * u(rng)) * scale;
        const double target = state.position + (u(rng) < 0.5 ? -mag : mag);
        absl::StrAppendFormat(&ctx, " target %.17g", target);
        auto jp = JerkProfile::Plan(state, target, l);
        ASSERT_TRUE(jp.ok()) << ctx << jp.status();
        intermediate_stops += jp->intermediate_stop();
        EXPECT_EQ(jp->At(jp->duration()).position, target) << ctx;
        p = *std::move(jp);
      } else if (pick < 0.9) {
        const double v = (u(rng) * 2.4 - 1.2) * l.max_velocity;
        absl::StrAppendFormat(&ctx, " velocity %.17g", v);
        auto vp = JerkVelocityProfile::Plan(state, v, l);
        ASSERT_TRUE(vp.ok()) << ctx << vp.status();
        EXPECT_NEAR(vp->At(SegmentsEnd(*vp) + 1).velocity,
                    std::clamp(v, -l.max_velocity, l.max_velocity), 1e-9 * l.max_velocity)
            << ctx;
        p = *std::move(vp);
      } else {
        ctx += " stop";
        auto sp = JerkVelocityProfile::Stop(state, l.deceleration, l.jerk);
        ASSERT_TRUE(sp.ok()) << ctx << sp.status();
        p = *std::move(sp);
      }
      ExpectWithinLimits(p, l, ctx, 1500);
      // Next command: right away, mid-way, or after the end.
      const double end = SegmentsEnd(p);
      const double r = u(rng);
      const double t = r < 0.1 ? 0 : (r < 0.9 ? end * u(rng) : end * 1.2);
      state = p.At(t);
    }
  }
  // The chains exercise the intermediate stop too.
  EXPECT_GT(intermediate_stops, 50);
}

// Random feasible start states (|a| within its bound, and the acceleration can be taken out
// before the velocity changes sign) and random targets, both directions.
TEST(JerkProfilePropertyTest, RandomStartStates_ReachTargetWithinLimits) {
  std::mt19937_64 rng(302);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 600 && !HasFailure(); ++i) {
    const JerkLimits l = RandomLimits(rng);
    const double v0 = (u(rng) * 2 - 1) * l.max_velocity * (u(rng) < 0.15 ? 3 : 1);
    double a0 = (u(rng) * 2 - 1) * std::max(l.acceleration, l.deceleration);
    if (a0 * v0 > 0) {
      // Accelerating: within the acceleration limit and not heading above vmax (unless the
      // start is already over-speed).
      a0 = std::clamp(a0, -l.acceleration, l.acceleration);
      const double room = std::max(0.0, l.max_velocity - std::abs(v0));
      if (std::abs(v0) <= l.max_velocity) {
        a0 = std::copysign(std::min(std::abs(a0), std::sqrt(2 * l.jerk * room)), a0);
      }
    } else {
      // Decelerating: within the deceleration limit and able to reach a = 0 before v = 0.
      a0 = std::clamp(a0, -l.deceleration, l.deceleration);
      a0 = std::copysign(std::min(std::abs(a0), std::sqrt(2 * l.jerk * std::abs(v0))), a0);
    }
    const Kinematics start{(u(rng) - 0.5) * 1000, v0, a0};
    const double reach = l.max_velocity * l.max_velocity / l.deceleration + 1;
    const double target =
        start.position + (u(rng) * 2 - 1) * std::pow(10.0, -3 + 4 * u(rng)) * reach;
    const std::string ctx =
        absl::StrCat("case ", i, " limits ", Str(l), " start ", Str(start), " target ", target);
    auto p = JerkProfile::Plan(start, target, l);
    ASSERT_TRUE(p.ok()) << ctx << p.status();
    EXPECT_EQ(p->At(p->duration()).position, target) << ctx;
    EXPECT_TRUE(std::isfinite(p->duration())) << ctx;
    ExpectWithinLimits(*p, l, ctx, 2000);
  }
}

// From rest, the S-curve is the time-optimal VA profile plus at most the time to ramp the
// acceleration in and out: T_va <= T <= T_va + (acc + dec)/jerk, for random limits and moves.
TEST(JerkProfilePropertyTest, RandomMovesFromRest_CostAtMostTheJerkRamps) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 2000 && !HasFailure(); ++i) {
    const JerkLimits l = RandomLimits(rng);
    const double dist = std::pow(10.0, -3 + 7 * u(rng)) * (u(rng) < 0.5 ? -1 : 1);
    const std::string ctx = absl::StrCat("limits ", Str(l), " distance ", dist);
    auto p = JerkProfile::Plan({0, 0, 0}, dist, l);
    auto va = VaProfile::Plan({0, 0, 0}, dist, {l.max_velocity, l.acceleration, l.deceleration});
    ASSERT_TRUE(p.ok() && va.ok()) << ctx;
    EXPECT_GE(p->duration(), va->duration() * (1 - 1e-9)) << ctx;
    EXPECT_LE(p->duration(),
              (va->duration() + (l.acceleration + l.deceleration) / l.jerk) * (1 + 1e-9))
        << ctx;
  }
}

}  // namespace
}  // namespace drivegw::sim::motion
