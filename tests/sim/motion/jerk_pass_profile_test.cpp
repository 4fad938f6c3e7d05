// Tests for JerkProfile::PlanPass: a jerk-limited move that passes its target at an End velocity
// (stober-motion.md §3.2 Target L364-373, §8.2 I429; docs/decisions/1161).
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "absl/strings/str_format.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/motion/jerk_profile.h"

namespace drivegw::sim::motion {
namespace {

using ::testing::HasSubstr;

// 1 m/s, 10 m/s² up, 5 m/s² down, 200 m/s³, in mm (as jerk_profile_test.cpp).
constexpr JerkLimits kLimits{1000, 10000, 5000, 200000};

JerkProfile PassOrDie(Kinematics start, double target, double ve, JerkLimits l = kLimits) {
  auto p = JerkProfile::PlanPass(start, target, ve, l);
  EXPECT_TRUE(p.ok()) << p.status();
  return *std::move(p);
}

// Samples the profile up to a little after the pass: continuity (no position, velocity or
// acceleration step) and |v|, |a|, |jerk| within the limits (acceleration bound: the larger of
// acceleration/deceleration, since the direction of |v| can change inside a sample).
void ExpectWithinLimits(const JerkProfile& p, const JerkLimits& l, const std::string& ctx) {
  const Kinematics s = p.start();
  // A start heading above max_velocity (|v|, or v once the acceleration is out) is over-speed.
  const double vz0 = s.velocity + s.acceleration * std::abs(s.acceleration) / (2 * l.jerk);
  const double vscale = std::max({l.max_velocity, std::abs(s.velocity), std::abs(vz0)});
  const double amax = std::max({l.acceleration, l.deceleration, std::abs(s.acceleration)});
  const double horizon = p.pass_time() * 1.05 + 1e-3;
  constexpr int kSamples = 20000;
  const double dt = horizon / kSamples;
  // The pass is snapped onto the target: a rounding-size step (1e-9 of the travel scale).
  const double ptol = 1e-9 * std::max({1.0, std::abs(s.position), vscale * horizon});
  Kinematics prev = p.At(0);
  EXPECT_EQ(prev.position, s.position) << ctx;
  EXPECT_EQ(prev.velocity, s.velocity) << ctx;
  int failures = 0;
  for (int i = 1; i <= kSamples && failures < 3; ++i) {
    const Kinematics k = p.At(i * dt);
    if (std::abs(k.acceleration - prev.acceleration) > l.jerk * dt * (1 + 1e-9) + 1e-6 * amax) {
      ADD_FAILURE() << ctx << " jerk at t=" << i * dt;
      ++failures;
    }
    if (std::abs(k.velocity) > vscale * (1 + 1e-9)) {
      ADD_FAILURE() << ctx << " |v| at t=" << i * dt << ": " << k.velocity;
      ++failures;
    }
    if (std::abs(k.acceleration) > amax * (1 + 1e-9)) {
      ADD_FAILURE() << ctx << " |a| at t=" << i * dt << ": " << k.acceleration;
      ++failures;
    }
    const double mid_v = (prev.velocity + k.velocity) / 2;
    if (std::abs((k.position - prev.position) - mid_v * dt) > amax * dt * dt + ptol) {
      ADD_FAILURE() << ctx << " position jump at t=" << i * dt;
      ++failures;
    }
    prev = k;
  }
}

// The state at the pass: exactly the target, the pass velocity, no acceleration.
void ExpectPass(const JerkProfile& p, double target, double velocity, const std::string& ctx) {
  ASSERT_TRUE(p.passes()) << ctx;
  EXPECT_TRUE(p.endless()) << ctx;
  const Kinematics at = p.At(p.pass_time());
  EXPECT_EQ(at.position, target) << ctx;
  EXPECT_EQ(p.pass_position(), target) << ctx;
  EXPECT_NEAR(at.velocity, velocity, 1e-9 * std::max(1.0, std::abs(velocity))) << ctx;
  EXPECT_NEAR(p.pass_velocity(), velocity, 1e-9 * std::max(1.0, std::abs(velocity))) << ctx;
  EXPECT_EQ(at.acceleration, 0) << ctx;
  // Just before the pass the profile is still short of the target and moving towards it.
  const Kinematics before = p.At(p.pass_time() * (1 - 1e-6));
  EXPECT_GT((target - before.position) * velocity, 0) << ctx << " overshoot before pass";
}

TEST(JerkPassProfileTest, PlanPass_LongMoveFromRest_PassesTargetAtEndVelocity) {
  const JerkProfile p = PassOrDie({0, 0, 0}, 500, 200);
  ExpectPass(p, 500, 200, "long");
  EXPECT_FALSE(p.intermediate_stop());
  ExpectWithinLimits(p, kLimits, "long");
  // It cruised at max_velocity on the way (the move is long enough).
  EXPECT_NEAR(p.At(p.pass_time() / 2).velocity, 1000, 1e-6);
  // Faster than stopping there: the ordinary move takes longer.
  auto stop = JerkProfile::Plan({0, 0, 0}, 500, kLimits);
  ASSERT_TRUE(stop.ok());
  EXPECT_LT(p.pass_time(), stop->duration());
  // After the pass it coasts at the end velocity (the motion core decides what follows).
  EXPECT_NEAR(p.At(p.pass_time() + 0.1).position, 520, 1e-9);
}

TEST(JerkPassProfileTest, PlanPass_NegativeDirection_PassesWithNegativeVelocity) {
  const JerkProfile p = PassOrDie({100, 0, 0}, -300, 150);
  ExpectPass(p, -300, -150, "negative");
  ExpectWithinLimits(p, kLimits, "negative");
}

TEST(JerkPassProfileTest, PlanPass_MediumMove_PeakBelowMaxVelocity) {
  const JerkProfile p = PassOrDie({0, 0, 0}, 60, 300);
  ExpectPass(p, 60, 300, "medium");
  ExpectWithinLimits(p, kLimits, "medium");
  double peak = 0;
  for (int i = 0; i <= 1000; ++i) peak = std::max(peak, p.At(p.pass_time() * i / 1000).velocity);
  EXPECT_GT(peak, 300);
  EXPECT_LT(peak, 1000);
}

TEST(JerkPassProfileTest, PlanPass_TooShortToReachEndVelocity_PassesAtTheReachableVelocity) {
  // 1 mm from rest cannot reach 800 mm/s (decision 1161: accelerate all the way).
  const JerkProfile p = PassOrDie({0, 0, 0}, 1, 800);
  ASSERT_TRUE(p.passes());
  EXPECT_GT(p.pass_velocity(), 0);
  EXPECT_LT(p.pass_velocity(), 800);
  ExpectPass(p, 1, p.pass_velocity(), "short");
  ExpectWithinLimits(p, kLimits, "short");
}

TEST(JerkPassProfileTest, PlanPass_EndVelocityAboveMaxVelocity_IsClipped) {
  const JerkProfile p = PassOrDie({0, 0, 0}, 800, 5000);
  ExpectPass(p, 800, 1000, "clipped");
  ExpectWithinLimits(p, kLimits, "clipped");
}

TEST(JerkPassProfileTest, PlanPass_FromMotionFasterThanEndVelocity_SlowsWithoutStep) {
  // Cruising at 1000 mm/s, 300 mm before the target: slow to 100 mm/s at the target.
  const JerkProfile p = PassOrDie({0, 1000, 0}, 300, 100);
  ExpectPass(p, 300, 100, "slow down");
  EXPECT_FALSE(p.intermediate_stop());
  ExpectWithinLimits(p, kLimits, "slow down");
}

TEST(JerkPassProfileTest, PlanPass_FromMotionAccelerating_ContinuesWithoutStep) {
  const JerkProfile p = PassOrDie({10, 300, 4000}, 400, 250);
  ExpectPass(p, 400, 250, "accelerating");
  EXPECT_EQ(p.At(0).acceleration, 4000);
  ExpectWithinLimits(p, kLimits, "accelerating");
}

TEST(JerkPassProfileTest, PlanPass_TargetBehind_StopsThenPassesInTheNewDirection) {
  // §8.2 (L304-306): moving away from the target → intermediate stop, then the approach.
  const JerkProfile p = PassOrDie({0, 500, 0}, -100, 200);
  EXPECT_TRUE(p.intermediate_stop());
  ExpectPass(p, -100, -200, "behind");
  ExpectWithinLimits(p, kLimits, "behind");
}

TEST(JerkPassProfileTest, PlanPass_CannotSlowDownInTime_OvershootsAndComesBack) {
  // 1000 mm/s, 5 mm before the target, end velocity 100: slowing to 100 needs ~100 mm.
  const JerkProfile p = PassOrDie({0, 1000, 0}, 5, 100);
  EXPECT_TRUE(p.intermediate_stop());
  ExpectPass(p, 5, -100, "overshoot");
  ExpectWithinLimits(p, kLimits, "overshoot");
}

TEST(JerkPassProfileTest, PlanPass_AtRestOnTarget_IsTheOrdinaryStandstill) {
  const JerkProfile p = PassOrDie({42, 0, 0}, 42, 100);
  EXPECT_FALSE(p.passes());
  EXPECT_FALSE(p.endless());
  EXPECT_EQ(p.target(), 42);
}

TEST(JerkPassProfileTest, PlanPass_ZeroEndVelocity_IsPlan) {
  const JerkProfile p = PassOrDie({0, 0, 0}, 100, 0);
  auto q = JerkProfile::Plan({0, 0, 0}, 100, kLimits);
  ASSERT_TRUE(q.ok());
  EXPECT_FALSE(p.passes());
  EXPECT_EQ(p.duration(), q->duration());
  EXPECT_EQ(p.target(), 100);
}

TEST(JerkPassProfileTest, PlanPass_InvalidInput_NamesTheField) {
  auto neg = JerkProfile::PlanPass({0, 0, 0}, 100, -1, kLimits);
  ASSERT_FALSE(neg.ok());
  EXPECT_THAT(neg.status().message(), HasSubstr("jerk_pass_profile.end_velocity"));
  JerkLimits inf = kLimits;
  inf.jerk = std::numeric_limits<double>::infinity();
  auto no_jerk = JerkProfile::PlanPass({0, 0, 0}, 100, 10, inf);
  ASSERT_FALSE(no_jerk.ok());
  EXPECT_THAT(no_jerk.status().message(), HasSubstr("jerk_pass_profile.limits.jerk"));
  JerkLimits zero = kLimits;
  zero.acceleration = 0;
  auto bad = JerkProfile::PlanPass({0, 0, 0}, 100, 10, zero);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.status().message(), HasSubstr("jerk_pass_profile.limits.acceleration"));
}

TEST(JerkPassProfilePropertyTest, RandomStartStates_PassTheTargetWithinLimits) {
  std::mt19937_64 rng(1161);
  std::uniform_real_distribution<double> pos(-500, 500);
  std::uniform_real_distribution<double> vel(-1000, 1000);
  std::uniform_real_distribution<double> acc(-4000, 4000);
  std::uniform_real_distribution<double> end(1, 1200);
  for (int i = 0; i < 1000; ++i) {
    const Kinematics start{pos(rng), vel(rng), acc(rng)};
    const double target = pos(rng);
    const double ve = end(rng);
    const std::string ctx =
        absl::StrFormat("case %d start {%.17g %.17g %.17g} target %.17g ve %.17g", i,
                        start.position, start.velocity, start.acceleration, target, ve);
    auto p = JerkProfile::PlanPass(start, target, ve, kLimits);
    ASSERT_TRUE(p.ok()) << ctx << ": " << p.status();
    if (!p->passes()) continue;  // only at rest on the target
    const double speed = std::abs(p->pass_velocity());
    EXPECT_LE(speed, std::min(ve, 1000.0) * (1 + 1e-9)) << ctx;
    EXPECT_GT(speed, 0) << ctx;
    ExpectPass(*p, target, p->pass_velocity(), ctx);
    ExpectWithinLimits(*p, kLimits, ctx);
  }
}

}  // namespace
}  // namespace drivegw::sim::motion
