// Tests for sim/motion/profile: linmot-mc.md §6.1 D-21 worked cases A-E and limit properties.
#include "sim/motion/profile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::motion {
namespace {

using ::testing::HasSubstr;

// §6.1 case A limits in mm: vmax 1 m/s, a 10 m/s², d 5 m/s².
constexpr Limits kCaseA{1000, 10000, 5000};

// |expected| * 1e-6 relative, at least 1e-9 absolute.
void ExpectNear(double actual, double expected, const char* what) {
  EXPECT_NEAR(actual, expected, std::max(1e-9, std::abs(expected) * 1e-6)) << what;
}

VaProfile PlanOrDie(Kinematics start, double target, Limits limits) {
  auto p = VaProfile::Plan(start, target, limits);
  EXPECT_TRUE(p.ok()) << p.status();
  return *std::move(p);
}

TEST(ProfileTest, VaProfilePlan_CaseATrapezoid_MatchesWorkedNumbers) {
  const VaProfile p = PlanOrDie({0, 0, 0}, 200, kCaseA);
  ExpectNear(p.duration(), 0.35, "duration");
  ExpectNear(p.target(), 200, "target");
  // Accelerate 0-0.10 s (0 -> 50 mm), cruise to 0.15 s (-> 100 mm), decelerate to 0.35 s.
  ExpectNear(p.At(0.10).position, 50, "p(0.10)");
  ExpectNear(p.At(0.10).velocity, 1000, "v(0.10)");
  ExpectNear(p.At(0.15).position, 100, "p(0.15)");
  ExpectNear(p.At(0.25).position, 175, "p(0.25)");
  ExpectNear(p.At(0.25).velocity, 500, "v(0.25)");
  EXPECT_DOUBLE_EQ(p.At(0.05).acceleration, 10000);
  EXPECT_DOUBLE_EQ(p.At(0.12).acceleration, 0);
  EXPECT_DOUBLE_EQ(p.At(0.30).acceleration, -5000);
  EXPECT_TRUE(p.Active(0.349));
  EXPECT_FALSE(p.Active(0.35));
  const Kinematics end = p.At(0.35);
  EXPECT_EQ(end.position, 200);
  EXPECT_EQ(end.velocity, 0);
  EXPECT_EQ(p.At(10).position, 200);  // clamps to the end
}

TEST(ProfileTest, VaProfilePlan_CaseBTriangle_PeaksAtHalfWay) {
  const VaProfile p = PlanOrDie({0, 0, 0}, 10, {1000, 10000, 10000});
  const double t_peak = std::sqrt(10.0 / 10000);  // 31.62 ms
  ExpectNear(t_peak, 0.0316228, "t_peak");
  ExpectNear(p.At(t_peak).velocity, std::sqrt(1e5), "peak 316.2 mm/s");
  ExpectNear(p.At(t_peak).position, 5, "p(t_peak)");
  ExpectNear(p.duration(), 2 * t_peak, "end 63.25 ms");
  EXPECT_NEAR(p.duration(), 0.06325, 1e-5);
  EXPECT_EQ(p.segments().size(), 2u);
}

TEST(ProfileTest, VaProfilePlan_CaseCRetargetWithOvershoot_StopsAt150ThenReturnsTo60) {
  const VaProfile a = PlanOrDie({0, 0, 0}, 200, kCaseA);
  const Kinematics at = a.At(0.10);  // p = 50, v = 1000
  const VaProfile c = PlanOrDie(at, 60, kCaseA);
  // Stop distance 100 mm > 10 mm: decelerate to 0 at 150 mm (t = 0.30 s absolute).
  ExpectNear(c.At(0.20).position, 150, "p at reversal");
  EXPECT_NEAR(c.At(0.20).velocity, 0, 1e-9);
  // Return from rest over 90 mm: peak 0.7746 m/s.
  const double vp = std::sqrt(2 * 10000.0 * 5000 * 90 / 15000);
  ExpectNear(vp, 774.597, "peak");
  const double t_peak = 0.20 + vp / 10000;
  ExpectNear(c.At(t_peak).velocity, -vp, "v at peak");
  ExpectNear(0.10 + c.duration(), 0.10 + 0.20 + vp / 10000 + vp / 5000, "done");
  EXPECT_NEAR(0.10 + c.duration(), 0.532, 5e-4);
  EXPECT_EQ(c.At(c.duration()).position, 60);
  // No jump: position and velocity continue from case A.
  ExpectNear(c.At(0).position, at.position, "p continuous");
  ExpectNear(c.At(0).velocity, at.velocity, "v continuous");
}

TEST(ProfileTest, StopProfilePlan_CaseDFromCruise_StopsAt150After200ms) {
  const VaProfile a = PlanOrDie({0, 0, 0}, 200, kCaseA);
  auto stop = StopProfile::Plan(a.At(0.10), 5000);
  ASSERT_TRUE(stop.ok()) << stop.status();
  ExpectNear(stop->duration(), 0.20, "stop duration");
  ExpectNear(stop->target(), 150, "stop position");
  ExpectNear(stop->At(0.1).velocity, 500, "linear decrease");
  EXPECT_EQ(stop->At(0.2).position, stop->target());
}

TEST(ProfileTest, VaProfilePlan_CaseEIncrementTargets_FollowTheTargetFormulas) {
  // §6.1 case E: the families compute the target; the profile must honour it exactly.
  const VaProfile to100 = PlanOrDie({0, 0, 0}, 100, kCaseA);
  double t = 0;
  while (to100.At(t).position < 30) t += 1e-4;
  const Kinematics demand = to100.At(t);
  const VaProfile inc_dem = PlanOrDie(demand, demand.position + 10, kCaseA);  // `011x`
  EXPECT_DOUBLE_EQ(inc_dem.target(), demand.position + 10);
  EXPECT_EQ(inc_dem.At(inc_dem.duration()).position, demand.position + 10);
  const VaProfile inc_target = PlanOrDie(demand, to100.target() + 10, kCaseA);  // `012x`
  EXPECT_DOUBLE_EQ(inc_target.target(), 110);
  const VaProfile inc_act = PlanOrDie({20.0003, 0, 0}, 20.0003 + 0, kCaseA);  // `015x` 0
  EXPECT_DOUBLE_EQ(inc_act.target(), 20.0003);
  EXPECT_FALSE(inc_act.Active(0));
  EXPECT_EQ(inc_act.duration(), 0);
}

TEST(ProfileTest, VaProfilePlan_MovingAwayFromTarget_BrakesWithDecelerationFirst) {
  // D-21 step 2: v = -500 with the target ahead: brake at d, v²/2d = 25 mm further away.
  const VaProfile p = PlanOrDie({0, -500, 0}, 100, kCaseA);
  ASSERT_FALSE(p.segments().empty());
  EXPECT_DOUBLE_EQ(p.segments()[0].acceleration, 5000);
  ExpectNear(p.segments()[0].duration, 0.1, "brake time");
  ExpectNear(p.At(0.1).position, -25, "turning point");
  EXPECT_EQ(p.At(p.duration()).position, 100);
}

TEST(ProfileTest, VaProfilePlan_OverSpeed_BrakesToMaxVelocityThenCruises) {
  // D-21 step 4: |v| = 2000 > vmax 1000 with room to stop.
  const VaProfile p = PlanOrDie({0, 2000, 0}, 1000, kCaseA);
  EXPECT_DOUBLE_EQ(p.segments()[0].acceleration, -5000);
  ExpectNear(p.segments()[0].duration, 0.2, "2000 -> 1000 at 5 m/s²");
  ExpectNear(p.At(0.2).velocity, 1000, "at vmax");
  ExpectNear(p.At(0.25).velocity, 1000, "cruising");
  EXPECT_EQ(p.At(p.duration()).position, 1000);
}

TEST(ProfileTest, VaProfilePlan_OnTargetButMoving_OvershootsAndReturns) {
  const VaProfile p = PlanOrDie({50, 1000, 0}, 50, kCaseA);
  ExpectNear(p.At(0.2).position, 150, "overshoot");
  EXPECT_EQ(p.At(p.duration()).position, 50);
}

TEST(ProfileTest, VaProfilePlan_ZeroLimitReject_InvalidArgumentNamesField) {
  for (auto [limits, field] : {std::pair{Limits{0, 1, 1}, "va_profile.limits.max_velocity"},
                               std::pair{Limits{1, 0, 1}, "va_profile.limits.acceleration"},
                               std::pair{Limits{1, 1, 0}, "va_profile.limits.deceleration"}}) {
    auto p = VaProfile::Plan({0, 0, 0}, 10, limits);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(p.status().message(), HasSubstr(field));
  }
}

TEST(ProfileTest, VaProfilePlan_ZeroLimitHold_HoldsPositionWithMotionActive) {
  // linmot-mc.md D-42, simulator side.
  auto p = VaProfile::Plan({12, 300, 0}, 100, {1000, 0, 1000}, ZeroLimits::kHoldPosition);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_TRUE(p->endless());
  EXPECT_TRUE(p->Active(1e6));
  EXPECT_EQ(p->At(5).position, 12);
  EXPECT_EQ(p->At(5).velocity, 0);
  EXPECT_EQ(p->duration(), std::numeric_limits<double>::infinity());
}

TEST(ProfileTest, VaProfilePlan_NegativeOrNonFinite_InvalidArgumentEvenWhenHolding) {
  EXPECT_EQ(VaProfile::Plan({0, 0, 0}, 10, {-1, 1, 1}, ZeroLimits::kHoldPosition).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(VaProfile::Plan({0, 0, 0}, std::nan(""), kCaseA).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(
      VaProfile::Plan({0, std::numeric_limits<double>::infinity(), 0}, 1, kCaseA).status().code(),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(StopProfile::Plan({0, 1, 0}, 0).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(StopProfile::Plan({0, 1, 0}, 0).status().message(),
              HasSubstr("stop_profile.deceleration"));
}

TEST(ProfileTest, StopProfilePlan_AtRest_IsFinishedAtOnce) {
  auto p = StopProfile::Plan({7, 0, 0}, 100);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->duration(), 0);
  EXPECT_EQ(p->target(), 7);
  EXPECT_FALSE(p->Active(0));
}

TEST(ProfileTest, StopProfilePlan_NegativeVelocity_StopsBehind) {
  auto p = StopProfile::Plan({0, -100, 0}, 1000);
  ASSERT_TRUE(p.ok());
  ExpectNear(p->target(), -5, "v²/2d behind");
  ExpectNear(p->duration(), 0.1, "duration");
}

// Samples a profile on a fine grid plus every knot and checks D-21's invariants.
void CheckLimitsHold(const Profile& p, const Limits& l, double v_start_abs) {
  const double eps = 1e-9 * std::max({1.0, l.max_velocity, v_start_abs});
  std::vector<double> times;
  double t = 0;
  for (const Segment& s : p.segments()) {
    times.push_back(t);
    times.push_back(t + s.duration / 2);
    t += s.duration;
    times.push_back(t);
    // Speeding up uses a, slowing down d (checked at the segment middle).
    const Kinematics mid = p.At(times[times.size() - 2]);
    const bool speeding_up = mid.velocity * s.acceleration > 0;
    EXPECT_LE(std::abs(s.acceleration),
              (speeding_up ? l.acceleration : l.deceleration) * (1 + 1e-12))
        << "segment accel";
  }
  const double d = p.duration();
  for (int i = 0; i <= 200; ++i) times.push_back(d * i / 200);
  const double vcap = std::max(l.max_velocity, v_start_abs) + eps;
  for (double ti : times) {
    const Kinematics k = p.At(ti);
    EXPECT_LE(std::abs(k.velocity), vcap) << "t=" << ti;
    EXPECT_LE(std::abs(k.acceleration), std::max(l.acceleration, l.deceleration) * (1 + 1e-12));
  }
}

TEST(ProfileTest, VaProfilePlan_RandomPlans_NeverExceedLimitsAndEndAtTargetAtRest) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> pos(-500, 500);
  std::uniform_real_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> lim(10, 20000);
  for (int i = 0; i < 4000; ++i) {
    const Limits l{lim(rng) / 10, lim(rng), lim(rng)};
    // Mostly within vmax (the |v| <= vmax property); every 4th plan starts over-speed.
    const double vscale = (i % 4 == 3) ? 3 : 1;
    const Kinematics start{pos(rng), (2 * unit(rng) - 1) * l.max_velocity * vscale, 0};
    const double target = (i % 10 == 0) ? start.position : pos(rng);
    auto p = VaProfile::Plan(start, target, l);
    ASSERT_TRUE(p.ok()) << p.status();
    SCOPED_TRACE(testing::Message()
                 << "plan " << i << " p0=" << start.position << " v0=" << start.velocity
                 << " T=" << target << " vmax=" << l.max_velocity << " a=" << l.acceleration
                 << " d=" << l.deceleration);
    CheckLimitsHold(*p, l, std::abs(start.velocity));
    if (std::abs(start.velocity) > l.max_velocity) {
      // Over-speed start: |v| never increases above the start speed and falls to vmax.
      EXPECT_LE(std::abs(p->At(p->duration() / 2).velocity), std::abs(start.velocity) + 1e-9);
    }
    // Ends at the target with v = 0, and the segments really integrate to it (the end state is
    // snapped, so compare against an un-snapped integration).
    const Kinematics end = p->At(p->duration());
    EXPECT_EQ(end.position, target);
    EXPECT_EQ(end.velocity, 0);
    const Profile raw = Profile::FromSegments(p->start(), p->segments(), false);
    EXPECT_NEAR(raw.target(), target, 1e-9 * std::max(1.0, std::abs(target)) + 1e-9);
    const double dt = 1e-6;
    const Kinematics before_end = p->At(p->duration() - dt);
    EXPECT_NEAR(before_end.velocity, 0, std::max(l.acceleration, l.deceleration) * dt * 1.001);
    // Start continuity (from-demand start rule).
    EXPECT_NEAR(p->At(0).position, start.position, 1e-12);
    EXPECT_NEAR(p->At(0).velocity, start.velocity, 1e-9);
  }
}

TEST(ProfileTest, VaProfilePlan_RetargetAtRandomTimes_PositionAndVelocityContinuous) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pos(-300, 300);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 500; ++i) {
    VaProfile p = PlanOrDie({0, 0, 0}, pos(rng), kCaseA);
    for (int k = 0; k < 5; ++k) {
      const double t = unit(rng) * p.duration();
      const Kinematics at = p.At(t);
      const VaProfile q = PlanOrDie(at, pos(rng), kCaseA);
      EXPECT_NEAR(q.At(0).position, at.position, 1e-12);
      EXPECT_NEAR(q.At(0).velocity, at.velocity, 1e-9);
      // A microsecond later both move by at most v·dt + max(a,d)·dt²/2.
      const double dt = 1e-6;
      EXPECT_NEAR(q.At(dt).position, at.position + at.velocity * dt, 10000 * dt * dt);
      p = q;
    }
  }
}

TEST(ProfileTest, JogProfilePlan_Unbounded_RampsThenCruisesForEver) {
  auto p = JogProfile::Plan({0, 0, 0}, 500, kCaseA);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_TRUE(p->endless());
  EXPECT_EQ(p->duration(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(p->target(), std::numeric_limits<double>::infinity());
  ExpectNear(p->At(0.05).velocity, 500, "at speed after 50 ms");
  ExpectNear(p->At(10).position, 12.5 + 500 * (10 - 0.05), "cruise");
  EXPECT_TRUE(p->Active(1e9));
  EXPECT_FALSE(p->velocity_limited());
}

TEST(ProfileTest, JogProfilePlan_ReverseAndClip_BrakesThroughZeroAndFlagsLimit) {
  auto p = JogProfile::Plan({0, 400, 0}, -5000, kCaseA);
  ASSERT_TRUE(p.ok());
  EXPECT_TRUE(p->velocity_limited());
  ASSERT_EQ(p->segments().size(), 2u);
  EXPECT_DOUBLE_EQ(p->segments()[0].acceleration, -5000);   // braking at d
  EXPECT_DOUBLE_EQ(p->segments()[1].acceleration, -10000);  // speeding up at a
  ExpectNear(p->At(1).velocity, -1000, "clipped to vmax");
  EXPECT_EQ(p->target(), -std::numeric_limits<double>::infinity());
}

TEST(ProfileTest, JogProfilePlan_Bounded_StopsExactlyAtBound) {
  auto p = JogProfile::Plan({0, 0, 0}, 200, kCaseA, 100.0);
  ASSERT_TRUE(p.ok());
  EXPECT_FALSE(p->endless());
  EXPECT_EQ(p->At(p->duration()).position, 100);
  for (double t = 0; t < p->duration(); t += 1e-3) EXPECT_LE(p->At(t).velocity, 200 + 1e-9);
}

TEST(ProfileTest, JogProfilePlan_BoundBehindOrZeroVelocity_Stops) {
  auto behind = JogProfile::Plan({150, 100, 0}, 200, kCaseA, 100.0);
  ASSERT_TRUE(behind.ok());
  ExpectNear(behind->target(), 151, "stop with d");
  auto zero = JogProfile::Plan({0, -100, 0}, 0, kCaseA);
  ASSERT_TRUE(zero.ok());
  ExpectNear(zero->target(), -1, "stop with d");
}

TEST(ProfileTest, ProfileFromSegments_Jerk_EvaluatesCubic) {
  // S-curve pieces fit the same representation (D-22).
  const Profile p = Profile::FromSegments({1, 0, 0}, {{1, 0, 2}, {1, 2, -2}}, false);
  EXPECT_NEAR(p.At(1).position, 1 + 1.0 / 3, 1e-12);
  EXPECT_NEAR(p.At(1).velocity, 1, 1e-12);
  EXPECT_NEAR(p.At(1).acceleration, 2, 1e-12);
  EXPECT_NEAR(p.At(1.5).acceleration, 1, 1e-12);
  EXPECT_NEAR(p.target(), 1 + 1.0 / 3 + (1 + 1 - 1.0 / 3), 1e-12);
}

TEST(ProfileTest, ProfileShift_Moving_MovesEveryPosition) {
  VaProfile p = PlanOrDie({0, 0, 0}, 200, kCaseA);
  const Kinematics before = p.At(0.2);
  p.Shift(-30);
  EXPECT_NEAR(p.At(0.2).position, before.position - 30, 1e-12);
  EXPECT_EQ(p.At(0.2).velocity, before.velocity);
  EXPECT_EQ(p.target(), 170);
}

}  // namespace
}  // namespace drivegw::sim::motion
