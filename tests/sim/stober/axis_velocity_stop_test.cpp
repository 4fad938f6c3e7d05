// stober-motion.md §10.6-10.7: MoveVelocity, MoveSpeed, MC_Stop, MC_Halt and the brake
// (CT-34 … CT-51), AXIS target, fixture F-LIN, 1 ms cycles.
#include <algorithm>
#include <cmath>

#include "axis_fixture.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::stober {
namespace {

using testing::Fixture;
using testing::TestAxis;

void StartVelocity(TestAxis& axis, double velocity) {
  axis.W("I404", velocity);
  axis.Start(Command::kMoveVelocity);
}

TEST(StoberAxis, CT34_MoveVelocityStartAndCompletion) {
  TestAxis axis;
  StartVelocity(axis, 300);
  EXPECT_EQ(axis.R("I89"), 4);
  int first = -1;
  bool together = true;
  for (int i = 1; i <= 1000 && first < 0; ++i) {
    axis.Advance();
    const bool a = axis.B("I183"), b = axis.B("I85"), c = axis.B("I92");
    if (a || b || c) {
      together = a && b && c;
      first = i;
    }
  }
  ASSERT_GT(first, 0);
  EXPECT_TRUE(together);
  EXPECT_NEAR(axis.R("E07"), 300, 1e-9);
  const double x = axis.R("I80");
  axis.Advance(100);
  EXPECT_NEAR(axis.R("I80") - x, 30, 1e-6);  // keeps moving (L945)
  EXPECT_EQ(axis.R("I92"), 1);
}

TEST(StoberAxis, CT35_MoveVelocityToLowerVelocity) {
  TestAxis axis;
  StartVelocity(axis, 300);
  ASSERT_GT(axis.RunUntilDone(), 0);
  StartVelocity(axis, 200);
  EXPECT_EQ(axis.R("I85"), 0);
  EXPECT_EQ(axis.R("I92"), 0);
  bool early = false;
  ASSERT_GT(axis.RunUntil([&] {
    if ((axis.B("I85") || axis.B("I92")) && std::abs(axis.R("E07") - 200) > 1e-9) early = true;
    return axis.B("I92");
  }),
            0);
  EXPECT_FALSE(early);
  EXPECT_EQ(axis.R("I85"), 1);
  EXPECT_NEAR(axis.R("E07"), 200, 1e-9);
}

TEST(StoberAxis, CT36_MoveVelocityDefaultLatchesVelocity) {
  TestAxis axis;
  StartVelocity(axis, 300);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.W("I404", 500);
  axis.Advance(300);
  EXPECT_NEAR(axis.R("E07"), 300, 1e-9);
}

TEST(StoberAxis, CT37_MoveVelocityCyclicalTakeoverIgnoresRamps) {
  TestAxis axis;
  axis.W("I113", 1);
  StartVelocity(axis, 300);
  axis.Advance(10);
  EXPECT_NEAR(axis.R("E07"), 300, 1e-9);
  axis.W("I404", 500);
  axis.Advance();
  EXPECT_NEAR(axis.R("E07"), 500, 1e-9);
  EXPECT_EQ(axis.R("I92"), 1);
}

TEST(StoberAxis, CT38_MoveVelocitySignChange) {
  TestAxis axis;
  StartVelocity(axis, 300);
  ASSERT_GT(axis.RunUntilDone(), 0);
  StartVelocity(axis, -300);
  double previous_a = axis.core().set_acceleration(), max_jerk = 0;
  bool crossed_zero = false;
  ASSERT_GT(axis.RunUntil([&] {
    const double a = axis.core().set_acceleration();
    max_jerk = std::max(max_jerk, std::abs(a - previous_a) / 0.001);
    previous_a = a;
    crossed_zero = crossed_zero || std::abs(axis.R("E07")) < 30;
    return axis.B("I92");
  }),
            0);
  EXPECT_TRUE(crossed_zero);
  EXPECT_LE(max_jerk, 50000 * (1 + 1e-6));
  EXPECT_NEAR(axis.R("E07"), -300, 1e-9);
}

TEST(StoberAxis, CT39_MoveSpeedFollowsSetValueChangesCyclically) {
  TestAxis axis;
  axis.W("I426", 300);
  axis.W("I216", 2000);
  axis.W("I217", 2000);
  axis.Start(Command::kMoveSpeed);
  EXPECT_EQ(axis.R("I89"), 4);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.R("E07"), 300, 1e-9);
  axis.W("I426", 600);  // no new edge
  double max_a = 0;
  ASSERT_GT(axis.RunUntil([&] {
    max_a = std::max(max_a, std::abs(axis.core().set_acceleration()));
    return std::abs(axis.R("E07") - 600) < 1e-9;
  }),
            0);
  EXPECT_LE(max_a, 2000 * (1 + 1e-9));
  EXPECT_GT(max_a, 1900);
}

TEST(StoberAxis, CT40_MoveSpeedDenialAndZeroCyclicAcceleration) {
  {
    TestAxis axis;
    axis.W("I407", 0);
    axis.W("I426", 300);
    axis.Start(Command::kMoveSpeed);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
  }
  TestAxis axis;
  axis.W("I426", 100);
  axis.W("I216", 2000);
  axis.Start(Command::kMoveSpeed);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.W("I216", 0);
  axis.W("I426", 300);
  axis.Start(Command::kMoveSpeed);
  double max_a = 0;
  ASSERT_GT(axis.RunUntil([&] {
    max_a = std::max(max_a, std::abs(axis.core().set_acceleration()));
    return axis.B("I92");
  }),
            0);
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_NEAR(max_a, 2000, 1e-6);
}

TEST(StoberAxis, CT41_MoveSpeedLimitFlags) {
  TestAxis axis;
  axis.W("I426", 2000);
  axis.W("I216", 20000);
  axis.W("I217", 20000);
  axis.W("I407", 100000);
  axis.Start(Command::kMoveSpeed);
  double max_v = 0, max_a = 0;
  axis.RunUntil(
      [&] {
        max_v = std::max(max_v, std::abs(axis.R("E07")));
        max_a = std::max(max_a, std::abs(axis.core().set_acceleration()));
        return false;
      },
      500);
  EXPECT_NEAR(max_v, 1000, 1e-9);
  EXPECT_LE(max_a, 10000 * (1 + 1e-9));
  EXPECT_EQ(axis.R("I193"), 1);
  EXPECT_EQ(axis.R("I195"), 1);
}

void RunVelocity500(TestAxis& axis) {
  StartVelocity(axis, 500);
  ASSERT_GT(axis.RunUntilDone(), 0);
}

TEST(StoberAxis, CT42_StopHoldsStoppingUntilExecuteLow) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.Start(Command::kStop);
  EXPECT_EQ(axis.R("I89"), 6);
  ASSERT_GT(axis.RunUntil([&] {
    EXPECT_EQ(axis.R("I89"), 6);
    return axis.B("I92");
  }),
            0);
  axis.Advance(100);
  EXPECT_EQ(axis.R("I89"), 6);
  axis.ExecuteLow();
  EXPECT_EQ(axis.R("I89"), 2);
}

TEST(StoberAxis, CT43_CommandsDuringStopAreDenied) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.Start(Command::kStop);
  axis.Advance(20);
  const double v = axis.R("E07");
  ASSERT_GT(v, 0);
  axis.MoveAbsolute(0);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kStopActive));
  EXPECT_EQ(axis.R("I89"), 6);  // G-30
  EXPECT_LT(axis.R("E07"), v);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("E07") == 0; }), 0);
  EXPECT_GT(axis.R("I80"), 0);  // it did not head for 0
}

TEST(StoberAxis, CT44_StopStatusOrder) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.Start(Command::kStop);
  int speed_reached = -1, profile_done = -1, done = -1;
  for (int i = 1; i <= 2000 && done < 0; ++i) {
    axis.Advance();
    if (speed_reached < 0 && axis.B("I183")) speed_reached = i;
    if (profile_done < 0 && axis.B("I85")) profile_done = i;
    if (done < 0 && axis.B("I92")) done = i;
  }
  ASSERT_GT(done, 0);
  EXPECT_LT(speed_reached, profile_done);
  EXPECT_EQ(profile_done, done);
  EXPECT_EQ(axis.R("E07"), 0);
  EXPECT_EQ(axis.R("I88"), 0);
}

TEST(StoberAxis, CT45_StopAtStandstillWithZeroDecelerationSucceeds) {
  TestAxis axis;
  axis.W("I406", 0);
  axis.Start(Command::kStop);
  EXPECT_EQ(axis.R("I92"), 0);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I92"), 1);
}

TEST(StoberAxis, CT46_StopInMotionWithZeroJerkDenied) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.W("I407", 0);
  axis.Start(Command::kStop);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
}

TEST(StoberAxis, CT47_HaltAllowsNewCommandBeforeStandstill) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.Start(Command::kHalt);
  EXPECT_EQ(axis.R("I89"), 3);
  axis.Advance(20);
  ASSERT_GT(axis.R("E07"), 0);
  StartVelocity(axis, 300);
  EXPECT_EQ(axis.R("I89"), 4);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_NEAR(axis.R("E07"), 300, 1e-9);
}

TEST(StoberAxis, CT48_ResumingAfterHalt) {
  TestAxis axis;
  RunVelocity500(axis);
  axis.Start(Command::kHalt);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.ExecuteLow();
  EXPECT_EQ(axis.R("I89"), 2);
  axis.Start(Command::kMoveVelocity);  // I404 still 500
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.R("E07"), 500, 1e-9);
}

TEST(StoberAxis, CT49_HaltAtStandstillWithZeroDecelerationSucceeds) {
  TestAxis axis;
  axis.W("I406", 0);
  axis.Start(Command::kHalt);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I92"), 1);
}

TEST(StoberAxis, CT50_BrakeEngagesAfterWaitTimeUnlessRestarted) {
  {
    TestAxis axis;
    axis.W("I410", 1);
    axis.W("I42", 200);
    axis.MoveAbsolute(500);
    ASSERT_GT(axis.RunUntilDone(), 0);
    EXPECT_FALSE(axis.core().brake_engaged());
    const int cycles = axis.RunUntil([&] { return axis.core().brake_engaged(); }, 1000);
    EXPECT_EQ(cycles, 200);
  }
  TestAxis axis;
  axis.W("I410", 1);
  axis.W("I42", 200);
  axis.MoveAbsolute(500);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.Advance(99);
  axis.W("I410", 0);
  axis.MoveAbsolute(600);  // the edge comes 100 ms after Done
  for (int i = 0; i < 2000; ++i) {
    axis.Advance();
    ASSERT_FALSE(axis.core().brake_engaged()) << i;
  }
  EXPECT_EQ(axis.R("I80"), 600);
}

TEST(StoberAxis, CT51_BrakeReleasedAtStartFromStandstill) {
  TestAxis axis;
  ASSERT_TRUE(axis.core().brake_engaged());
  axis.MoveAbsolute(500);
  EXPECT_FALSE(axis.core().brake_engaged());
  EXPECT_LT(axis.R("I80"), 0.01);
  ASSERT_GT(axis.RunUntilDone(), 0);
}

TEST(StoberAxis, CT51b_MotionWaitsForTheBrakeReleaseTime) {
  MotionCoreOptions options;
  options.brake_release_ms = 20;
  TestAxis axis(Fixture::kLin, options);
  axis.MoveAbsolute(500);
  for (int i = 1; i < 20; ++i) {
    EXPECT_TRUE(axis.core().brake_engaged()) << i;
    EXPECT_EQ(axis.R("I80"), 0) << i;
    axis.Advance();
  }
  EXPECT_FALSE(axis.core().brake_engaged());
  EXPECT_EQ(axis.R("I80"), 0);
  axis.Advance();
  EXPECT_GT(axis.R("I80"), 0);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 500);
}

TEST(StoberAxis, LimitSwitchDuringMoveCancelsWithQuickStop) {
  MotionCoreOptions options;
  options.positive_limit_switch = 300;
  TestAxis axis(Fixture::kLin, options);
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntil([&] { return axis.B("I91"); }), 0);
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kLimitSwitchFault));
  EXPECT_EQ(axis.R("I89"), 7);
  EXPECT_EQ(axis.R("I441"), 1);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }), 0);
  EXPECT_LT(axis.R("I80"), 340);  // ≈ 35 u of quick stop from 500 u/s
}

}  // namespace
}  // namespace drivegw::sim::stober
