// Further behaviour of the simulated STOBER axis beyond the §10 contract cases: CiA 402 cyclic
// modes through their objects, limit switches in MoveSpeed/TorqueControl, homing errors,
// endless MoveRelative (decisions 1144, 1150, 1152, 1153).
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

TEST(StoberAxisModes, CyclicSynchronousVelocityThroughCiA402Objects) {
  TestAxis axis(Fixture::kCyc);
  axis.W("A541", 9);  // CSV → MC_CyclicSpeed
  axis.W("A592", 50);
  axis.W("A638", 100);
  EXPECT_EQ(axis.R("I426"), 150);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute);
  axis.Advance();
  EXPECT_EQ(axis.R("I89"), 11);
  for (int i = 0; i < 10; ++i) {
    axis.W("A638", 100);
    axis.Advance();
  }
  EXPECT_NEAR(axis.R("E07"), 150, 1e-9);
  EXPECT_NE(static_cast<int>(axis.R("A516")) & sw::kOpModeSpecific12, 0);
  EXPECT_TRUE(axis.core().events().empty());
}

TEST(StoberAxisModes, CyclicSynchronousPositionThroughA567) {
  TestAxis axis(Fixture::kCyc);
  axis.W("A541", 8);  // CSP → MC_CyclicPosition, set position A567
  axis.W("A567", 0);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute);
  axis.Advance();
  for (int i = 1; i <= 100; ++i) {
    axis.W("A567", 0.5 * i);  // 500 u/s
    axis.Advance();
  }
  EXPECT_NEAR(axis.R("I80"), 50, 1e-9);
  EXPECT_NEAR(axis.R("E07"), 500, 1e-6);
}

TEST(StoberAxisModes, MoveSpeedAtLimitSwitchQuickStopsThenFollowsAwayOnly) {
  MotionCoreOptions options;
  options.positive_limit_switch = 200;
  TestAxis axis(Fixture::kLin, options);
  axis.W("I426", 300);
  axis.W("I216", 5000);
  axis.W("I217", 5000);
  axis.Start(Command::kMoveSpeed);
  ASSERT_GT(axis.RunUntil([&] { return axis.B("I441"); }), 0);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("E07") == 0; }, 1000), 0);
  EXPECT_EQ(axis.R("I89"), 4);
  EXPECT_EQ(axis.R("I91"), 0);
  axis.Advance(100);
  EXPECT_EQ(axis.R("E07"), 0);  // +300 towards the switch is ignored
  axis.W("I426", -100);
  ASSERT_GT(axis.RunUntil([&] { return std::abs(axis.R("E07") + 100) < 1e-9; }, 1000), 0);
}

TEST(StoberAxisModes, TorqueTowardsActiveLimitSwitchIsZero) {
  TestAxis axis;
  axis.core().ForceLimitSwitch(true, true);
  axis.W("I428", 50);
  axis.Start(Command::kTorqueControl);
  axis.Advance(50);
  EXPECT_EQ(axis.R("E90"), 0);
  EXPECT_EQ(axis.R("I88"), 0);
  EXPECT_LT(axis.R("I80"), 1);  // the quick stop does not carry the torque step's acceleration
  axis.W("I428", -50);
  axis.Advance(50);
  EXPECT_EQ(axis.R("E90"), -50);
  EXPECT_LT(axis.R("I88"), 0);
}

TEST(StoberAxisModes, HomeZeroPulseNotFoundWithinI37) {
  MotionCoreOptions options;
  options.zero_pulse_spacing = 1000;
  options.zero_pulse_offset = 500;
  TestAxis axis(Fixture::kLin, options);
  axis.W("A586", 34);  // N: zero pulse, positive
  axis.W("I37", 100);
  axis.W("I33", 100);
  axis.Start(Command::kHome);
  ASSERT_GT(axis.RunUntil([&] { return axis.B("I91"); }), 0);
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kZeroPulseNotFound));
  EXPECT_THAT(axis.core().error_text(), HasSubstr("I37"));
  EXPECT_EQ(axis.R("I86"), 0);
  EXPECT_EQ(axis.R("I89"), 7);
}

TEST(StoberAxisModes, HomeOnZeroPulseOnly) {
  MotionCoreOptions options;
  options.zero_pulse_spacing = 360;
  options.zero_pulse_offset = 30;
  TestAxis axis(Fixture::kLin, options);
  axis.W("A586", 33);  // M: zero pulse, negative → pulse at machine −330
  axis.W("I33", 50);
  axis.W("I34", 7);
  axis.Start(Command::kHome);
  int cycles = 0;
  double at_reference = NAN;
  cycles = axis.RunUntil([&] {
    if (std::isnan(at_reference) && axis.B("I86")) at_reference = axis.R("I80");
    return axis.B("I92");
  });
  ASSERT_GT(cycles, 0);
  EXPECT_NEAR(at_reference, 7, 0.051);
  EXPECT_GT(cycles, 330 / 50 * 1000);  // travelled ≈ 330 u at 50 u/s
}

// Reference-switch search in either direction, also when the search starts on the switch: the
// reference point is always the switch edge on the approach side (decision 1150).
double ReferenceSwitchHome(double start, int direction) {
  MotionCoreOptions options;
  options.reference_switch = {{-100, -50}};
  TestAxis axis(Fixture::kLin, options);
  axis.core().SetActualPosition(start);
  axis.W("I30", 1);
  axis.W("I31", direction);
  axis.W("I33", 10);
  axis.W("I34", 1000);
  axis.Start(Command::kHome);
  EXPECT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I86"), 1);
  EXPECT_EQ(axis.R("I89"), 2);
  return axis.R("I80");
}

TEST(StoberAxisModes, ReferenceSwitchSearchBothDirectionsAndFromOnTheSwitch) {
  // The reference point reads I34 = 1000; the stop from the slow 10 u/s with I39 = 1000,
  // I44 = 10000 adds ≈ 0.32 u in the return direction.
  // Negative search from 0 meets the switch at −50 and leaves it there going back (positive).
  const double negative = ReferenceSwitchHome(0, 1);
  EXPECT_GT(negative, 1000);
  EXPECT_LT(negative, 1000.5);
  // Positive search from −200 leaves it at −100 going back (negative).
  const double positive = ReferenceSwitchHome(-200, 0);
  EXPECT_LT(positive, 1000);
  EXPECT_GT(positive, 999.5);
  // Starting on the switch (−70) searching negative: out positive through −50, as the first.
  EXPECT_NEAR(ReferenceSwitchHome(-70, 1), negative, 1e-3);
}

TEST(StoberAxisModes, EndlessMoveRelativeWrapsAround) {
  TestAxis axis(Fixture::kEnd);
  axis.core().SetActualPosition(350);
  axis.W("I403", 20);
  axis.Start(Command::kMoveRelative);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.R("I80"), 10, 1e-9);
  EXPECT_NEAR(axis.R("I96"), 10, 1e-9);
}

TEST(StoberAxisModes, NewCommandAfterTorqueControlContinuesWithoutJump) {
  TestAxis axis;
  axis.W("I428", 20);
  axis.Start(Command::kTorqueControl);
  axis.Advance(100);
  const double v = axis.R("I88");
  ASSERT_GT(v, 0);
  axis.W("I404", 100);
  axis.Start(Command::kMoveVelocity);
  EXPECT_NEAR(axis.R("E07"), v, v * 0.05 + 1);  // starts from the torque mode's velocity
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_NEAR(axis.R("E07"), 100, 1e-9);
}

}  // namespace
}  // namespace drivegw::sim::stober
