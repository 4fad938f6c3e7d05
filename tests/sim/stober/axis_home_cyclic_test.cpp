// stober-motion.md §10.8-10.9: MC_Home with simulated sensors, cyclic and torque commands
// (CT-52 … CT-66), AXIS target, fixtures F-LIN / F-CYC, 1 ms cycles.
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

TEST(StoberAxis, CT52_HomeOnlyFromStandstill) {
  TestAxis axis;
  axis.W("I30", 5);
  axis.W("I404", 300);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(100);
  axis.Start(Command::kHome);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_THAT(axis.core().error_text(), HasSubstr("I89 = 2"));
}

TEST(StoberAxis, CT53_HomeWithInactiveReferencingTypeDenied) {
  TestAxis axis;
  axis.W("I30", 0);
  axis.Start(Command::kHome);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kReferencingInactive));
}

TEST(StoberAxis, CT54_ZeroReferencingSpeedIsNoDenial) {
  MotionCoreOptions options;
  options.reference_switch = {{800, 820}};
  TestAxis axis(Fixture::kLin, options);
  axis.W("I30", 1);
  axis.W("I32", 0);
  axis.Start(Command::kHome);
  for (int i = 0; i < 200; ++i) {
    axis.Advance();
    ASSERT_EQ(axis.R("I91"), 0);
  }
  EXPECT_EQ(axis.R("I92"), 0);  // G-11: busy without motion
  EXPECT_EQ(axis.R("I89"), 8);
  EXPECT_EQ(axis.R("I80"), 0);
}

TEST(StoberAxis, CT55_DefineHome) {
  TestAxis axis;
  axis.core().SetActualPosition(250);
  axis.core().SetReferenced(false);
  axis.W("I30", 5);
  axis.W("I34", 123);
  axis.Start(Command::kHome);
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I92"), 0);
  axis.Advance();
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I80"), 123);
  EXPECT_EQ(axis.R("I86"), 1);
  EXPECT_EQ(axis.R("I92"), 1);
  EXPECT_EQ(axis.R("I183"), 0);
  EXPECT_EQ(axis.R("I85"), 0);
}

TestAxis ReferenceSwitchAxis() {
  MotionCoreOptions options;
  options.reference_switch = {{800, 820}};
  TestAxis axis(Fixture::kLin, options);
  axis.core().SetReferenced(false);
  axis.W("I30", 1);
  axis.W("I31", 0);  // positive
  axis.W("I35", 0);
  axis.W("I34", 0);
  axis.W("I32", 2000);  // above I10
  axis.W("I33", 10);
  axis.W("I39", 5000);
  axis.W("I44", 50000);
  return axis;
}

TEST(StoberAxis, CT56_ReferenceSwitchSearch) {
  TestAxis axis = ReferenceSwitchAxis();
  axis.Start(Command::kHome);
  EXPECT_EQ(axis.R("I89"), 8);
  double max_v = 0;
  bool flag = false;
  double at_reference = NAN;
  ASSERT_GT(axis.RunUntil([&] {
    max_v = std::max(max_v, std::abs(axis.R("E07")));
    flag = flag || axis.B("I190") || axis.B("I191");
    if (std::isnan(at_reference) && axis.B("I86")) at_reference = axis.R("I80");
    if (!axis.B("I92")) {
      EXPECT_EQ(axis.R("I89"), 8);
    }
    return axis.B("I92");
  }),
            0);
  EXPECT_NEAR(max_v, 1000, 1e-9);
  EXPECT_FALSE(flag);
  // The reference point (the switch edge at machine 800) reads I34 = 0; the slow speed moves
  // at most 10 u/s · 1 ms past it within the cycle.
  EXPECT_LE(std::abs(at_reference), 0.0101);
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I86"), 1);
  EXPECT_EQ(axis.R("I92"), 1);
  EXPECT_EQ(axis.R("I91"), 0);
  // Machine position 800 is user position 0 from now on.
  EXPECT_NEAR(axis.core().actual_position_unwrapped(), axis.R("I80"), 1e-9);
}

TEST(StoberAxis, CT56b_ReferenceSwitchWithZeroPulseAndMoveToReference) {
  MotionCoreOptions options;
  options.reference_switch = {{800, 820}};
  options.zero_pulse_spacing = 360;
  options.zero_pulse_offset = 50;  // pulses at …, 410, 770, 1130 (machine)
  TestAxis axis(Fixture::kLin, options);
  axis.W("I30", 1);
  axis.W("I35", 1);
  axis.W("I34", 1000);
  axis.W("I33", 100);
  axis.W("I43", 1);
  axis.Start(Command::kHome);
  ASSERT_GT(axis.RunUntilDone(60000), 0);
  // Switch edge at 800 going back, next zero pulse at 770 = 1000; then travel to I34.
  EXPECT_NEAR(axis.R("I80"), 1000, 1e-9);
  EXPECT_NEAR(axis.core().actual_position_unwrapped() - 1000 + 770, 770, 1e-9);
}

TEST(StoberAxis, CT56c_LimitSwitchAndTorqueStopMethods) {
  {
    MotionCoreOptions options;
    options.negative_limit_switch = -500;
    TestAxis axis(Fixture::kLin, options);
    axis.W("A586", 17);  // C: negative limit switch, no zero pulse
    axis.W("A569", -10);
    axis.W("A588", 5000);
    axis.W("A587[0]", 400);
    axis.W("A587[1]", 20);
    axis.Start(Command::kHome);
    ASSERT_GT(axis.RunUntilDone(), 0);
    EXPECT_EQ(axis.R("I91"), 0);
    EXPECT_EQ(axis.R("I86"), 1);
    // Reference at the switch edge (machine −500 → −10), stopped just past it: from 20 u/s
    // with I44 = 10000 u/s³ the stop takes ≈ 0.9 u.
    EXPECT_GT(axis.R("I80"), -10);
    EXPECT_LT(axis.R("I80"), -9);
  }
  MotionCoreOptions options;
  options.positive_end_stop = 200;
  TestAxis axis(Fixture::kLin, options);
  axis.W("I30", 4);
  axis.W("I28", 100);  // E65 = 300 % exceeds it at the stop
  axis.W("I29", 50);
  axis.W("I34", 0);
  axis.Start(Command::kHome);
  const int cycles = axis.RunUntilDone();
  ASSERT_GT(cycles, 0);
  EXPECT_EQ(axis.R("I86"), 1);
  EXPECT_NEAR(axis.R("I80"), 0, 1e-9);
}

TEST(StoberAxis, CT57_HomeRespectsOverrideZero) {
  TestAxis axis = ReferenceSwitchAxis();
  axis.Start(Command::kHome);
  axis.Advance(200);
  axis.W("I230", 0);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000), 0);
  const double held = axis.R("I80");
  axis.Advance(300);
  EXPECT_EQ(axis.R("I80"), held);
  EXPECT_EQ(axis.R("I89"), 8);
  axis.W("I230", 100);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I86"), 1);
}

// Runs a cyclic command for `cycles`, writing `value(i)` to `id` before every cycle.
template <typename F>
void Feed(TestAxis& axis, const char* id, int cycles, F value) {
  for (int i = 0; i < cycles; ++i) {
    axis.W(id, value(i));
    axis.Advance();
  }
}

TEST(StoberAxis, CT58_CyclicCommandsNeverDenied) {
  for (Command c : {Command::kCyclicSpeed, Command::kCyclicPosition, Command::kTorqueControl}) {
    TestAxis axis(Fixture::kCyc);
    axis.W("I11", 0);
    axis.W("I16", 0);
    axis.Start(c);
    Feed(axis, "I426", 3, [](int) { return 0.0; });
    EXPECT_EQ(axis.R("I91"), 0) << static_cast<int>(c);
  }
}

TEST(StoberAxis, CT59_DoneFromTheSecondCycle) {
  const std::pair<Command, int> cases[] = {
      {Command::kCyclicSpeed, 11}, {Command::kCyclicPosition, 11}, {Command::kTorqueControl, 4}};
  for (auto [command, state] : cases) {
    TestAxis axis(Fixture::kCyc);
    const char* id = command == Command::kCyclicPosition ? "I421" : "I426";
    axis.Start(command);  // cycle k
    EXPECT_EQ(axis.R("I92"), 0);
    EXPECT_EQ(axis.R("I89"), state);
    axis.W(id, 0);
    axis.Advance();  // k + 1
    EXPECT_EQ(axis.R("I92"), 0);
    axis.W(id, 0);
    axis.Advance();  // k + 2 (G-32)
    EXPECT_EQ(axis.R("I92"), 1);
    EXPECT_EQ(axis.R("I89"), state);
  }
}

TEST(StoberAxis, CT60_CyclicSpeedClampsToI10) {
  TestAxis axis(Fixture::kCyc);
  axis.W("I426", 0);
  axis.Start(Command::kCyclicSpeed);
  Feed(axis, "I426", 5, [](int) { return 1500.0; });
  EXPECT_NEAR(axis.R("E07"), 1000, 1e-9);
}

TEST(StoberAxis, CT61_ImpermissibleDirectionFiltered) {
  {
    TestAxis axis(Fixture::kCyc);
    axis.W("I04", 1);
    axis.Start(Command::kCyclicSpeed);
    Feed(axis, "I426", 5, [](int) { return -100.0; });
    EXPECT_EQ(axis.R("E07"), 0);
    EXPECT_EQ(axis.R("I193"), 1);
    Feed(axis, "I426", 5, [](int) { return 100.0; });
    EXPECT_NEAR(axis.R("E07"), 100, 1e-9);
  }
  TestAxis axis(Fixture::kCyc);
  axis.W("I04", 1);
  axis.core().SetActualPosition(100);
  axis.W("I421", 100);
  axis.Start(Command::kCyclicPosition);
  Feed(axis, "I421", 10, [](int i) { return 99.0 - i; });
  EXPECT_EQ(axis.R("I80"), 100);
  EXPECT_EQ(axis.R("I192"), 1);
  EXPECT_EQ(axis.R("I193"), 1);
}

TEST(StoberAxis, CT62_ExtrapolationThenEvent78Cause3) {
  TestAxis axis(Fixture::kCyc);
  axis.W("I426", 200);
  axis.Start(Command::kCyclicSpeed);
  Feed(axis, "I426", 10, [](int) { return 200.0; });
  ASSERT_TRUE(axis.core().events().empty());
  for (int i = 1; i <= 5; ++i) {  // 5 ms extrapolated at 200
    axis.Advance();
    EXPECT_NEAR(axis.R("E07"), 200, 1e-9) << i;
    EXPECT_TRUE(axis.core().events().empty()) << i;
  }
  axis.Advance();
  ASSERT_EQ(axis.core().events().size(), 1u);
  EXPECT_EQ(axis.core().events()[0].number, 78);
  EXPECT_EQ(axis.core().events()[0].cause, 3);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);  // G-31
  EXPECT_EQ(axis.R("I89"), 7);
  EXPECT_LT(axis.R("E07"), 200);
}

TEST(StoberAxis, CT62b_DroppedTelegramsAreExtrapolated) {
  TestAxis axis(Fixture::kCyc);
  axis.W("I426", 100);
  axis.Start(Command::kCyclicSpeed);
  Feed(axis, "I426", 3, [](int i) { return 100.0 + 10 * i; });  // 100, 110, 120
  axis.core().DropCyclicSetValues(true);
  Feed(axis, "I426", 2, [](int) { return 500.0; });  // lost
  EXPECT_NEAR(axis.R("E07"), 140, 1e-9);             // linear continuation
  axis.core().DropCyclicSetValues(false);
  Feed(axis, "I426", 2, [](int) { return 150.0; });
  EXPECT_NEAR(axis.R("E07"), 150, 1e-9);
  EXPECT_TRUE(axis.core().events().empty());
}

TEST(StoberAxis, CT63_LimitSwitchDuringCyclicMotion) {
  TestAxis axis(Fixture::kCyc);
  axis.W("I426", 200);
  axis.Start(Command::kCyclicSpeed);
  Feed(axis, "I426", 20, [](int) { return 200.0; });
  axis.core().ForceLimitSwitch(true, true);
  // The switch is seen at the end of the cycle; the quick stop ramps from the next one.
  Feed(axis, "I426", 2, [](int) { return 200.0; });
  EXPECT_LT(axis.R("E07"), 200);
  EXPECT_GT(axis.R("E07"), 0);
  Feed(axis, "I426", 200, [](int) { return 100.0; });
  EXPECT_EQ(axis.R("E07"), 0);
  EXPECT_EQ(axis.R("I89"), 11);
  Feed(axis, "I426", 5, [](int) { return -100.0; });
  EXPECT_NEAR(axis.R("E07"), -100, 1e-9);
}

TEST(StoberAxis, CT64_CyclicPositionOnEndlessAxis) {
  TestAxis axis(Fixture::kCyc);
  axis.W("I00", 1);
  axis.W("I01", 360);
  axis.core().SetActualPosition(350);
  axis.W("I421", 350);
  axis.Start(Command::kCyclicPosition);
  const double sequence[] = {355, 0, 5, 10};
  for (double p : sequence) {
    axis.W("I421", p);
    axis.Advance();
  }
  Feed(axis, "I421", 30, [](int) { return 10.0; });  // |v| <= I10 spreads the steps
  EXPECT_NEAR(axis.core().actual_position_unwrapped() - 350, 20, 1e-9);
  EXPECT_NEAR(axis.R("I80"), 10, 1e-9);
  axis.W("I421", 400);
  axis.Advance();
  ASSERT_EQ(axis.core().events().size(), 1u);
  EXPECT_EQ(axis.core().events()[0].cause, 2);
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 1);
}

TEST(StoberAxis, CT65_CyclicStatusBitsUnused) {
  for (Command c : {Command::kCyclicSpeed, Command::kCyclicPosition}) {
    TestAxis axis(Fixture::kCyc);
    axis.Start(c);
    const char* id = c == Command::kCyclicSpeed ? "I426" : "I421";
    for (int i = 0; i < 100; ++i) {
      axis.W(id, c == Command::kCyclicSpeed ? 100.0 : 0.1 * i);
      axis.Advance();
      ASSERT_EQ(axis.R("I183"), 0);
      ASSERT_EQ(axis.R("I85"), 0);
    }
  }
}

TEST(StoberAxis, CT66_TorqueControlLimitsAndStatus) {
  TestAxis axis;
  axis.W("I428", 500);  // above E65 = 300 %
  axis.Start(Command::kTorqueControl);
  double max_v = 0;
  for (int i = 0; i < 3000; ++i) {
    axis.Advance();
    max_v = std::max(max_v, std::abs(axis.R("I88")));
    ASSERT_EQ(axis.R("I91"), 0);
    ASSERT_EQ(axis.R("I85"), 0);
    ASSERT_EQ(axis.R("I183"), 0);
  }
  EXPECT_EQ(axis.R("I194"), 1);
  EXPECT_EQ(axis.R("E90"), 300);
  EXPECT_NEAR(max_v, 1000, 1e-9);
}

TEST(StoberAxis, CT66b_TorqueRampsAndLoad) {
  MotionCoreOptions options;
  options.load_torque = 20;
  TestAxis axis(Fixture::kLin, options);
  axis.W("I428", 50);
  axis.W("I430", 1000);  // %/s
  axis.Start(Command::kTorqueControl);
  EXPECT_NEAR(axis.R("E90"), 1, 1e-9);
  axis.Advance(100);
  EXPECT_NEAR(axis.R("E90"), 50, 1e-9);
  EXPECT_GT(axis.R("I88"), 0);  // 50 % drive against 20 % load
  axis.W("I428", 10);           // below the load: decelerates
  const double v = axis.R("I88");
  axis.Advance(20);
  EXPECT_LT(axis.R("I88"), v);
}

}  // namespace
}  // namespace drivegw::sim::stober
