// CiA 402 power state machine and its effect on the motion core (stober-motion.md §2.13,
// G-18, decisions 1143-1146).
#include "sim/stober/cia402.h"

#include "axis_fixture.h"
#include "gtest/gtest.h"

namespace drivegw::sim::stober {
namespace {

using testing::TestAxis;

constexpr uint16_t kRemote = sw::kRemote;

TEST(StoberCia402, PowerUpSequenceToOperationEnabled) {
  PowerStateMachine m;
  EXPECT_EQ(m.state(), PowerState::kNotReadyToSwitchOn);
  EXPECT_EQ(m.StatusWord({}), kRemote);
  m.Step(0, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x40);
  m.Step(cw::kEnableOperationWord, true);  // not a valid command in Switch on disabled
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
  m.Step(cw::kShutdownWord, true);
  EXPECT_EQ(m.state(), PowerState::kReadyToSwitchOn);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x31);
  m.Step(cw::kSwitchOnWord, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchedOn);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x33);
  m.Step(cw::kEnableOperationWord, true);
  EXPECT_EQ(m.state(), PowerState::kOperationEnabled);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x37);
  EXPECT_TRUE(m.operation_enabled());
}

TEST(StoberCia402, DisableOperationShutdownDisableVoltage) {
  PowerStateMachine m(/*operation_enabled=*/true);
  m.Step(cw::kDisableOperationWord, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchedOn);
  m.Step(cw::kEnableOperationWord, true);
  m.Step(cw::kShutdownWord, true);
  EXPECT_EQ(m.state(), PowerState::kReadyToSwitchOn);
  m.Step(cw::kEnableOperationWord, true);  // 3 then 4
  EXPECT_EQ(m.state(), PowerState::kSwitchedOn);
  m.Step(cw::kEnableOperationWord, true);
  EXPECT_EQ(m.state(), PowerState::kOperationEnabled);
  m.Step(cw::kDisableVoltageWord, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
}

TEST(StoberCia402, QuickStopRampsThenSwitchOnDisabled) {
  PowerStateMachine m(true);
  m.Step(cw::kQuickStopWord, /*motion_stopped=*/false);
  EXPECT_EQ(m.state(), PowerState::kQuickStopActive);
  EXPECT_EQ(m.StatusWord({}) & sw::kQuickStop, 0);  // bit 5 = 0 while quick stop is active
  EXPECT_TRUE(m.stopping());
  m.Step(cw::kQuickStopWord, false);
  EXPECT_EQ(m.state(), PowerState::kQuickStopActive);
  m.Step(cw::kQuickStopWord, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
}

TEST(StoberCia402, FaultReactionFaultAndResetOnRisingEdgeOnly) {
  PowerStateMachine m(true);
  m.RaiseFault();
  EXPECT_EQ(m.state(), PowerState::kFaultReactionActive);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x1F);
  m.Step(cw::kEnableOperationWord, false);
  EXPECT_EQ(m.state(), PowerState::kFaultReactionActive);
  m.Step(cw::kEnableOperationWord, true);
  EXPECT_EQ(m.state(), PowerState::kFault);
  EXPECT_EQ(m.StatusWord({}), kRemote | 0x08);
  m.Step(cw::kFaultResetWord | cw::kEnableOperationWord, true);  // rising edge of bit 7
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
  m.RaiseFault();
  m.Step(cw::kFaultResetWord, true);  // bit 7 still high: no edge, stays in Fault
  EXPECT_EQ(m.state(), PowerState::kFault);
  m.Step(0, true);
  m.Step(cw::kFaultResetWord, true);
  EXPECT_EQ(m.state(), PowerState::kSwitchOnDisabled);
}

TEST(StoberCia402, StatusWordExtraBits) {
  PowerStateMachine m(true);
  StatusWordInputs in{.warning = true,
                      .target_reached = true,
                      .internal_limit_active = true,
                      .op_mode_bit12 = true,
                      .op_mode_bit13 = true};
  EXPECT_EQ(m.StatusWord(in), kRemote | 0x37 | sw::kWarning | sw::kTargetReached |
                                  sw::kInternalLimitActive | sw::kOpModeSpecific12 |
                                  sw::kOpModeSpecific13);
}

TEST(StoberCia402, AxisStartsDisabledAndIsEnabledThroughTheControlWord) {
  MotionCore core;
  EXPECT_EQ(*core.Read(P("I89")), 0);
  core.Advance();
  EXPECT_EQ(core.power_state(), PowerState::kSwitchOnDisabled);
  // A command while not enabled is denied (G-07 "not ready", cause 13).
  ASSERT_TRUE(core.Write(P("I401"), 1).ok());
  ASSERT_TRUE(core.Write(P("I403"), 100).ok());
  ASSERT_TRUE(core.Write(P("I402"), 1).ok());
  core.Advance();
  EXPECT_EQ(*core.Read(P("I91")), 0);  // start cycle
  core.Advance();
  EXPECT_EQ(*core.Read(P("I91")), 1);
  EXPECT_EQ(*core.Read(P("I90")), static_cast<int>(Cause::kNotEnabled));
  EXPECT_EQ(*core.Read(P("I80")), 0);
  for (uint16_t word : {cw::kShutdownWord, cw::kSwitchOnWord, cw::kEnableOperationWord}) {
    ASSERT_TRUE(core.Write(P("A515"), word).ok());
    core.Advance();
  }
  EXPECT_EQ(core.power_state(), PowerState::kOperationEnabled);
  EXPECT_EQ(*core.Read(P("I89")), 2);
  EXPECT_EQ(static_cast<int>(*core.Read(P("A516"))) & 0x6F, 0x27);
}

TEST(StoberCia402, ProfilePositionModeThroughCiA402Objects) {
  TestAxis axis;
  axis.W("A541", 1);  // profile position → MoveAbsolute (A515.6 = 0)
  axis.W("A567", 300);
  axis.W("A574", 400);
  EXPECT_EQ(axis.R("I401"), 1);
  EXPECT_EQ(axis.R("I404"), 400);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute);
  axis.Advance();
  EXPECT_EQ(axis.R("A542"), 1);
  const int status = static_cast<int>(axis.R("A516"));
  EXPECT_NE(status & sw::kOpModeSpecific12, 0);  // set-point acknowledge
  EXPECT_EQ(status & sw::kTargetReached, 0);
  ASSERT_GT(
      axis.RunUntil([&] { return (static_cast<int>(axis.R("A516")) & sw::kTargetReached) != 0; }),
      0);
  EXPECT_EQ(axis.R("I80"), 300);
  EXPECT_EQ(axis.R("A545"), 300);
  // Relative (A515.6 = 1, A621.0-1 = 0/1) and additive (0/0) selections.
  axis.W("A621", 2);
  axis.W("A515", cw::kEnableOperationWord | cw::kRelative);
  EXPECT_EQ(axis.R("I401"), 2);
  axis.W("A621", 0);
  axis.W("A515", cw::kEnableOperationWord | cw::kRelative);
  EXPECT_EQ(axis.R("I401"), 3);
  axis.W("A541", 6);
  EXPECT_EQ(axis.R("I401"), 6);
  axis.W("A541", 9);
  EXPECT_EQ(axis.R("I401"), 7);
  axis.W("A541", 8);
  EXPECT_EQ(axis.R("I401"), 10);
  axis.W("A541", 10);
  EXPECT_EQ(axis.R("I401"), 9);
  axis.W("A541", 3);
  EXPECT_EQ(axis.R("I401"), 8);
}

TEST(StoberCia402, DisableOperationCancelsWithoutErrorAndEngagesBrake) {
  TestAxis axis;
  axis.MoveAbsolute(5000);
  axis.Advance(300);
  ASSERT_GT(std::abs(axis.R("I88")), 0);
  const double at = axis.R("I80");
  axis.W("A515", cw::kDisableOperationWord);
  axis.Advance();
  EXPECT_EQ(axis.core().power_state(), PowerState::kSwitchedOn);
  EXPECT_EQ(axis.R("I89"), 0);  // G-18
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I80"), at);  // held where it was (decision 1146)
  EXPECT_TRUE(axis.core().brake_engaged());
  axis.Advance(50);
  EXPECT_EQ(axis.R("I80"), at);
  EXPECT_EQ(axis.R("I92"), 0);
  axis.W("A515", cw::kEnableOperationWord);
  axis.Advance();
  EXPECT_EQ(axis.R("I89"), 2);
}

TEST(StoberCia402, QuickStopCommandRampsTheAxisDown) {
  TestAxis axis;
  axis.W("I404", 800);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(400);
  axis.W("A515", cw::kQuickStopWord);
  axis.Advance();
  EXPECT_EQ(axis.core().power_state(), PowerState::kQuickStopActive);
  EXPECT_GT(std::abs(axis.R("I88")), 0);  // ramping, not stepped
  const int cycles = axis.RunUntil(
      [&] { return axis.core().power_state() == PowerState::kSwitchOnDisabled; }, 2000);
  ASSERT_GT(cycles, 0);
  EXPECT_EQ(axis.R("I88"), 0);
  // 800 u/s at I11 = 10000 u/s², I16 = 1e5: at least 80 ms.
  EXPECT_GE(cycles, 80);
  EXPECT_EQ(axis.R("I91"), 0);
}

TEST(StoberCia402, InjectedFaultStopsAndFaultResetRecovers) {
  TestAxis axis;
  axis.W("I404", 500);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(200);
  axis.core().InjectFault();
  axis.Advance();
  EXPECT_EQ(axis.core().power_state(), PowerState::kFaultReactionActive);
  ASSERT_GT(axis.RunUntil([&] { return axis.core().power_state() == PowerState::kFault; }), 0);
  EXPECT_EQ(axis.R("I88"), 0);
  EXPECT_NE(static_cast<int>(axis.R("A516")) & sw::kFault, 0);
  axis.W("A515", cw::kFaultResetWord);
  axis.Advance();
  EXPECT_EQ(axis.core().power_state(), PowerState::kSwitchOnDisabled);
}

TEST(StoberCia402, FaultResetLeavesErrorStop) {
  TestAxis axis;
  axis.W("I404", 0);
  axis.MoveAbsolute(100);
  axis.Advance();
  ASSERT_EQ(axis.R("I89"), 7);
  axis.W("I404", 500);
  axis.MoveAbsolute(100);  // G-04: denied while in error stop
  axis.Advance();
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kErrorStopActive));
  EXPECT_EQ(axis.core().error_text().find("fault reset") != std::string::npos, true);
  axis.W("A515", cw::kEnableOperationWord | cw::kFaultReset);
  axis.Advance();
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I91"), 0);
  axis.W("A515", cw::kEnableOperationWord);
  axis.MoveAbsolute(100);
  EXPECT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 100);
}

TEST(StoberCia402, HaltBitHoldsAndResumesLikeOverrideZero) {
  TestAxis axis;  // G-19, decision 1159
  axis.W("A541", 1);
  axis.W("A567", 3000);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute);
  axis.Advance(500);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute | cw::kHalt);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000), 0);
  const double held = axis.R("I80");
  axis.Advance(200);
  EXPECT_EQ(axis.R("I80"), held);
  EXPECT_EQ(axis.R("I92"), 0);
  EXPECT_EQ(axis.R("I89"), 3);
  axis.W("A515", cw::kEnableOperationWord | cw::kExecute);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 3000);
}

TEST(StoberCia402, DisableOperationWithRampOption) {
  MotionCoreOptions options;
  options.enable_off_stops_immediately = false;
  TestAxis axis(testing::Fixture::kLin, options);
  axis.W("I404", 500);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(300);
  axis.W("A515", cw::kDisableOperationWord);
  axis.Advance();
  EXPECT_GT(axis.R("I88"), 0);  // ramping down
  EXPECT_LT(axis.R("I88"), 500);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I88") == 0; }, 1000), 0);
  axis.Advance();
  EXPECT_TRUE(axis.core().brake_engaged());
  EXPECT_EQ(axis.R("I89"), 0);
}

}  // namespace
}  // namespace drivegw::sim::stober
