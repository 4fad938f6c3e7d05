// stober-motion.md §10.2-10.3: execution model, status timing, denial, limits and override
// (CT-01 … CT-17), AXIS target, fixture F-LIN, 1 ms cycles.
#include <algorithm>
#include <cmath>

#include "axis_fixture.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::stober {
namespace {

using testing::Fixture;
using ::testing::HasSubstr;
using testing::TestAxis;

TEST(StoberAxis, CT01_RisingEdgeStartsLevelDoesNotRestart) {
  TestAxis axis;
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 1000);
  axis.W("I403", 2000);
  axis.Advance(500);
  EXPECT_EQ(axis.R("I80"), 1000);
  axis.ExecuteLow();
  axis.W("I402", 1);
  axis.Advance();
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 2000);
}

// The record the recovery tests read (decision 1451): one count per rising Execute edge with a
// command — started or denied — none for a held level, a falling edge or MC_DoNothing.
TEST(StoberAxis, ExecuteEdgesCountedForCommandsOnly) {
  TestAxis axis;
  EXPECT_EQ(axis.core().execute_edges(), 0u);
  axis.MoveAbsolute(1000);
  EXPECT_EQ(axis.core().execute_edges(), 1u);
  axis.Advance(100);  // level held
  axis.ExecuteLow();
  EXPECT_EQ(axis.core().execute_edges(), 1u);
  axis.W("I401", 0);  // MC_DoNothing
  axis.W("I402", 1);
  axis.Advance();
  EXPECT_EQ(axis.core().execute_edges(), 1u);
  axis.MoveAbsolute(1e9);  // denied (software limit): still an edge the master sent
  EXPECT_EQ(axis.core().execute_edges(), 2u);
}

TEST(StoberAxis, CT02_SetValuesLatchedAtTheEdge) {
  TestAxis axis;
  axis.MoveAbsolute(5000);
  axis.Advance(200);
  axis.W("I404", 900);
  double max_v = 0;
  ASSERT_GT(axis.RunUntil([&] {
    max_v = std::max(max_v, std::abs(axis.R("E07")));
    return axis.B("I92");
  }),
            0);
  EXPECT_LE(max_v, 500 + 1e-9);
  EXPECT_EQ(axis.R("I80"), 5000);
}

TEST(StoberAxis, CT03_DoneZeroInStartCycleEvenWhenComplete) {
  TestAxis axis;
  axis.MoveAbsolute(0);
  EXPECT_EQ(axis.R("I92"), 0);
  EXPECT_GT(axis.RunUntilDone(100), 0);
}

TEST(StoberAxis, CT04_ErrorZeroInStartCycleEvenWhenDenied) {
  TestAxis axis;
  axis.W("I404", 0);
  axis.MoveAbsolute(1000);
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I90"), 0);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_NE(axis.R("I90"), 0);
  EXPECT_EQ(axis.R("I89"), 7);
  EXPECT_THAT(axis.core().error_text(), HasSubstr("velocity I404 = 0"));
  axis.Advance(100);
  EXPECT_EQ(axis.R("I80"), 0);
}

TEST(StoberAxis, CT05_DeniedOutsideSoftwareLimits) {
  {
    TestAxis axis;
    axis.MoveAbsolute(12000);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_THAT(axis.core().error_text(), HasSubstr("position outside software limits I50..I51"));
    EXPECT_EQ(axis.R("I80"), 0);
  }
  for (Command c : {Command::kMoveRelative, Command::kMoveAdditive}) {
    TestAxis axis;
    axis.W("I403", -15000);
    axis.Start(c);
    axis.Advance(10);
    EXPECT_EQ(axis.R("I91"), 1) << static_cast<int>(c);
    EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kSoftwareLimit));
    EXPECT_EQ(axis.R("I80"), 0);
  }
  {
    TestAxis axis;  // G-33: the limits themselves are allowed
    axis.W("I404", 1000);
    axis.MoveAbsolute(10000);
    EXPECT_GT(axis.RunUntilDone(), 0);
  }
}

TEST(StoberAxis, CT06_DeniedWithZeroMaximumAccelerationOrJerk) {
  for (const char* zero : {"I11", "I16"}) {
    for (Command c : {Command::kMoveAbsolute, Command::kMoveRelative, Command::kMoveVelocity}) {
      TestAxis axis;
      axis.W(zero, 0);
      axis.W("I403", 100);
      axis.Start(c);
      axis.Advance();
      EXPECT_EQ(axis.R("I91"), 1) << zero << " " << static_cast<int>(c);
      EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kZeroMaximumValue));
      EXPECT_THAT(axis.core().error_text(), HasSubstr(zero));
    }
  }
}

TEST(StoberAxis, CT07_DeniedByLimitSwitchInTravelDirectionOnly) {
  {
    TestAxis axis;
    axis.core().ForceLimitSwitch(/*positive=*/true, true);
    axis.MoveAbsolute(1000);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kHardwareLimit));
    EXPECT_THAT(axis.core().error_text(), HasSubstr("I441"));
  }
  TestAxis axis;
  axis.core().ForceLimitSwitch(true, true);
  EXPECT_EQ(axis.R("I441"), 1);
  axis.MoveAbsolute(-1000);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I80"), -1000);
}

TEST(StoberAxis, CT08_DeniedWithZeroProfileValue) {
  {
    TestAxis axis;
    axis.W("I407", 0);
    axis.MoveAbsolute(1000);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_THAT(axis.core().error_text(), HasSubstr("jerk I407 = 0"));
  }
  {
    TestAxis axis;
    axis.W("I404", 300);
    axis.W("I406", 0);
    axis.Start(Command::kMoveVelocity);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_THAT(axis.core().error_text(), HasSubstr("deceleration I406 = 0"));
  }
  TestAxis axis;  // velocity 0 is not a denial cause [D]
  axis.W("I404", 0);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(5);
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I89"), 4);
}

TEST(StoberAxis, CT09_DenialFromMotionQuickStops) {
  TestAxis axis;
  axis.W("I404", 500);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(300);
  ASSERT_NEAR(axis.R("E07"), 500, 1e-9);
  axis.W("I405", 0);
  axis.MoveAbsolute(5000);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_EQ(axis.R("I89"), 7);
  EXPECT_LT(axis.R("E07"), 500);
  const int cycles = axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000);
  ASSERT_GT(cycles, 0);
  // Quick stop with I11 = 10000, I16 = 1e5 from 500 u/s: 50 ms + 100 ms jerk phases at most.
  EXPECT_LE(cycles, 160);
  const double stop_at = axis.R("I80");
  axis.Advance(100);
  EXPECT_EQ(axis.R("I80"), stop_at);
}

TEST(StoberAxis, CT10_InWindowAndDoneDropOnNewStart) {
  TestAxis axis;
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I180"), 1);
  axis.MoveAbsolute(3000);
  EXPECT_EQ(axis.R("I180"), 0);
  EXPECT_EQ(axis.R("I92"), 0);
  bool early = false;
  const int cycles = axis.RunUntil([&] {
    if (axis.B("I92") && std::abs(axis.R("I80") - 3000) > 1) early = true;
    if (axis.B("I180") && std::abs(axis.R("I80") - 3000) > 1) early = true;
    return axis.B("I92");
  });
  ASSERT_GT(cycles, 0);
  EXPECT_FALSE(early);
}

TEST(StoberAxis, CT11_MotionIdReportedDoNothingChangesNothing) {
  TestAxis axis;
  axis.W("I400", 7);
  axis.MoveAbsolute(500);
  EXPECT_EQ(axis.R("I82"), 7);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.W("I400", 9);
  axis.Start(Command::kDoNothing);
  axis.Advance(3);
  EXPECT_EQ(axis.R("I82"), 7);
  EXPECT_EQ(axis.R("I92"), 1);
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I91"), 0);
}

TEST(StoberAxis, CT11b_DoNothingLetsTheRunningCommandContinue) {
  TestAxis axis;  // G-12
  axis.MoveAbsolute(2000);
  axis.Advance(100);
  axis.Start(Command::kDoNothing);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 2000);
}

TEST(StoberAxis, CT12_VelocityLimit) {
  TestAxis axis;
  axis.W("I404", 2000);
  axis.MoveAbsolute(8000);
  double max_v = 0;
  bool flag_while_limited = true;
  ASSERT_GT(axis.RunUntil([&] {
    max_v = std::max(max_v, std::abs(axis.R("E07")));
    if (std::abs(axis.R("E07")) >= 1000 - 1e-9 && !axis.B("I190")) flag_while_limited = false;
    return axis.B("I92");
  }),
            0);
  EXPECT_NEAR(max_v, 1000, 1e-9);
  EXPECT_TRUE(flag_while_limited);
  EXPECT_EQ(axis.R("I193"), 0);
}

TEST(StoberAxis, CT13_OverrideAbove100Clipped) {
  TestAxis axis;
  axis.W("I230", 150);
  axis.W("I404", 800);
  axis.MoveAbsolute(8000);
  double max_v = 0;
  bool seen_193 = false;
  ASSERT_GT(axis.RunUntil([&] {
    max_v = std::max(max_v, std::abs(axis.R("E07")));
    seen_193 = seen_193 || axis.B("I193");
    return axis.B("I92");
  }),
            0);
  EXPECT_NEAR(max_v, 1000, 1e-9);
  EXPECT_TRUE(seen_193);
  EXPECT_EQ(axis.R("I190"), 0);
}

TEST(StoberAxis, CT14_AccelerationAndJerkLimit) {
  TestAxis axis;
  axis.W("I404", 1000);
  axis.W("I405", 20000);
  axis.W("I407", 200000);
  axis.MoveAbsolute(8000);
  EXPECT_EQ(axis.R("I191"), 1);
  double max_a = 0, max_j = 0, previous_a = axis.core().set_acceleration();
  ASSERT_GT(axis.RunUntil([&] {
    const double a = axis.core().set_acceleration();
    max_a = std::max(max_a, std::abs(a));
    max_j = std::max(max_j, std::abs(a - previous_a) / 0.001);
    previous_a = a;
    return axis.B("I92");
  }),
            0);
  EXPECT_LE(max_a, 10000 * (1 + 1e-9));
  EXPECT_GT(max_a, 9000);
  EXPECT_LE(max_j, 100000 * (1 + 1e-6));
}

TEST(StoberAxis, CT15_OverrideZeroHoldsNonZeroResumes) {
  TestAxis axis;
  axis.MoveAbsolute(5000);
  axis.Advance(500);
  axis.W("I230", 0);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000), 0);
  const double held = axis.R("I80");
  EXPECT_LT(held, 5000);
  axis.Advance(500);
  EXPECT_EQ(axis.R("I80"), held);
  EXPECT_EQ(axis.R("I92"), 0);
  axis.W("I230", 100);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 5000);
}

TEST(StoberAxis, CT16_StopAtOverrideZeroKeepsAxisStationary) {
  TestAxis axis;
  axis.MoveAbsolute(5000);
  axis.Advance(500);
  axis.W("I230", 0);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000), 0);
  const double held = axis.R("I80");
  axis.Start(Command::kStop);
  axis.ExecuteLow();
  axis.W("I230", 100);
  axis.Advance(500);
  EXPECT_EQ(axis.R("I80"), held);
  EXPECT_EQ(axis.R("I89"), 2);
  axis.MoveAbsolute(5000);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 5000);
}

// Cycles from the Stop start to rest, and the largest deceleration seen.
std::pair<int, double> StopFrom800(double override_percent) {
  TestAxis axis;
  axis.W("I404", 800);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(400);
  axis.ExecuteLow();
  // Override and MC_Stop in the same cycle: the override never reaches MoveVelocity.
  axis.W("I230", override_percent);
  axis.W("I406", 4000);
  axis.W("I401", static_cast<int>(Command::kStop));
  axis.W("I402", 1);
  axis.Advance();
  double max_d = std::abs(axis.core().set_acceleration());
  const int cycles = axis.RunUntil([&] {
    max_d = std::max(max_d, std::abs(axis.core().set_acceleration()));
    return axis.R("E07") == 0;
  });
  return {cycles, max_d};
}

TEST(StoberAxis, CT17_StopIgnoresOverride) {
  auto [cycles_10, decel_10] = StopFrom800(10);
  auto [cycles_100, decel_100] = StopFrom800(100);
  EXPECT_GT(cycles_10, 0);
  EXPECT_EQ(cycles_10, cycles_100);
  EXPECT_NEAR(decel_10, 4000, 1e-6);
  EXPECT_NEAR(decel_100, 4000, 1e-6);
}

}  // namespace
}  // namespace drivegw::sim::stober
