// LinMotDnDevice: the application behaviour of linmot-devicenet.md §12.5 and the §13.3-§13.6
// contract cases at image level, advanced by explicit ticks (no clock, no sockets).
#include "sim/linmot_devicenet/device.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>

#include "absl/strings/str_format.h"
#include "adapters/linmot/devicenet/commands.h"
#include "tests/sim/linmot_devicenet/test_util.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

using std::chrono::milliseconds;
using testing::Bytes;
using testing::Dotted;

class DeviceTest : public ::testing::Test {
 protected:
  void Make(const DnSimOptions& options) {
    auto d = LinMotDnDevice::Create(options);
    ASSERT_TRUE(d.ok()) << d.status();
    device_ = *std::move(d);
    device_->SetIoConnected(true);
  }
  // One poll: consumed bytes in, produced bytes out ("" when the drive does not answer).
  std::string Poll(std::string_view consumed) {
    const auto bytes = Bytes(consumed);
    if (device_->Consume(IoConnection::kPoll, bytes) == ConsumeOutcome::kResetController) {
      return "";
    }
    return Dotted(device_->Produce(IoConnection::kPoll));
  }
  // Addressed Out value word of the last poll (F1 layout: bytes 6-7).
  uint16_t Value(std::string_view consumed) {
    const auto out = Bytes(Poll(consumed));
    return static_cast<uint16_t>(out[6] | (out[7] << 8));
  }
  uint16_t CodedError() { return Value("00.00.0A.00.00.00"); }
  uint16_t SL() { return device_->status_low(); }
  uint16_t SH() { return device_->status_high(); }
  void Run(milliseconds t) { device_->Advance(t); }
  // RUN via a 0 -> 1 edge of the RUN request (seed lines 864, 910).
  void EnterRun() {
    Poll("00.00.00.00.00.00");
    Poll("02.00.00.00.00.00");
    ASSERT_TRUE(SL() & dn::StatusLowWord::kRunState);
  }
  const MotorSnapshot A() { return device_->Snapshot().motors[0]; }

  std::unique_ptr<LinMotDnDevice> device_;
};

TEST_F(DeviceTest, Create_BadOptions_InvalidArgumentNamingField) {
  DnSimOptions o = testing::F1Options();
  o.mac_id = 64;
  auto d = LinMotDnDevice::Create(o);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(d.status().message(), ::testing::HasSubstr("dn_sim_options.mac_id: 64"));
}

TEST_F(DeviceTest, PowerUp_NotInitialised_DisableStateAndNoRun) {
  DnSimOptions o = testing::F1Options();
  o.initialised = false;
  Make(o);
  EXPECT_EQ(device_->state(), ControllerState::kDisable);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kDisableState);
  Poll("02.00.00.00.00.00");
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState) << "RUN needs INIT Done (D-10)";
}

TEST_F(DeviceTest, InitRequest_MovesToInitPosition_InitDoneThenRunOnEdge) {
  DnSimOptions o = testing::F1Options();
  o.initialised = false;
  o.motors[0].initial_position_mm = 20;
  o.motors[0].init_position_mm = 0;
  Make(o);
  Poll("08.00.00.00.00.00");  // INIT request
  EXPECT_EQ(device_->state(), ControllerState::kInit);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kInitState);
  Run(milliseconds(2000));
  EXPECT_EQ(device_->state(), ControllerState::kStopped);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kInitDone);
  EXPECT_NEAR(A().actual_mm, 0, 1e-6);
  Poll("00.00.00.00.00.00");
  Poll("02.00.00.00.00.00");
  EXPECT_EQ(device_->state(), ControllerState::kRun);
}

// TC-12.
TEST_F(DeviceTest, GetStatusLowWord_Tc12) {
  Make(testing::F1Options());
  Poll("00.00.45.10.00.10");  // Pos Range Min A = 4096: outside the range, SH = 0
  Poll("00.00.00.00.00.00");
  EXPECT_EQ(Poll("02.00.02.00.00.00"), "03.10.00.00.02.00.03.10");
}

// TC-13.
TEST_F(DeviceTest, GetStatusHighWord_Tc13) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.95.10.00.00");  // a T-command: Command Toggle A := 1
  EXPECT_EQ(Poll("02.00.03.00.00.00"), "03.10.0A.00.03.00.0A.00");
}

// TC-14.
TEST_F(DeviceTest, GetControlWord_Tc14) {
  Make(testing::F1Options());
  EXPECT_THAT(Poll("02.00.04.00.00.00"), ::testing::EndsWith("04.00.02.00"));
}

// TC-15.
TEST_F(DeviceTest, SetControlWordWithoutControlIn_Tc15) {
  Make(testing::F1PrimeOptions());
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
  EXPECT_THAT(Poll("05.00.02.00"), ::testing::EndsWith("05.00.02.00"));
  EXPECT_TRUE(SL() & dn::StatusLowWord::kRunState);
}

// TC-16.
TEST_F(DeviceTest, RunAndStopRequests_Tc16) {
  Make(testing::F1Options());
  Poll("00.00.00.00.00.00");
  Poll("02.00.00.00.00.00");
  EXPECT_TRUE(SL() & dn::StatusLowWord::kRunState);
  Poll("04.00.00.00.00.00");
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
}

// TC-17 and TC-18.
TEST_F(DeviceTest, SetPositionSetpoint_MovesAndInPositionFollowsTheWindow_Tc17Tc18) {
  Make(testing::F1Options());
  EnterRun();
  EXPECT_THAT(Poll("02.00.11.10.00.14"), ::testing::EndsWith("11.10.00.14"));
  Run(milliseconds(10));
  EXPECT_TRUE(A().motion_active);
  EXPECT_FALSE(SL() & (dn::StatusLowWord::kInPositionA));
  Run(milliseconds(2000));
  EXPECT_NEAR(A().actual_mm, 100.0, 1e-6);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kInPositionA);
  EXPECT_THAT(Poll("02.00.10.10.00.00"), ::testing::EndsWith("10.10.00.14"));
  device_->SetDisturbance(Motor::kA, 5 / 51.2);  // 5125: inside 5110 ... 5130
  EXPECT_TRUE(SL() & dn::StatusLowWord::kInPositionA);
  device_->SetDisturbance(Motor::kA, 80 / 51.2);  // 5200
  EXPECT_FALSE(SL() & dn::StatusLowWord::kInPositionA);
}

// TC-19.
TEST_F(DeviceTest, GetActualPosition_Negative_Tc19) {
  DnSimOptions o = testing::F1Options();
  o.motors[0].initial_position_mm = -5;
  Make(o);
  EXPECT_THAT(Poll("02.00.18.10.00.00"), ::testing::EndsWith("18.10.00.FF"));
}

// TC-20.
TEST_F(DeviceTest, SetPositionSetpointWaitingForTrigger_MovesOnTriggerEdge_Tc20) {
  Make(testing::F1Options());
  EnterRun();
  EXPECT_THAT(Poll("02.00.12.10.00.14"), ::testing::EndsWith("12.10.00.14"));
  Run(milliseconds(200));
  EXPECT_NEAR(A().demand_mm, 0, 1e-9) << "armed, no motion";
  Poll("02.01.12.10.00.14");  // CW 0x0102: Trig In Motor A
  Run(milliseconds(2000));
  EXPECT_NEAR(A().actual_mm, 100.0, 1e-6);
  EXPECT_THAT(Poll("02.01.10.10.00.00"), ::testing::EndsWith("10.10.00.14"));
}

// TC-21.
TEST_F(DeviceTest, IncrementPositionSetpoint_OncePerToggle_Tc21) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.11.10.00.14");
  for (int i = 0; i < 5; ++i) Poll("02.00.93.10.00.01");
  EXPECT_EQ(A().setpoint, 5376);
  EXPECT_TRUE(A().command_toggle);
  EXPECT_EQ(device_->Snapshot().toggle_commands_ignored, 4u);
}

// TC-22 and TC-23.
TEST_F(DeviceTest, StartCurve_OncePerToggleChange_CurveDoneToggles_Tc22Tc23) {
  Make(testing::F1Options());
  EnterRun();
  const bool c = A().curve_done;
  for (int i = 0; i < 3; ++i) {
    EXPECT_THAT(Poll("02.00.A0.10.03.00"), ::testing::EndsWith("A0.10.03.00"));
    Run(milliseconds(1));
  }
  EXPECT_TRUE(SH() & dn::StatusHighWord::Bit(Motor::kA, dn::StatusHighWord::kCommandToggle));
  EXPECT_EQ(A().running_curve, 3);
  for (int i = 0; i < 30; ++i) {
    Poll("02.00.A0.10.03.00");
    Run(milliseconds(100));
  }
  EXPECT_EQ(A().curves_completed, 1u);
  EXPECT_EQ(A().curve_done, !c);
  EXPECT_NEAR(A().actual_mm, 50.0, 1e-6);  // curve 3 ends at 2560
  // TC-23: T unchanged -> nothing; T inverted -> runs again, toggle 0.
  Poll("02.00.A0.10.03.00");
  EXPECT_FALSE(A().running_curve.has_value());
  Poll("02.00.20.10.03.00");
  EXPECT_FALSE(SH() & dn::StatusHighWord::Bit(Motor::kA, dn::StatusHighWord::kCommandToggle));
  Run(milliseconds(10));
  EXPECT_EQ(A().curves_completed, 2u);
}

// TC-24.
TEST_F(DeviceTest, StartCurveIncremental_RelativeToDemand_Tc24) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.11.10.00.0A");  // 2560
  Run(milliseconds(2000));
  Poll("02.00.A2.10.04.00");
  EXPECT_TRUE(A().command_toggle);
  Run(milliseconds(2000));
  EXPECT_NEAR(A().demand_mm, (2560 + 512) / 51.2, 1e-6);
  EXPECT_EQ(A().curves_completed, 1u);
}

TEST_F(DeviceTest, StartCurveIncremental_StartPointNotZero_CurveTypeMismatch) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.A2.10.05.00");  // curve 5 starts at 512
  EXPECT_EQ(device_->coded_error(), dn::kCodedCurveTypeMismatch);
}

TEST_F(DeviceTest, StartCurve_WhileCurveRuns_CurveProcessing) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.A0.10.03.00");
  Run(milliseconds(10));
  Poll("02.00.20.10.03.00");
  EXPECT_EQ(device_->coded_error(), dn::kCodedCurveProcessing);
}

// TC-25.
TEST_F(DeviceTest, StartCurveWaitingForTrigger_RestartsOnEveryTrigger_Tc25) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.21.10.03.00");
  Run(milliseconds(100));
  EXPECT_FALSE(A().motion_active);
  Poll("02.01.21.10.03.00");
  EXPECT_EQ(A().running_curve, 3);
  Run(milliseconds(3000));
  EXPECT_EQ(A().curves_completed, 1u);
  const bool done = A().curve_done;
  Poll("02.00.21.10.03.00");
  Poll("02.01.21.10.03.00");
  Run(milliseconds(100));
  EXPECT_EQ(A().curves_completed, 2u);
  EXPECT_EQ(A().curve_done, !done);
}

// TC-26.
TEST_F(DeviceTest, MoveHomePosition_NoMotionToggleRule_Tc26) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.95.10.00.00");
  EXPECT_TRUE(A().command_toggle);
  Run(milliseconds(100));
  EXPECT_FALSE(A().motion_active);
  EXPECT_EQ(A().demand_velocity_mm_s, 0);
}

TEST_F(DeviceTest, MoveHomePosition_ShiftsTheZero) {
  DnSimOptions o = testing::F1Options();
  o.motors[0].initial_position_mm = 50;
  Make(o);
  EnterRun();
  Poll("02.00.95.10.00.0A");  // home := 2560 (50 mm): the slider now reads 0
  EXPECT_NEAR(A().actual_mm, 0, 1e-9);
  EXPECT_FALSE(A().motion_active);
}

// TC-27.
TEST_F(DeviceTest, SetActualPosition_NoMotionToggleRule_Tc27) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.95.10.00.00");  // toggle 1
  Poll("02.00.19.10.00.0A");  // T = 0: executes
  EXPECT_FALSE(A().command_toggle);
  Run(milliseconds(100));
  EXPECT_FALSE(A().motion_active);
  EXPECT_THAT(Poll("02.00.18.10.00.00"), ::testing::EndsWith("18.10.00.0A"));
}

// TC-28 (D-7: echo with value 0, ERROR state).
TEST_F(DeviceTest, MotionOutsideSerialMode_DriveNotSerial_Tc28) {
  DnSimOptions o = testing::F1Options();
  o.motors[0].run_mode = RunMode::kMasterEncoder;
  Make(o);
  EnterRun();
  EXPECT_THAT(Poll("02.00.11.10.00.14"), ::testing::EndsWith("11.10.00.00"));
  EXPECT_TRUE(SL() & dn::StatusLowWord::kErrorPending);
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
  EXPECT_THAT(Poll("02.00.08.00.00.00"), ::testing::EndsWith("08.00.80.00"));
  EXPECT_THAT(Poll("02.00.0A.00.00.00"), ::testing::EndsWith("0A.00.12.81"));
}

TEST_F(DeviceTest, SetSerialRunMode_EnablesMotionCommands) {
  DnSimOptions o = testing::F1Options();
  o.motors[0].run_mode = RunMode::kOther;
  Make(o);
  Poll("00.00.6E.10.00.00");
  EXPECT_EQ(A().run_mode, RunMode::kSerial);
  EnterRun();
  Poll("02.00.11.10.00.14");
  EXPECT_EQ(device_->coded_error(), 0);
}

// TC-29.
TEST_F(DeviceTest, StartUndefinedCurve_CurveMissing_Tc29) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.A0.10.0A.00");
  Run(milliseconds(10));
  EXPECT_FALSE(A().motion_active);
  EXPECT_EQ(CodedError(), 0x8130);
}

// TC-30 ... TC-33.
TEST_F(DeviceTest, CodedErrors_UnknownNoMotorNotMasterRange_Tc30To33) {
  Make(testing::F1Options());
  Poll("02.00.01.00.00.00");
  EXPECT_TRUE(SL() & dn::StatusLowWord::kErrorPending);
  EXPECT_THAT(Poll("02.00.0A.00.00.00"), ::testing::EndsWith("0A.00.08.81"));

  Make(testing::F1Options());
  Poll("02.00.18.00.00.00");
  EXPECT_EQ(CodedError(), 0x8110);

  DnSimOptions two = testing::F1Options();
  two.motor_count = 2;
  two.motors[1].master = false;
  Make(two);
  Poll("02.00.11.20.00.14");
  EXPECT_EQ(CodedError(), 0x8111);

  Make(testing::F1Options());
  Poll("02.00.4B.10.01.00");
  EXPECT_EQ(CodedError(), 0x8118);
  EXPECT_THAT(Poll("02.00.4A.10.00.00"), ::testing::EndsWith("4A.10.0A.00"));
}

TEST_F(DeviceTest, TwoMotorSelectBits_DriveNotSpecified_D6) {
  Make(testing::F1Options());
  Poll("00.00.18.30.00.00");
  EXPECT_EQ(device_->coded_error(), dn::kCodedDriveNotSpecified);
}

TEST_F(DeviceTest, SystemCommandWithMotorBits_DriveNotSpecified_D6) {
  Make(testing::F1Options());
  Poll("00.00.02.10.00.00");
  EXPECT_EQ(device_->coded_error(), dn::kCodedDriveNotSpecified);
}

TEST_F(DeviceTest, CodedError_OnlyTheFirstIsLatched_D23) {
  Make(testing::F1Options());
  Poll("00.00.01.00.00.00");
  Poll("00.00.18.00.00.00");
  EXPECT_EQ(CodedError(), 0x8108);
}

// TC-34.
TEST_F(DeviceTest, WarnState_SystemAndMotorWords_Tc34) {
  Make(testing::F1Options());
  device_->SetMotorWarningCause(Motor::kA, dn::kMotorTooHotCalc);
  EXPECT_THAT(Poll("02.00.06.00.00.00"), ::testing::EndsWith("06.00.00.10"));
  EXPECT_TRUE(SL() & dn::StatusLowWord::kWarningPending);
  EXPECT_THAT(Poll("02.00.06.10.00.00"), ::testing::EndsWith("06.10.01.00"));
  // 0x07 clears the latch; the persisting cause re-latches (D-23).
  device_->SetMotorWarningCause(Motor::kA, 0);
  Poll("02.00.07.00.00.00");
  EXPECT_FALSE(SL() & dn::StatusLowWord::kWarningPending);
}

// TC-35 and TC-36.
TEST_F(DeviceTest, ErrorState_FirstErrorLatched_Tc35Tc36) {
  Make(testing::F1Options());
  device_->SetMotorErrorCause(Motor::kA, dn::kMotorFollowingError);
  EXPECT_THAT(Poll("02.00.08.00.00.00"), ::testing::EndsWith("08.00.00.10"));
  EXPECT_TRUE(SH() & 0x0001);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kErrorPending);
  EXPECT_THAT(Poll("02.00.08.10.00.00"), ::testing::EndsWith("08.10.04.00"));
  device_->SetMotorErrorCause(Motor::kA, dn::kMotorFollowingError | dn::kMotorTooHotSensor);
  const uint16_t w = Value("02.00.08.10.00.00");
  EXPECT_TRUE(w & dn::kMotorFollowingError);
  EXPECT_FALSE(w & dn::kMotorTooHotSensor);
}

// TC-37.
TEST_F(DeviceTest, ResetErrorState_NeedsRunReEdge_Tc37) {
  Make(testing::F1Options());
  EnterRun();
  device_->SetMotorErrorCause(Motor::kA, dn::kMotorFollowingError);
  EXPECT_TRUE(SL() & dn::StatusLowWord::kErrorState);
  device_->SetMotorErrorCause(Motor::kA, 0);
  EXPECT_THAT(Poll("02.00.09.00.00.00"), ::testing::EndsWith("09.00.00.00"));
  EXPECT_FALSE(SL() & (dn::StatusLowWord::kErrorState | dn::StatusLowWord::kErrorPending));
  Poll("02.00.00.00.00.00");
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
  Poll("00.00.00.00.00.00");
  Poll("02.00.00.00.00.00");
  EXPECT_TRUE(SL() & dn::StatusLowWord::kRunState);
}

TEST_F(DeviceTest, ResetErrorState_OtherMotorSelected_KeepsLatch_D22) {
  DnSimOptions o = testing::F1Options();
  o.motor_count = 2;
  Make(o);
  device_->SetMotorErrorCause(Motor::kA, dn::kMotorTooHotCalc);
  device_->SetMotorErrorCause(Motor::kA, 0);
  Poll("00.00.09.20.00.00");  // motor B selected
  EXPECT_TRUE(SL() & dn::StatusLowWord::kErrorPending);
  Poll("00.00.09.10.00.00");  // motor A
  EXPECT_FALSE(SL() & dn::StatusLowWord::kErrorPending);
}

// TC-38.
TEST_F(DeviceTest, ResetCodedError_NeedsRunReEdge_Tc38) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.01.00.00.00");
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
  EXPECT_THAT(Poll("02.00.0B.00.00.00"), ::testing::EndsWith("0B.00.00.00"));
  EXPECT_EQ(Value("02.00.08.00.00.00") & dn::kSystemErrorCodedError, 0);
  EXPECT_FALSE(SL() & dn::StatusLowWord::kRunState);
  Poll("00.00.00.00.00.00");
  Poll("02.00.00.00.00.00");
  EXPECT_TRUE(SL() & dn::StatusLowWord::kRunState);
}

// TC-39.
TEST_F(DeviceTest, GetControllerIo_Tc39) {
  Make(testing::F1Options());
  device_->SetControllerInputs(0x0101);                            // Run request input, Dig In 5
  device_->SetMotorWarningCause(Motor::kA, dn::kMotorTooHotCalc);  // Warn out
  EXPECT_THAT(Poll("02.00.0C.00.00.00"), ::testing::EndsWith("0C.00.01.05"));
}

// TC-40.
TEST_F(DeviceTest, SetControllerIo_AnswersActualState_Tc40) {
  Make(testing::F1Options());
  EXPECT_THAT(Poll("02.00.0D.00.00.80"), ::testing::EndsWith("0D.00.00.80"));
  DnSimOptions o = testing::F1Options();
  o.sw_assigned_outputs = 0x9C00;  // Dig out 6 has a software function (off)
  Make(o);
  EXPECT_THAT(Poll("02.00.0D.00.00.80"), ::testing::EndsWith("0D.00.00.00"));
}

// TC-41 and TC-42.
TEST_F(DeviceTest, ExtendedIoAndEncoderModules_Tc41Tc42) {
  DnSimOptions o = testing::F1Options();
  o.digital_io_module = true;
  Make(o);
  device_->SetExtendedInputs(0x3C);
  EXPECT_THAT(Poll("02.00.65.00.00.A5"), ::testing::EndsWith("65.00.3C.A5"));
  EXPECT_THAT(Poll("02.00.64.00.00.00"), ::testing::EndsWith("64.00.3C.A5"));
  Poll("02.00.60.00.00.00");
  EXPECT_EQ(CodedError(), 0x8120) << "digital IO module is no encoder";
}

TEST_F(DeviceTest, EncoderInSsiMode_SetPosition_EncoderSsiMode) {
  DnSimOptions o = testing::F1Options();
  o.master_encoder_module = true;
  o.encoder_mode = EncoderMode::kSsi;
  Make(o);
  device_->SetEncoderCounts(1234);
  EXPECT_EQ(Value("00.00.60.00.00.00"), 1234);
  Poll("00.00.61.00.00.01");
  EXPECT_EQ(CodedError(), 0x8121);
}

// TC-43.
TEST_F(DeviceTest, DirectOutVariableSelection_Tc43) {
  Make(testing::F1Options());
  EXPECT_THAT(Poll("02.00.70.10.00.00"), ::testing::EndsWith("70.10.00.00"));
  EXPECT_THAT(Poll("02.00.71.10.04.00"), ::testing::EndsWith("71.10.04.00"));
  EXPECT_THAT(Poll("02.00.70.10.00.00"), ::testing::EndsWith("70.10.04.00"));
}

// TC-44 and TC-45 at image level (the stack reassembles the 10-byte image).
TEST_F(DeviceTest, Example2DirectSlots_Tc44Tc45) {
  Make(testing::F2Options());
  Poll("00.00.00.00.00.00.00.00.00.00");
  Poll("02.00.11.00.00.14.11.00.00.EC");
  Run(milliseconds(3000));
  const auto out = Bytes(Poll("02.00.11.00.00.14.11.00.00.EC"));
  ASSERT_EQ(out.size(), 8u);
  EXPECT_EQ(Dotted(std::span(out).subspan(4)), "00.14.00.EC");
  // TC-45: slot C selects Actual Speed for Direct Out 1: 0 at standstill, no echo.
  const auto speed = Bytes(Poll("02.00.11.00.00.14.71.00.04.00"));
  EXPECT_EQ(Dotted(std::span(speed).subspan(4)), "00.14.00.00");
  EXPECT_EQ(device_->Snapshot().motors[2].direct_out_1, 4);
}

TEST_F(DeviceTest, GetInDirectSlot_IgnoredAndCounted_D20) {
  Make(testing::F2Options());
  Poll("00.00.18.00.00.00.00.00.00.00");
  EXPECT_EQ(device_->Snapshot().direct_gets_ignored, 1u);
  EXPECT_EQ(device_->coded_error(), 0);
}

TEST_F(DeviceTest, Example1_ProducedImageInterleavesDirectOutPerMotor) {
  DnSimOptions o = testing::F3Options();
  for (size_t i = 0; i < 4; ++i) o.motors[i].initial_position_mm = 10.0 * static_cast<double>(i);
  Make(o);
  std::vector<uint8_t> consumed(22, 0);
  consumed[2] = 0x18;  // Get Actual Position, motor B
  consumed[3] = 0x20;
  ASSERT_EQ(device_->Consume(IoConnection::kPoll, consumed), ConsumeOutcome::kRespond);
  const auto out = device_->Produce(IoConnection::kPoll);
  ASSERT_EQ(out.size(), 24u);
  EXPECT_EQ(out[4], 0x18);  // echo
  EXPECT_EQ(out[5], 0x20);
  EXPECT_EQ(out[6] | (out[7] << 8), 512);  // B at 10 mm
  for (int m = 0; m < 4; ++m) {
    const int do1 = static_cast<int16_t>(out[8 + 4 * m] | (out[9 + 4 * m] << 8));
    const int do2 = static_cast<int16_t>(out[10 + 4 * m] | (out[11 + 4 * m] << 8));
    EXPECT_EQ(do1, 512 * m) << "Direct Out 1 (Actual Pos) of motor " << m;
    EXPECT_EQ(do2, 512 * m) << "Direct Out 2 (Demand Pos) of motor " << m;
  }
}

TEST_F(DeviceTest, ResetController_NoResponseAndPowerUp) {
  Make(testing::F1Options());
  EnterRun();
  EXPECT_EQ(Poll("02.00.0F.00.00.00"), "");
  EXPECT_EQ(device_->Snapshot().controller_resets, 1u);
  EXPECT_FALSE(device_->io_connected());
  EXPECT_NE(device_->state(), ControllerState::kRun);
}

TEST_F(DeviceTest, IoConnectionLost_ReleasesRun_D15) {
  Make(testing::F1Options());
  EnterRun();
  device_->SetIoConnected(false);
  EXPECT_EQ(device_->state(), ControllerState::kStopped);
  EXPECT_EQ(device_->control_word(), 0);
  EXPECT_EQ(device_->coded_error(), 0);
  Poll("02.00.00.00.00.00");
  EXPECT_NE(device_->state(), ControllerState::kRun) << "RUN needs an I/O connection";
}

TEST_F(DeviceTest, IoConnectionLost_KeepReaction_RunsOn) {
  DnSimOptions o = testing::F1Options();
  o.io_loss_reaction = IoLossReaction::kKeep;
  Make(o);
  EnterRun();
  device_->SetIoConnected(false);
  EXPECT_EQ(device_->state(), ControllerState::kRun);
}

TEST_F(DeviceTest, Freeze_HoldsAndResumesMotion) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.11.10.00.14");
  Run(milliseconds(50));
  Poll("12.00.11.10.00.14");  // FREEZE request
  Run(milliseconds(500));
  EXPECT_FALSE(A().motion_active);
  EXPECT_LT(A().actual_mm, 90);
  EXPECT_TRUE(A().frozen);
  Poll("02.00.11.10.00.14");
  Run(milliseconds(2000));
  EXPECT_NEAR(A().actual_mm, 100, 1e-6);
}

TEST_F(DeviceTest, BlockedMotor_FollowingErrorLatchedAndRunLeft) {
  Make(testing::F1Options());
  EnterRun();
  device_->SetMotorBlocked(Motor::kA, true);
  Poll("02.00.11.10.00.14");
  Run(milliseconds(500));
  EXPECT_TRUE(SH() & 0x0001);
  EXPECT_EQ(Value("02.00.08.10.00.00"), dn::kMotorFollowingError);
  EXPECT_EQ(device_->state(), ControllerState::kError);
}

TEST_F(DeviceTest, SetPointClampedToMaximalPosition) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.43.10.00.0A");  // Maximal Position 2560
  Poll("02.00.11.10.00.14");  // 5120 -> 2560
  EXPECT_EQ(A().setpoint, 2560);
}

TEST_F(DeviceTest, FilterMaxSpeed_LimitsTheMove) {
  Make(testing::F1Options());
  EnterRun();
  Poll("02.00.51.10.24.01");  // 0x124 = 292 x 0.190735 ≈ 55.7 mm/s
  Poll("02.00.11.10.00.14");
  Run(milliseconds(1000));
  EXPECT_LT(A().actual_mm, 60);
  EXPECT_NEAR(A().demand_velocity_mm_s, 292 * kMmSPerSpeedIncrement, 1e-6);
}

TEST_F(DeviceTest, ResponseLatency_AnswersOnePollLate_D5) {
  DnSimOptions o = testing::F1Options();
  o.response_latency_cycles = 1;
  Make(o);
  EXPECT_THAT(Poll("00.00.04.00.00.00"), ::testing::EndsWith("00.00.00.00"));
  EXPECT_THAT(Poll("00.00.0A.00.00.00"), ::testing::EndsWith("04.00.00.00"));
}

TEST_F(DeviceTest, CodedErrorsDecimal_ReportsDecimalReading_D2) {
  DnSimOptions o = testing::F1Options();
  o.coded_errors_decimal = true;
  Make(o);
  Poll("00.00.01.00.00.00");
  EXPECT_EQ(CodedError(), 8108);
}

TEST_F(DeviceTest, UndocumentedCommand_EchoedWithoutEffectOrError_D19) {
  Make(testing::F1Options());
  EXPECT_THAT(Poll("00.00.6D.10.07.00"), ::testing::EndsWith("6D.10.07.00"));
  EXPECT_EQ(device_->coded_error(), 0);
  DnSimOptions o = testing::F1Options();
  o.undocumented_commands_error = true;
  Make(o);
  Poll("00.00.6D.10.07.00");
  EXPECT_EQ(device_->coded_error(), dn::kCodedUnknownCommand);
}

TEST_F(DeviceTest, EdgeTriggeredXCommands_RepeatedSetIsNotReExecuted_D4Alternative) {
  DnSimOptions o = testing::F1Options();
  o.x_commands_edge_triggered = true;
  Make(o);
  EnterRun();
  Poll("02.00.11.10.00.14");
  Run(milliseconds(2000));
  // Moved away by a Direct-less override: Set Actual Position, then the same 0x11 frame again.
  Poll("02.00.95.10.00.00");
  Poll("02.00.11.10.00.14");
  const uint64_t executed = device_->Snapshot().commands_executed;
  Poll("02.00.11.10.00.14");
  EXPECT_EQ(device_->Snapshot().commands_executed, executed);
}

// The per-ID record the recovery tests read (decision 1451): executed commands counted under
// their §8.4 ID; a repeated X-command ignored by the edge rule (D-4 alternative) is not counted.
TEST_F(DeviceTest, ExecutedById_CountsEachExecutedCommandUnderItsId) {
  DnSimOptions o = testing::F1Options();
  o.x_commands_edge_triggered = true;
  Make(o);
  EnterRun();
  const auto before = device_->Snapshot().executed_by_id;
  Poll("02.00.11.10.00.14");
  Poll("02.00.11.10.00.14");  // same word: not executed again
  const auto after = device_->Snapshot().executed_by_id;
  EXPECT_EQ(after[0x11], before[0x11] + 1);
  EXPECT_EQ(after[0x19], before[0x19]);
}

TEST_F(DeviceTest, ParameterPairs_SetThenGetEveryMotorParameter) {
  Make(testing::F1Options());
  int checked = 0;
  for (const dn::CommandSpec& spec : dn::AllCommands()) {
    const dn::CommandSpec* get = dn::FindCommand(static_cast<uint8_t>(spec.id - 1));
    if (spec.kind != dn::CommandKind::kSet || get == nullptr ||
        !device_->Parameter(Motor::kA, get->id)) {
      continue;
    }
    if (spec.requirement != dn::Requirement::kNone) continue;
    const int32_t value = std::max(spec.request.min, std::min(spec.request.max, 7));
    const uint16_t raw = static_cast<uint16_t>(static_cast<int16_t>(value));
    const std::string set =
        absl::StrFormat("00.00.%02X.10.%02X.%02X", spec.id, raw & 0xFF, raw >> 8);
    Poll(set);
    EXPECT_EQ(device_->Parameter(Motor::kA, get->id), value) << spec.name;
    const std::string read = absl::StrFormat("00.00.%02X.10.00.00", get->id);
    EXPECT_EQ(static_cast<int16_t>(Value(read)), value) << get->name;
    ++checked;
  }
  EXPECT_EQ(checked, 27);
  EXPECT_EQ(device_->coded_error(), 0);
}

// Every documented command of the table executes (no internal error, no unexpected coded error)
// and is echoed.
TEST_F(DeviceTest, EveryCommand_ExecutesAndEchoes) {
  DnSimOptions o = testing::F1Options();
  o.master_encoder_module = true;
  o.digital_io_module = true;
  Make(o);
  EnterRun();
  for (const dn::CommandSpec& spec : dn::AllCommands()) {
    if (spec.id == Raw(dn::CommandId::kResetController) || !spec.documented) continue;
    const bool motor = spec.motor_select == dn::MotorSelect::kRequired;
    int32_t value = 0;
    if (spec.request.type == dn::ValueType::kInt16 || spec.request.type == dn::ValueType::kUInt16) {
      value = std::max(spec.request.min, std::min(spec.request.max, 3));
    }
    if (spec.id == Raw(dn::CommandId::kSetControlWord)) value = 0x0002;
    const uint16_t raw = static_cast<uint16_t>(static_cast<int16_t>(value));
    const uint16_t word = static_cast<uint16_t>((motor ? 0x1000 : 0) | spec.id |
                                                (spec.toggle && !A().command_toggle ? 0x80 : 0));
    const std::string consumed =
        absl::StrFormat("02.00.%02X.%02X.%02X.%02X", word & 0xFF, word >> 8, raw & 0xFF, raw >> 8);
    const auto out = Bytes(Poll(consumed));
    ASSERT_EQ(out.size(), 8u) << spec.name;
    EXPECT_EQ(out[4] | (out[5] << 8), word) << spec.name;
    EXPECT_EQ(device_->coded_error(), 0)
        << spec.name << " raised " << dn::CodedErrorText(device_->coded_error());
    Run(milliseconds(3000));  // let curves and moves end
    if (spec.id == Raw(dn::CommandId::kSetMasterEncoderRunMode))
      device_->SetRunMode(Motor::kA, RunMode::kSerial);
  }
}

}  // namespace
}  // namespace drivegw::sim::linmot_devicenet
