// Tests for sim/motion/axis: D-10 actual values, in-target, stroke events, start rules, ticks.
#include "sim/motion/axis.h"

#include <cmath>
#include <limits>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::motion {
namespace {

constexpr Limits kCaseA{1000, 10000, 5000};  // linmot-mc.md §6.1 case A in mm
constexpr double kTick = 0.001;              // D-23 default tick

Axis MakeAxis(AxisConfig config = {}, double initial = 0) {
  auto axis = Axis::Create(config, initial);
  EXPECT_TRUE(axis.ok()) << axis.status();
  return *std::move(axis);
}

void AdvanceFor(Axis& axis, double seconds, double dt = kTick) {
  const int n = static_cast<int>(std::lround(seconds / dt));
  for (int i = 0; i < n; ++i) axis.Advance(dt);
}

TEST(AxisTest, Create_InvalidConfig_InvalidArgument) {
  EXPECT_EQ(Axis::Create({.min_position_mm = 10, .max_position_mm = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Axis::Create({.in_target_window_mm = -1}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Axis::Create({.lag_time_constant_s = std::nan("")}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Axis::Create({}, std::numeric_limits<double>::infinity()).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(AxisTest, Advance_DefaultLag_ActualIsDemandOneTickEarlier) {
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  Kinematics previous = axis.demand();
  for (int i = 0; i < 400; ++i) {
    axis.Advance(kTick);
    EXPECT_EQ(axis.actual().position, previous.position);
    EXPECT_EQ(axis.actual().velocity, previous.velocity);
    EXPECT_DOUBLE_EQ(axis.following_error(), axis.demand().position - previous.position);
    previous = axis.demand();
  }
}

TEST(AxisTest, Advance_CaseA_MotionActiveFor350msAndLimitsHold) {
  // linmot-mc.md §14 LMC-13: limits never exceeded, ends at 200 mm, active 0.35 s ± 2 ticks.
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  int active_ticks = 0;
  for (int i = 0; i < 1000; ++i) {
    axis.Advance(kTick);
    if (axis.motion_active()) ++active_ticks;
    EXPECT_LE(std::abs(axis.demand().velocity), 1000 + 1e-9);
    EXPECT_LE(axis.demand().acceleration, 10000);
    EXPECT_GE(axis.demand().acceleration, -5000);
  }
  EXPECT_NEAR(active_ticks, 350, 2);
  EXPECT_EQ(axis.demand().position, 200);
}

TEST(AxisTest, InTarget_AfterMotion_SetOnceActualInsideWindow) {
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(10, kCaseA).ok());
  EXPECT_FALSE(axis.in_target());
  while (axis.motion_active()) {
    EXPECT_FALSE(axis.in_target());
    axis.Advance(kTick);
  }
  // Demand finished; the actual is one tick behind, then in the window (D-10).
  axis.Advance(kTick);
  EXPECT_TRUE(axis.in_target());
  EXPECT_EQ(axis.actual().position, 10);
  EXPECT_EQ(axis.following_error(), 0);
}

TEST(AxisTest, InTarget_LaggingActual_WaitsForWindow) {
  Axis axis = MakeAxis({.in_target_window_mm = 0.01, .lag_time_constant_s = 0.02});
  ASSERT_TRUE(axis.MoveTo(50, kCaseA).ok());
  while (axis.motion_active()) axis.Advance(kTick);
  EXPECT_FALSE(axis.in_target());  // actual still far behind the end of the ramp
  int ticks = 0;
  while (!axis.in_target() && ticks < 10000) {
    axis.Advance(kTick);
    ++ticks;
  }
  EXPECT_TRUE(axis.in_target());
  EXPECT_GT(ticks, 1);
  EXPECT_LE(std::abs(axis.actual().position - 50), 0.01);
}

TEST(AxisTest, Advance_FirstOrderLagCruise_FollowingErrorIsVelocityTimesTau) {
  Axis axis = MakeAxis({.lag_time_constant_s = 0.01});
  ASSERT_TRUE(axis.Jog(100, kCaseA, std::nullopt).ok());
  AdvanceFor(axis, 1.0);
  EXPECT_NEAR(axis.following_error(), 100 * 0.01, 1e-6);
  EXPECT_NEAR(axis.actual().velocity, 100, 1e-6);
}

TEST(AxisTest, Advance_ManySmallTicks_MatchFewLargeTicks) {
  for (double tau : {0.0, 0.005}) {
    Axis fine = MakeAxis({.lag_time_constant_s = tau});
    Axis coarse = MakeAxis({.lag_time_constant_s = tau});
    ASSERT_TRUE(fine.MoveTo(200, kCaseA).ok());
    ASSERT_TRUE(coarse.MoveTo(200, kCaseA).ok());
    for (int step = 0; step < 50; ++step) {
      for (int i = 0; i < 100; ++i) fine.Advance(0.0001);
      coarse.Advance(0.01);
      // Demand is a closed-form f(t): equal up to rounding of the summed time.
      EXPECT_NEAR(fine.demand().position, coarse.demand().position, 1e-6);
      EXPECT_NEAR(fine.demand().velocity, coarse.demand().velocity, 1e-3);
      if (tau > 0) {
        // The lag is integrated exactly over the profile pieces (D-10 option).
        EXPECT_NEAR(fine.actual().position, coarse.actual().position, 1e-6) << step;
      } else {
        // One-tick delay: the lag is one tick of travel by definition (D-10).
        EXPECT_NEAR(fine.actual().position, coarse.actual().position, 1000 * 0.01 + 1e-9);
      }
    }
    EXPECT_EQ(fine.demand().position, 200);
    EXPECT_NEAR(fine.actual().position, coarse.actual().position, 1e-6);
  }
}

TEST(AxisTest, MoveTo_RetargetWhileMoving_DemandContinuous) {
  // LMC-14 / §6.1 case C through the axis.
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  AdvanceFor(axis, 0.1);
  const Kinematics before = axis.demand();
  ASSERT_TRUE(axis.MoveTo(60, kCaseA).ok());
  EXPECT_EQ(axis.demand().position, before.position);
  EXPECT_EQ(axis.demand().velocity, before.velocity);
  double previous_p = axis.demand().position;
  double previous_v = axis.demand().velocity;
  double max_p = 0;
  int ticks = 0;
  while (axis.motion_active()) {
    axis.Advance(kTick);
    ++ticks;
    EXPECT_LE(std::abs(axis.demand().position - previous_p), 1000 * kTick + 1e-9);
    EXPECT_LE(std::abs(axis.demand().velocity - previous_v), 10000 * kTick + 1e-9);
    previous_p = axis.demand().position;
    previous_v = axis.demand().velocity;
    max_p = std::max(max_p, previous_p);
  }
  EXPECT_NEAR(max_p, 150, 1e-3);
  EXPECT_NEAR(0.1 + ticks * kTick, 0.532, 1.5e-3);
  EXPECT_EQ(axis.demand().position, 60);
}

TEST(AxisTest, Stop_CaseD_StopsAt150) {
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  AdvanceFor(axis, 0.1);
  ASSERT_TRUE(axis.Stop(5000).ok());
  EXPECT_NEAR(axis.target(), 150, 1e-9);
  AdvanceFor(axis, 0.25);
  EXPECT_FALSE(axis.motion_active());
  EXPECT_NEAR(axis.demand().position, 150, 1e-9);
  EXPECT_TRUE(axis.in_target());
}

TEST(AxisTest, StartState_FromActual_UsesActualPositionAndVelocityRule) {
  Axis axis = MakeAxis({.lag_time_constant_s = 0.01});
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  AdvanceFor(axis, 0.12);
  const Kinematics actual = axis.actual();
  ASSERT_GT(axis.following_error(), 1);
  const Kinematics with_v = axis.StartState(StartFrom::kActualWithActualVelocity);
  EXPECT_EQ(with_v.position, actual.position);
  EXPECT_EQ(with_v.velocity, actual.velocity);
  const Kinematics zero_v = axis.StartState(StartFrom::kActualWithZeroVelocity);
  EXPECT_EQ(zero_v.position, actual.position);
  EXPECT_EQ(zero_v.velocity, 0);
  // `015x` with increment 0: target = actual, demand jumps there (§6.1 case E).
  ASSERT_TRUE(axis.MoveTo(actual.position, kCaseA, StartFrom::kActualWithZeroVelocity).ok());
  EXPECT_EQ(axis.target(), actual.position);
  EXPECT_EQ(axis.demand().position, actual.position);
  EXPECT_FALSE(axis.motion_active());
}

TEST(AxisTest, Advance_DemandBeyondStroke_ReportsOneLimitEvent) {
  Axis axis = MakeAxis({.min_position_mm = -5, .max_position_mm = 100});
  ASSERT_TRUE(axis.Jog(500, kCaseA, std::nullopt).ok());
  std::optional<LimitEvent> event;
  for (int i = 0; i < 1000 && !event; ++i) {
    axis.Advance(kTick);
    event = axis.TakeLimitEvent();
  }
  ASSERT_TRUE(event.has_value());
  EXPECT_EQ(event->limit, StrokeLimit::kMax);
  EXPECT_GT(event->demand_position_mm, 100);
  EXPECT_LT(event->demand_position_mm, 100 + 500 * kTick + 1e-9);
  EXPECT_EQ(axis.stroke_limit(), StrokeLimit::kMax);
  // The axis keeps moving (the family decides); no second event while beyond.
  EXPECT_TRUE(axis.motion_active());
  axis.Advance(kTick);
  EXPECT_FALSE(axis.TakeLimitEvent().has_value());
  // Back inside and out at the other end: a new event.
  ASSERT_TRUE(axis.Jog(-500, kCaseA, std::nullopt).ok());
  std::optional<LimitEvent> low;
  for (int i = 0; i < 2000 && !low; ++i) {
    axis.Advance(kTick);
    low = axis.TakeLimitEvent();
  }
  ASSERT_TRUE(low.has_value());
  EXPECT_EQ(low->limit, StrokeLimit::kMin);
}

TEST(AxisTest, Halt_WhileMoving_VelocityZeroPositionStays) {
  Axis axis = MakeAxis();
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  AdvanceFor(axis, 0.12);
  const double actual = axis.actual().position;
  axis.Halt();
  EXPECT_FALSE(axis.motion_active());
  EXPECT_EQ(axis.demand().velocity, 0);
  EXPECT_EQ(axis.actual().velocity, 0);
  EXPECT_EQ(axis.demand().position, actual);
  AdvanceFor(axis, 0.1);
  EXPECT_EQ(axis.actual().position, actual);
  EXPECT_TRUE(axis.in_target());
}

TEST(AxisTest, SetPosition_WhileMoving_ShiftsFrameKeepsMotion) {
  Axis axis = MakeAxis({.min_position_mm = 0, .max_position_mm = 300});
  ASSERT_TRUE(axis.MoveTo(200, kCaseA).ok());
  AdvanceFor(axis, 0.1);
  const double error = axis.following_error();
  const double physical = axis.physical_position();
  axis.SetPosition(1000);
  EXPECT_EQ(axis.actual().position, 1000);
  EXPECT_NEAR(axis.following_error(), error, 1e-9);
  EXPECT_NEAR(axis.target(), 1000 - physical + 200, 1e-9);
  EXPECT_NEAR(axis.physical_position(), physical, 1e-9);
  EXPECT_TRUE(axis.WithinStroke(1000));
  EXPECT_FALSE(axis.WithinStroke(500));
  AdvanceFor(axis, 0.5);
  EXPECT_NEAR(axis.actual().position, 1000 - physical + 200, 1e-9);
  EXPECT_FALSE(axis.TakeLimitEvent().has_value());
}

TEST(AxisTest, MoveTo_ZeroLimit_RejectedOrHeld) {
  Axis axis = MakeAxis();
  EXPECT_EQ(axis.MoveTo(10, {0, 1, 1}).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(axis.motion_active());
  ASSERT_TRUE(axis.MoveTo(10, {0, 1, 1}, StartFrom::kDemand, ZeroLimits::kHoldPosition).ok());
  AdvanceFor(axis, 1);
  EXPECT_TRUE(axis.motion_active());  // D-42: Motion Active = 1 until the next command
  EXPECT_EQ(axis.demand().position, 0);
}

}  // namespace
}  // namespace drivegw::sim::motion
