// stober-motion.md §10.4-10.5: positioning commands and the endless axis (CT-18 … CT-33),
// AXIS target, fixtures F-LIN / F-END, 1 ms cycles.
#include <algorithm>
#include <cmath>

#include "axis_fixture.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/stober/cia402.h"

namespace drivegw::sim::stober {
namespace {

using testing::Fixture;
using ::testing::HasSubstr;
using testing::TestAxis;

// Largest |Δa|/Δt between consecutive cycles while `run` advances the axis.
struct JerkWatch {
  explicit JerkWatch(TestAxis& axis) : axis(axis), previous(axis.core().set_acceleration()) {}
  void Sample() {
    const double a = axis.core().set_acceleration();
    max_jerk = std::max(max_jerk, std::abs(a - previous) / 0.001);
    previous = a;
  }
  TestAxis& axis;
  double previous;
  double max_jerk = 0;
};

TEST(StoberAxis, CT18_RetargetingMoveAbsoluteEndsAtLastTarget) {
  {
    TestAxis axis;  // case A
    axis.MoveAbsolute(1000);
    ASSERT_GT(axis.RunUntilDone(), 0);
    axis.W("I404", 800);
    axis.MoveAbsolute(2000);
    ASSERT_GT(axis.RunUntilDone(), 0);
    EXPECT_EQ(axis.R("I80"), 2000);
  }
  TestAxis axis;  // case B: at 500, no acceleration step
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I80") >= 500; }), 0);
  JerkWatch watch(axis);
  axis.W("I404", 800);
  axis.MoveAbsolute(2000);
  watch.Sample();
  ASSERT_GT(axis.RunUntil([&] {
    watch.Sample();
    return axis.B("I92");
  }),
            0);
  EXPECT_EQ(axis.R("I80"), 2000);
  EXPECT_LE(watch.max_jerk, 100000 * (1 + 1e-6));
}

TEST(StoberAxis, CT19_IntermediateStopOnReversal) {
  TestAxis axis;
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I80") >= 600; }), 0);
  JerkWatch watch(axis);
  axis.MoveAbsolute(200);
  watch.Sample();
  bool went_negative = false;
  double max_position = 0;
  ASSERT_GT(axis.RunUntil([&] {
    watch.Sample();
    went_negative = went_negative || axis.R("E07") < 0;
    max_position = std::max(max_position, axis.R("I80"));
    return axis.B("I92");
  }),
            0);
  EXPECT_TRUE(went_negative);
  EXPECT_GT(max_position, 600);
  EXPECT_LE(watch.max_jerk, 50000 * (1 + 1e-6));  // command jerk, continuous acceleration
  EXPECT_EQ(axis.R("I80"), 200);
}

TEST(StoberAxis, CT20_MoveRelativeEndPositionsDiffer) {
  {
    TestAxis axis;
    axis.W("I403", 1000);
    axis.Start(Command::kMoveRelative);
    ASSERT_GT(axis.RunUntilDone(), 0);
    axis.Start(Command::kMoveRelative);
    ASSERT_GT(axis.RunUntilDone(), 0);
    EXPECT_EQ(axis.R("I80"), 2000);
  }
  TestAxis axis;
  axis.W("I403", 1000);
  axis.Start(Command::kMoveRelative);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I80") >= 570; }), 0);
  axis.W("I404", 300);
  axis.Start(Command::kMoveRelative);
  const double base = axis.position_before_edge;
  EXPECT_NEAR(base, 570, 1);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_DOUBLE_EQ(axis.R("I80"), base + 1000);
}

TEST(StoberAxis, CT21_MoveRelativeNeedsReferenceOnlyWithSoftwareLimits) {
  {
    TestAxis axis;
    axis.core().SetReferenced(false);
    axis.W("I403", 100);
    axis.Start(Command::kMoveRelative);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kNotReferenced));
  }
  TestAxis axis(Fixture::kEnd);
  axis.core().SetReferenced(false);
  axis.W("I403", 100);
  axis.Start(Command::kMoveRelative);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 100);
}

TEST(StoberAxis, CT22_MoveAdditiveEndPositionsSame) {
  {
    TestAxis axis;
    axis.W("I403", 1000);
    axis.Start(Command::kMoveAdditive);
    ASSERT_GT(axis.RunUntilDone(), 0);
    axis.Start(Command::kMoveAdditive);
    ASSERT_GT(axis.RunUntilDone(), 0);
    EXPECT_EQ(axis.R("I80"), 2000);
  }
  TestAxis axis;
  axis.W("I403", 1000);
  axis.Start(Command::kMoveAdditive);
  axis.Advance(700);
  axis.W("I404", 300);
  axis.Start(Command::kMoveAdditive);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 2000);
}

// One row of Table 11 (§3.4.6): first command to `first_target`, an interruption, MoveAdditive
// 200; returns the end position and, for enable-off rows, the position at enable-off.
enum class Interrupt { kNone, kStop, kEnableOff };
struct RowResult {
  double end = 0;
  double at_interrupt = 0;
};
RowResult RunRow(double start, Command first, double value, Interrupt interrupt,
                 double interrupt_at) {
  TestAxis axis;
  if (start != 0) axis.core().SetActualPosition(start);
  axis.W("I403", value);
  axis.Start(first);
  RowResult result;
  if (interrupt == Interrupt::kNone) {
    EXPECT_GT(axis.RunUntilDone(), 0);
  } else {
    EXPECT_GT(axis.RunUntil([&] { return axis.R("I80") >= interrupt_at; }), 0);
    result.at_interrupt = axis.R("I80");
    if (interrupt == Interrupt::kStop) {
      axis.Start(Command::kStop);
      axis.ExecuteLow();
      EXPECT_GT(axis.RunUntil([&] { return axis.R("I89") == 2; }), 0);
    } else {
      axis.W("A515", cw::kDisableOperationWord);
      axis.Advance(5);
      EXPECT_EQ(axis.R("I80"), result.at_interrupt);
      axis.W("A515", cw::kEnableOperationWord);
      axis.Advance();
    }
  }
  axis.W("I403", 200);
  axis.Start(Command::kMoveAdditive);
  EXPECT_GT(axis.RunUntilDone(), 0);
  result.end = axis.R("I80");
  return result;
}

TEST(StoberAxis, CT23_MoveAdditiveStartingPointTable11) {
  const Command abs = Command::kMoveAbsolute;
  const Command add = Command::kMoveAdditive;
  const Command rel = Command::kMoveRelative;
  EXPECT_DOUBLE_EQ(RunRow(0, abs, 1000, Interrupt::kNone, 0).end, 1200);      // 1
  EXPECT_DOUBLE_EQ(RunRow(0, abs, 1000, Interrupt::kStop, 578.9).end, 1200);  // 2
  RowResult r3 = RunRow(0, abs, 1000, Interrupt::kEnableOff, 578.9);          // 3: 778.9
  EXPECT_NEAR(r3.at_interrupt, 578.9, 0.5);
  EXPECT_DOUBLE_EQ(r3.end, r3.at_interrupt + 200);
  EXPECT_DOUBLE_EQ(RunRow(0, add, 200, Interrupt::kNone, 0).end, 400);     // 4
  EXPECT_DOUBLE_EQ(RunRow(0, add, 200, Interrupt::kStop, 91.2).end, 400);  // 5
  RowResult r6 = RunRow(0, add, 200, Interrupt::kEnableOff, 91.2);         // 6: 291.2
  EXPECT_NEAR(r6.at_interrupt, 91.2, 0.5);
  EXPECT_DOUBLE_EQ(r6.end, r6.at_interrupt + 200);
  EXPECT_DOUBLE_EQ(RunRow(9.5, rel, 200, Interrupt::kNone, 0).end, 409.5);     // 7
  EXPECT_DOUBLE_EQ(RunRow(9.5, rel, 200, Interrupt::kStop, 91.2).end, 409.5);  // 8
  RowResult r9 = RunRow(9.5, rel, 200, Interrupt::kEnableOff, 91.2);           // 9: 291.2
  EXPECT_NEAR(r9.at_interrupt, 91.2, 0.5);
  EXPECT_DOUBLE_EQ(r9.end, r9.at_interrupt + 200);
}

TEST(StoberAxis, CT24_MoveAdditiveBaseAfterEnableOffInsideWindow) {
  TestAxis axis;
  axis.MoveAbsolute(1000);
  ASSERT_GT(axis.RunUntilDone(), 0);
  axis.Advance(20);
  axis.W("A515", cw::kDisableOperationWord);
  axis.Advance(3);
  axis.W("A515", cw::kEnableOperationWord);
  axis.Advance();
  axis.W("I403", 200);
  axis.Start(Command::kMoveAdditive);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 1200);
}

// Cycles of I180↑, I85↑ and I92↑ after a MoveAbsolute 1000 with window `window`, time I87.
struct DoneTiming {
  int in_window = -1;
  int profile_done = -1;
  int done = -1;
  bool moving_when_in_window = false;
};
DoneTiming Timing(double window, double window_time) {
  TestAxis axis;
  axis.W("I22", window);
  axis.W("I87", window_time);
  axis.MoveAbsolute(1000);
  DoneTiming t;
  for (int i = 1; i <= 5000 && t.done < 0; ++i) {
    axis.Advance();
    if (t.in_window < 0 && axis.B("I180")) {
      t.in_window = i;
      t.moving_when_in_window = axis.R("I88") != 0;
    }
    if (t.profile_done < 0 && axis.B("I85")) t.profile_done = i;
    if (t.done < 0 && axis.B("I92")) t.done = i;
  }
  return t;
}

TEST(StoberAxis, CT25_DoneNeedsProfileDoneAndWindowHeldForI87) {
  // A window of 0.002 u is entered ≈ 6 ms before the profile ends (jerk 50000: s = j·t³/6).
  DoneTiming fast = Timing(0.002, 2);
  ASSERT_GT(fast.done, 0);
  EXPECT_TRUE(fast.moving_when_in_window);
  EXPECT_GE(fast.profile_done - fast.in_window, 3);
  EXPECT_EQ(fast.done, fast.profile_done);  // example 1: I92 with I85
  DoneTiming slow = Timing(0.002, 50);
  ASSERT_GT(slow.done, 0);
  EXPECT_TRUE(slow.moving_when_in_window);
  EXPECT_LT(slow.profile_done, slow.done);    // example 2: I85 first
  EXPECT_EQ(slow.done - slow.in_window, 50);  // I92 50 ms after I180
}

TEST(StoberAxis, CT25b_FollowingLagDelaysWindowAndDone) {
  MotionCoreOptions options;
  options.following_time_constant_ms = 20;
  TestAxis axis(Fixture::kLin, options);
  axis.W("I22", 0.01);
  axis.MoveAbsolute(1000);
  int profile_done = -1, done = -1;
  for (int i = 1; i <= 5000 && done < 0; ++i) {
    axis.Advance();
    if (profile_done < 0 && axis.B("I85")) profile_done = i;
    if (done < 0 && axis.B("I92")) done = i;
  }
  ASSERT_GT(done, profile_done);
  EXPECT_GE(done - profile_done, 10);  // the lag keeps the actual position out of I22 a while
  EXPECT_NEAR(axis.R("I80"), 1000, 0.01);
}

TEST(StoberAxis, CT26_MoveAbsoluteRequiresReferencedAxis) {
  TestAxis axis;
  axis.core().SetReferenced(false);
  axis.MoveAbsolute(100);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_THAT(axis.core().error_text(), HasSubstr("I86"));
}

// Endless axis: start at `from`, MoveAbsolute `to` with direction mode; returns the travel.
double EndlessTravel(double from, double to, int mode) {
  TestAxis axis(Fixture::kEnd);
  axis.core().SetActualPosition(from);
  axis.W("I411", mode);
  axis.MoveAbsolute(to);
  EXPECT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.R("I80"), to, 1e-9);
  return axis.core().actual_position_unwrapped() - from;
}

TEST(StoberAxis, CT27_ShortestPathFromStandstill) {
  EXPECT_NEAR(EndlessTravel(350, 10, 0), 20, 1e-9);
  EXPECT_NEAR(EndlessTravel(350, 10, 3), 20, 1e-9);
  EXPECT_NEAR(EndlessTravel(10, 350, 0), -20, 1e-9);
  EXPECT_NEAR(EndlessTravel(0, 180, 0), 180, 1e-9);  // tie → positive (G-33)
}

TEST(StoberAxis, CT28_OnlyPositiveOnlyNegativeFromStandstill) {
  EXPECT_NEAR(EndlessTravel(10, 350, 1), 340, 1e-9);
  EXPECT_NEAR(EndlessTravel(350, 10, 2), -340, 1e-9);
}

TEST(StoberAxis, CT29_ForcedDirectionIgnoredInsideWindow) {
  EXPECT_NEAR(EndlessTravel(10, 9.5, 1), -0.5, 1e-9);
  EXPECT_NEAR(EndlessTravel(9.5, 10, 2), 0.5, 1e-9);
}

TEST(StoberAxis, CT30_TargetOutsideRevolutionLengthDenied) {
  for (double target : {400.0, 360.0, -1.0}) {
    TestAxis axis(Fixture::kEnd);
    axis.MoveAbsolute(target);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1) << target;
    EXPECT_THAT(axis.core().error_text(), HasSubstr("revolution length I01"));
  }
}

TEST(StoberAxis, CT31_FromMotionModeZeroKeepsDirection) {
  TestAxis axis(Fixture::kEnd);
  axis.core().SetActualPosition(300);
  axis.W("I404", -200);
  axis.Start(Command::kMoveVelocity);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I80") <= 200; }), 0);
  const double from = axis.core().actual_position_unwrapped();
  axis.W("I404", 500);
  axis.W("I411", 0);
  axis.MoveAbsolute(210);
  bool reversed = false;
  ASSERT_GT(axis.RunUntil([&] {
    reversed = reversed || axis.R("E07") > 0;
    return axis.B("I92");
  }),
            0);
  EXPECT_FALSE(reversed);
  EXPECT_NEAR(axis.R("I80"), 210, 1e-9);
  const double travel = axis.core().actual_position_unwrapped() - from;
  EXPECT_NEAR(travel, -350, 1);
}

TEST(StoberAxis, CT31b_FromMotionExtraRevolutionWhenTooCloseToBrake) {
  TestAxis axis(Fixture::kEnd);
  axis.core().SetActualPosition(300);
  axis.W("I404", -1000);
  axis.Start(Command::kMoveVelocity);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I80") <= 200 && axis.R("E07") == -1000; }), 0);
  const double from = axis.core().actual_position_unwrapped();
  axis.W("I404", 1000);
  axis.W("I406", 1000);  // braking from 1000 u/s needs > 500 u
  axis.MoveAbsolute(190);
  bool reversed = false;
  ASSERT_GT(axis.RunUntil([&] {
    reversed = reversed || axis.R("E07") > 0;
    return axis.B("I92");
  }),
            0);
  EXPECT_FALSE(reversed);
  EXPECT_NEAR(axis.R("I80"), 190, 1e-9);
  const double travel = axis.core().actual_position_unwrapped() - from;
  EXPECT_LT(travel, -360);  // at least one more revolution (L308)
}

TEST(StoberAxis, CT32_FromMotionForcedDirectionBrakesAndReverses) {
  TestAxis axis(Fixture::kEnd);
  axis.core().SetActualPosition(300);
  axis.W("I404", -200);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(300);
  axis.W("I404", 500);
  axis.W("I411", 1);
  axis.MoveAbsolute(100);
  bool positive = false;
  double last_velocity = 0;
  ASSERT_GT(axis.RunUntil([&] {
    const double v = axis.R("E07");
    positive = positive || v > 0;
    if (v != 0) last_velocity = v;
    return axis.B("I92");
  }),
            0);
  EXPECT_TRUE(positive);
  EXPECT_GT(last_velocity, 0);
  EXPECT_NEAR(axis.R("I80"), 100, 1e-9);
}

TEST(StoberAxis, CT33_PermittedDirectionBlocks) {
  {
    TestAxis axis(Fixture::kEnd);
    axis.W("I04", 1);
    axis.core().SetActualPosition(200);
    axis.W("I411", 2);
    axis.MoveAbsolute(100);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_THAT(axis.core().error_text(), HasSubstr("permitted direction I04"));
  }
  {
    TestAxis axis(Fixture::kEnd);
    axis.W("I04", 1);
    axis.W("I404", -100);
    axis.Start(Command::kMoveVelocity);
    axis.Advance();
    EXPECT_EQ(axis.R("I91"), 1);
    EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kPermittedDirection));
  }
  TestAxis axis(Fixture::kEnd);  // the permitted direction still works
  axis.W("I04", 1);
  axis.core().SetActualPosition(200);
  axis.W("I411", 1);
  axis.MoveAbsolute(100);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.core().actual_position_unwrapped(), 460, 1e-9);
}

}  // namespace
}  // namespace drivegw::sim::stober
