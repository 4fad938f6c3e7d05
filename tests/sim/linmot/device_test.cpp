// LinMotDevice: state machine sequences (linmot-mc.md §2.7, LMC-01..09), count rule and echo
// (LMC-10, 11), errors (D-34, D-36), homing (D-39), warnings (D-41), Reset (LMC-35).
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/warn_word.h"
#include "sim/linmot/parameters.h"
#include "tests/sim/linmot/device_fixture.h"

namespace drivegw::sim::linmot::testing {
namespace {

using DeviceTest = DeviceFixture;

TEST_F(DeviceTest, Create_BadOptions_NamesField) {
  SimOptions o = TestOptions();
  o.tick = std::chrono::microseconds(100);
  auto d = LinMotDevice::Create(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("tick"), std::string::npos) << d.status();
}

TEST_F(DeviceTest, PowerUpWithSwitchOnHeld_StaysLocked_Lmc01) {
  Cw(mc::kOperational);
  Ms(100);
  EXPECT_EQ(Main(), 0);
  EXPECT_TRUE(Sw().switch_on_locked());
  EXPECT_FALSE(Sw().operation_enabled());
  Cw(mc::kSwitchedOff);
  EXPECT_TRUE(Main() == 1 || Main() == 2);
  EXPECT_FALSE(Sw().switch_on_locked());
}

TEST_F(DeviceTest, StateOneWaitsForBitsOneAndTwo_Lmc02) {
  Cw(mc::kAllOff);
  EXPECT_EQ(Sv().raw(), 0x0100);
  Cw(0x003A);
  Ms(100);
  EXPECT_EQ(Sv().raw(), 0x0100);
  Cw(0x003C);
  Ms(100);
  EXPECT_EQ(Sv().raw(), 0x0100);
  Cw(0x003E);
  EXPECT_EQ(Sv().raw(), 0x0200);
}

TEST_F(DeviceTest, SwitchOnPassesHwTests_Lmc03) {
  Cw(mc::kSwitchedOff);
  Cw(mc::kOperationDisabled);
  EXPECT_EQ(Main(), 5);
  EXPECT_FALSE(Sw().operation_enabled());
  Ms(299);
  EXPECT_EQ(Main(), 5);
  Ms(1);
  EXPECT_EQ(Main(), 6);
  EXPECT_FALSE(Sw().operation_enabled());
}

TEST_F(DeviceTest, EnableOperation_Lmc04_AndMirrors_Lmc05) {
  SwitchOn();
  EXPECT_TRUE(Sw().operation_enabled());
  EXPECT_TRUE(Sw().enable_operation());
  // LMC-05: SW 1, 2, 4, 5 = CW 0, 3, 1, 2, in any state.
  for (uint16_t cw : {uint16_t{0x0000}, uint16_t{0x0001}, uint16_t{0x0002}, uint16_t{0x0004},
                      uint16_t{0x0008}, uint16_t{0x003F}}) {
    Cw(cw);
    const mc::StatusWord sw = Sw();
    EXPECT_EQ(sw.switch_on_active(), (cw & mc::kSwitchOn) != 0) << cw;
    EXPECT_EQ(sw.enable_operation(), (cw & mc::kEnableOperation) != 0) << cw;
    EXPECT_EQ(sw.voltage_enable(), (cw & mc::kVoltageEnable) != 0) << cw;
    EXPECT_EQ(sw.quick_stop_n(), (cw & mc::kQuickStopN) != 0) << cw;
  }
}

TEST_F(DeviceTest, MotionCommandInStateSix_Raises0086_Lmc06) {
  Cw(mc::kSwitchedOff);
  Cw(mc::kOperationDisabled);
  Ms(300);
  ASSERT_EQ(Main(), 6);
  const double before = DemandMm();
  const linudp::Reply r = Mc(GoTo(10));
  EXPECT_EQ(r.state_var, 0x0486);
  EXPECT_TRUE(mc::StatusWord{*r.status_word}.error());
  EXPECT_EQ(r.error_code, mc::kMotionCommandInWrongState);
  Ms(50);
  EXPECT_DOUBLE_EQ(DemandMm(), before);
  ASSERT_EQ(dev_->error_log().logged(), 1u);
  EXPECT_EQ(dev_->error_log().Entry(0)->code, 0x0086);
}

TEST_F(DeviceTest, NoOperationInStateSix_IsHarmless_Lmc07) {
  Cw(mc::kSwitchedOff);
  Cw(mc::kOperationDisabled);
  Ms(300);
  Mc(mc::NoOperation());
  EXPECT_EQ(Main(), 6);
  EXPECT_FALSE(Sw().error());
}

TEST_F(DeviceTest, CommandsInStatesZeroToFive_IgnoredButCountStored_D36) {
  Cw(mc::kAllOff);  // state 1
  Mc(GoTo(10));
  EXPECT_EQ(Main(), 1);
  EXPECT_FALSE(Sw().error());
  EXPECT_EQ(dev_->Snapshot().mc_count, 1);
  // Switching on later must not execute the stored command (same count).
  SwitchOn();
  McRaw(GoTo(10), 1);
  Ms(100);
  EXPECT_NEAR(DemandMm(), 10.0, 1e-9);  // initial position, not moved
  EXPECT_FALSE(Sw().motion_active());
}

TEST_F(DeviceTest, ErrorAcknowledgeNeedsRisingEdge_Lmc08) {
  SwitchOn();
  Cw(mc::kAcknowledge);  // bit 7 held since before the error
  ASSERT_TRUE(dev_->RaiseError(mc::kPwrVoltageTooLow).ok());
  EXPECT_EQ(Main(), 4);
  Ms(200);
  Cw(mc::kAcknowledge);
  EXPECT_EQ(Main(), 4);
  Cw(mc::kOperational);
  const linudp::Reply r = Cw(mc::kAcknowledge);
  EXPECT_NE(Main(), 4);
  EXPECT_FALSE(mc::StatusWord{*r.status_word}.error());
  EXPECT_EQ(r.error_code, 0);
  // D-04: bit 0 was 1 -> state 0 with Switch On Locked; §2.7 step 1 again.
  EXPECT_EQ(Main(), 0);
  EXPECT_TRUE(Sw().switch_on_locked());
  Cw(mc::kSwitchedOff);
  Cw(mc::kOperational);
  Ms(300);
  EXPECT_EQ(Main(), 8);
}

TEST_F(DeviceTest, FatalErrorCannotBeAcknowledged_ResetRecovers_Lmc09) {
  SwitchOn();
  ASSERT_TRUE(dev_->RaiseError(mc::kPwrOverCurrent).ok());
  EXPECT_EQ(Main(), 4);
  EXPECT_TRUE(Sw().fatal_error());
  Cw(mc::kOperational);
  Cw(mc::kAcknowledge);
  EXPECT_EQ(Main(), 4);
  EXPECT_TRUE(Sw().fatal_error());
  // §2.6: a fatal error is left by Reset (00F0h after a count != 0).
  McRaw(mc::NoOperation(), 1);
  EXPECT_FALSE(McRaw(mc::Reset(), 0).has_value());  // rebooting: silent
  EXPECT_TRUE(dev_->booting());
  Ms(100);
  EXPECT_FALSE(dev_->booting());
  EXPECT_EQ(Main(), 0);
  EXPECT_FALSE(Sw().error());
  EXPECT_EQ(dev_->Snapshot().boots, 1u);
}

TEST_F(DeviceTest, RaiseError_UnknownCode_Rejected_D33) {
  EXPECT_TRUE(absl::IsInvalidArgument(dev_->RaiseError(0x00FF)));
  EXPECT_TRUE(absl::IsInvalidArgument(dev_->RaiseError(0)));
}

TEST_F(DeviceTest, CountRule_SameCountDoesNothing_Lmc10) {
  Ready();
  McRaw(GoTo(10), 1);
  Ms(500);
  EXPECT_NEAR(DemandMm(), 10.0, 1e-9);
  EXPECT_EQ(Sv().count_echo(), 1);
  McRaw(GoTo(20), 1);  // same count, new parameters
  Ms(500);
  EXPECT_NEAR(DemandMm(), 10.0, 1e-9);
  McRaw(GoTo(20), 2);
  Ms(500);
  EXPECT_NEAR(DemandMm(), 20.0, 1e-9);
  EXPECT_EQ(Sv().count_echo(), 2);
}

TEST_F(DeviceTest, CountEchoAndFlagsInStateVar_Lmc11_Lmc12) {
  Ready();
  const linudp::Reply r = *McRaw(mc::VaiGoToPos(1'000'000, 500'000, 200'000, 200'000), 3);
  const auto sv = mc::StateVar::FromRaw(*r.state_var);
  const auto sw = mc::StatusWord{*r.status_word};
  EXPECT_EQ(sv.main_state, 8);
  EXPECT_EQ(sv.count_echo(), 3);
  EXPECT_TRUE(sv.motion_active());
  // Same telegram: SV bits 5, 6, 7 = SW bits 13, 10, 11.
  for (int i = 0; i < 60; ++i) {
    const linudp::Reply p = Poll();
    const auto v = mc::StateVar::FromRaw(*p.state_var);
    const auto w = mc::StatusWord{*p.status_word};
    ASSERT_EQ(v.motion_active(), w.motion_active());
    ASSERT_EQ(v.in_target_position(), w.in_target_position());
    ASSERT_EQ(v.homed(), w.homed());
    ASSERT_EQ(v.event_handler_active(), w.event_handler_active());
    Ms(50);
  }
  EXPECT_TRUE(sw.homed());
  // LMC-12: motion done, in target, demand exact.
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_TRUE(Sw().in_target_position());
  EXPECT_TRUE(Sv().in_target_position());
  EXPECT_EQ(dev_->demand_position(), 1'000'000);
}

TEST_F(DeviceTest, UnknownCommand_Raises0081_Lmc42) {
  Ready();
  linudp::Request r;
  r.response_definition = linudp::kRespStandard;
  r.motion_command = mc::McBlock{};
  (*r.motion_command)[0] = 0x01;  // header 0x1301: master 13h, sub 0, count 1
  (*r.motion_command)[1] = 0x13;
  const linudp::Reply rep = Send(r);
  EXPECT_EQ(rep.error_code, mc::kUnknownMotionCommand);
  EXPECT_EQ(Main(), 4);
}

TEST_F(DeviceTest, CommandNotOnProduct_Raises0081_D20) {
  Ready();  // C1250: 0B0 (VAI Predef Acc) is E1200/E1400 only
  mc::McCommand c{0x0B, 0x0, {100000, 100000}};
  Mc(c);
  EXPECT_EQ(dev_->error_code(), mc::kUnknownMotionCommand);
}

TEST_F(DeviceTest, UnsupportedKnownCommand_EchoedNoError_D28) {
  Ready();
  mc::McCommand stream{0x03, 0x0, {0}};  // P stream: not simulated (time curves are, 606)
  const linudp::Reply r = Mc(stream);
  EXPECT_EQ(mc::StateVar::FromRaw(*r.state_var).count_echo(), mc_count_);
  EXPECT_EQ(Main(), 8);
}

TEST_F(DeviceTest, Homing_MovesToHomeSetsHomedAndSubStateF_D39) {
  SwitchOn();
  EXPECT_FALSE(Sw().homed());
  EXPECT_TRUE(dev_->warn_word() & mc::WarnWord::kMotorNotHomed);  // D-41
  EXPECT_TRUE(Sw().warning());
  Cw(mc::kHoming);
  EXPECT_EQ(Main(), 9);
  EXPECT_TRUE(Sw().special_motion_active());  // D-40
  Ms(50);
  EXPECT_EQ(Sv().sub_state, 0);
  EXPECT_LT(DemandMm(), 10.0);
  Ms(1000);
  EXPECT_EQ(Sv().raw(), 0x090F);
  EXPECT_TRUE(Sw().homed());
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  EXPECT_NEAR(dev_->Snapshot().actual_position_mm, 0.0, 1e-6);
  EXPECT_FALSE(dev_->warn_word() & mc::WarnWord::kMotorNotHomed);
}

TEST_F(DeviceTest, Homing_ReleasedEarly_StopsNotHomed_D06) {
  SwitchOn();
  Cw(mc::kHoming);
  Ms(30);
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  EXPECT_FALSE(Sw().homed());
  Ms(200);
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_GT(DemandMm(), 0.5);  // stopped on the way
}

TEST_F(DeviceTest, MasterHoming_HomesWithoutLeavingEight_Lmc34) {
  SwitchOn();
  const linudp::Reply r = Mc(mc::MasterHoming(500'000));
  EXPECT_TRUE(mc::StatusWord{*r.status_word}.homed());
  EXPECT_EQ(Main(), 8);
  EXPECT_EQ(dev_->parameters().Get(upid::kHomePosition), 500'000);
  EXPECT_EQ(dev_->actual_position(), 500'000);
}

TEST_F(DeviceTest, SelectPositionControllerSet_Lmc44) {
  Ready();
  Mc(mc::McCommand{0x00, 0x5, {1}});
  EXPECT_EQ(dev_->parameters().Get(upid::kActivePositionControllerSet), 1);
}

TEST_F(DeviceTest, LiveParameterBool_UsesBitZero_Lmc19) {
  Ready();
  Mc(mc::WriteLiveParameter(upid::kMotorRequiresHoming, static_cast<int32_t>(0xFFFFFFFE)));
  EXPECT_EQ(dev_->parameters().Get(upid::kMotorRequiresHoming), 0);
  Mc(mc::WriteLiveParameter(upid::kMotorRequiresHoming, 1));
  EXPECT_EQ(dev_->parameters().Get(upid::kMotorRequiresHoming), 1);
}

TEST_F(DeviceTest, WriteInterfaceControlWord_DrivesStateMachine_001) {
  Ready();
  Mc(mc::WriteInterfaceControlWord(mc::kOperationDisabled));
  EXPECT_EQ(Main(), 6);
}

TEST_F(DeviceTest, ResetWithCountZero_RebootsOnce_Lmc35) {
  Ready();
  McRaw(mc::NoOperation(), 1);
  EXPECT_FALSE(McRaw(mc::Reset(), 0).has_value());
  Ms(100);
  // The interface still holds 00F0h: same count as after boot, the drive stays up.
  ASSERT_TRUE(McRaw(mc::Reset(), 0).has_value());
  Ms(200);
  ASSERT_TRUE(McRaw(mc::Reset(), 0).has_value());
  EXPECT_EQ(Main(), 0);
  EXPECT_EQ(dev_->Snapshot().boots, 1u);
  EXPECT_FALSE(Sw().homed());  // D-39: not homed after power-up
}

TEST_F(DeviceTest, ResetWithNonZeroCount_RebootLoop_Lmc35) {
  Ready();
  EXPECT_FALSE(McRaw(mc::Reset(), 2).has_value());
  for (int boot = 1; boot <= 3; ++boot) {
    Ms(100);
    EXPECT_FALSE(dev_->booting());
    EXPECT_FALSE(McRaw(mc::Reset(), 2).has_value()) << "boot " << boot;  // reboots again
  }
  EXPECT_EQ(dev_->Snapshot().boots, 3u);
}

TEST_F(DeviceTest, InjectedWarning_SetsWarnAndStatusBit7_Lmc36) {
  Ready();
  EXPECT_FALSE(Sw().warning());
  dev_->SetInjectedWarnings(mc::WarnWord::kMotorSupplyVoltageLow);
  const linudp::Reply r = Poll();
  EXPECT_EQ(*r.warn_word, mc::WarnWord::kMotorSupplyVoltageLow);
  EXPECT_TRUE(mc::StatusWord{*r.status_word}.warning());
  dev_->SetInjectedWarnings(0);
  EXPECT_FALSE(Sw().warning());
}

TEST_F(DeviceTest, PtcError_AcknowledgeWaitsForWarnBit_Lmc39) {
  Ready();
  dev_->SetInjectedWarnings(mc::WarnWord::kPtcSensor1Hot);
  ASSERT_TRUE(dev_->RaiseError(mc::kPtc1SensorTooHot).ok());
  Cw(mc::kOperational);
  Cw(mc::kAcknowledge);
  EXPECT_EQ(Main(), 4);
  dev_->SetInjectedWarnings(0);
  Cw(mc::kOperational);
  Cw(mc::kAcknowledge);
  EXPECT_EQ(Main(), 0);
}

TEST_F(DeviceTest, SetupErrorWhileSwitchedOff_StateThreeThenFour_D03) {
  Cw(mc::kSwitchedOff);
  ASSERT_TRUE(dev_->RaiseError(0x0063).ok());  // Cfg Err: Pos Ctrl Max Curr High
  EXPECT_EQ(Sv().raw(), 0x0363);
  EXPECT_TRUE(Sw().error());
  EXPECT_EQ(dev_->error_log().logged(), 0u);
  Cw(mc::kOperational);
  EXPECT_EQ(Sv().raw(), 0x0463);
  EXPECT_EQ(dev_->error_log().logged(), 1u);
}

TEST_F(DeviceTest, Off2_PowersOffAtOnce_D05) {
  Ready();
  Mc(GoTo(100));
  Ms(50);
  Cw(mc::kOperational & ~mc::kVoltageEnable);
  EXPECT_EQ(Main(), 1);
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_EQ(dev_->current_ma(), 0);
}

TEST_F(DeviceTest, Off3_QuickStopThenSwitchOnDisabled_D05) {
  Ready();
  Mc(GoTo(100));
  Ms(100);  // 1 m/s
  Cw(mc::kOperational & ~mc::kQuickStopN);
  EXPECT_EQ(Main(), 8);
  EXPECT_TRUE(Sw().motion_active());
  Ms(100);  // 1 m/s at 50 m/s² stops in 20 ms
  EXPECT_EQ(Main(), 1);
}

TEST_F(DeviceTest, MotionCommandInHoming_Raises0086_D36) {
  SwitchOn();
  Cw(mc::kHoming);
  Mc(GoTo(5));
  EXPECT_EQ(dev_->error_code(), mc::kMotionCommandInWrongState);
}

TEST_F(DeviceTest, JogPlus_MovesTowardsMaximalPositionUntilReleased_T18) {
  Ready();
  Cw(mc::kOperational | mc::kJogPlus);
  EXPECT_EQ(Sv().raw(), 0x1001);
  EXPECT_TRUE(Sw().special_motion_active());
  Ms(1000);  // 50 mm/s default jog speed (F008h), homing acceleration F002h
  EXPECT_NEAR(DemandMm(), 48.75, 1e-3);  // 50 ms ramp at 1000 mm/s² loses 1.25 mm
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  Ms(100);
  EXPECT_FALSE(Sw().motion_active());
}

TEST_F(DeviceTest, GoToPosition_FinishesAndWaitsForRelease_T17) {
  Ready();
  Cw(mc::kOperational | mc::kGoToPosition);
  EXPECT_EQ(Main(), 15);
  Ms(3000);  // to the stroke middle, 150 mm (F006h default), with the homing limits
  EXPECT_EQ(Sv().raw(), 0x0F0F);
  EXPECT_EQ(dev_->demand_position(), 1'500'000);
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
}

}  // namespace
}  // namespace drivegw::sim::linmot::testing
