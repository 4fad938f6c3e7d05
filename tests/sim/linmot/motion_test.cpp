// Motion through the MC interface: D-21 VAI timing (linmot-mc.md §6.1 cases A-E, LMC-13..20,
// 24, 25, 27, 43), infinite motion, event handler, runtime errors (lag, stroke; D-34).
#include <cmath>

#include "adapters/linmot/mc/error_codes.h"
#include "sim/linmot/parameters.h"
#include "tests/sim/linmot/device_fixture.h"

namespace drivegw::sim::linmot::testing {
namespace {

class MotionTest : public DeviceFixture {
 protected:
  void SetUp() override {
    DeviceFixture::SetUp();
    Ready();
  }
  // Runs until Motion Active drops; returns the elapsed simulated milliseconds.
  int RunToEnd(int limit_ms = 5000) {
    int t = 0;
    while (Sw().motion_active() && t < limit_ms) {
      Ms(1);
      ++t;
    }
    return t;
  }
};

TEST_F(MotionTest, VaiGoToPos_CaseA_TrapezoidTiming_Lmc13) {
  Mc(GoTo(200));
  EXPECT_TRUE(Sw().motion_active());
  double max_v = 0;
  double prev_v = 0;
  double max_acc = 0;
  double min_acc = 0;
  for (int t = 1; t <= 350; ++t) {
    Ms(1);
    const double v = DemandVelocity();
    max_v = std::max(max_v, std::abs(v));
    max_acc = std::max(max_acc, (v - prev_v) / 1e-3);
    min_acc = std::min(min_acc, (v - prev_v) / 1e-3);
    prev_v = v;
    if (t == 100) {
      EXPECT_NEAR(DemandMm(), 50.0, 1e-6);
    }
    if (t == 150) {
      EXPECT_NEAR(DemandMm(), 100.0, 1e-6);
    }
    if (t == 250) {
      EXPECT_NEAR(DemandMm(), 175.0, 1e-6);
      EXPECT_NEAR(DemandVelocity(), 500.0, 1e-6);
    }
    if (t == 348) {
      EXPECT_TRUE(Sw().motion_active());
    }
  }
  EXPECT_LE(max_v, 1000.0 + 1e-6);
  EXPECT_LE(max_acc, 10000.0 + 1e-3);
  EXPECT_GE(min_acc, -5000.0 - 1e-3);
  Ms(4);  // 0.35 s +- 2 ticks
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_EQ(dev_->demand_position(), 2'000'000);
  Ms(2);
  EXPECT_TRUE(Sw().in_target_position());
  EXPECT_EQ(dev_->actual_position(), 2'000'000);
}

TEST_F(MotionTest, VaiGoToPos_CaseB_Triangle) {
  Mc(GoTo(10, 1'000'000, 1'000'000, 1'000'000));
  Ms(32);
  EXPECT_NEAR(DemandVelocity(), 316.2, 5.0);  // peak at 31.6 ms
  const int rest = RunToEnd();
  EXPECT_NEAR(32 + rest, 63, 2);
  EXPECT_EQ(dev_->demand_position(), 100'000);
}

TEST_F(MotionTest, NewTargetWhileMoving_CaseC_Continuous_Lmc14) {
  Mc(GoTo(200));
  Ms(100);
  const double p0 = DemandMm();
  const double v0 = DemandVelocity();
  Mc(GoTo(60));
  Ms(1);
  // No jump: one tick later position and velocity moved by at most one tick's worth.
  EXPECT_NEAR(DemandMm(), p0 + v0 * 1e-3, 0.01);
  EXPECT_NEAR(DemandVelocity(), v0, 5000.0 * 1e-3 + 1e-6);
  Ms(199);  // t = 0.30 s: stopped at 150 mm
  EXPECT_NEAR(DemandMm(), 150.0, 0.01);
  const int rest = RunToEnd();
  EXPECT_NEAR(300 + rest, 532, 3);
  EXPECT_EQ(dev_->demand_position(), 600'000);
}

TEST_F(MotionTest, VaiStop_CaseD_StopsAt150_Lmc17) {
  Mc(GoTo(200));
  Ms(100);
  Mc(mc::VaiStop(500'000));
  Ms(100);
  EXPECT_NEAR(DemandVelocity(), 500.0, 1e-6);  // linear decrease
  Ms(102);
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_NEAR(DemandMm(), 150.0, 1.0);  // +- 1 tick of travel
}

TEST_F(MotionTest, IncrementDemandVsIncrementTarget_CaseE_Lmc15) {
  Mc(GoTo(100));
  Ms(80);
  const double p = DemandMm();
  Mc(mc::VaiIncrementDemPos(100'000, 1'000'000, 1'000'000, 500'000));
  RunToEnd();
  EXPECT_NEAR(DemandMm(), p + 10.0, 1e-3);

  Mc(GoTo(0));
  RunToEnd();
  Mc(GoTo(100));
  Ms(80);
  Mc(mc::VaiIncrementTargetPos(100'000, 1'000'000, 1'000'000, 500'000));
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 1'100'000);
}

TEST_F(MotionTest, IncrementActualZero_TargetIsActual_Lmc16) {
  Mc(GoTo(20.0003));
  RunToEnd();
  Ms(2);
  Mc(mc::VaiIncrementActPos(0, 1'000'000, 1'000'000, 1'000'000));
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 200'003);
}

TEST_F(MotionTest, PredefVai_EqualsExplicitLimits_QuickStopUses1721_Lmc18) {
  Mc(mc::WriteLiveParameter(upid::kPredefVelocity, 500'000));
  Mc(mc::WriteLiveParameter(upid::kPredefAcceleration, 1'000'000));
  Mc(mc::WriteLiveParameter(upid::kPredefDeceleration, 1'000'000));
  Mc(mc::PredefVaiGoToPos(500'000));
  const int predef_ms = RunToEnd();
  Mc(GoTo(0, 500'000, 1'000'000, 1'000'000));
  const int explicit_ms = RunToEnd();
  EXPECT_NEAR(predef_ms, explicit_ms, 1);
  EXPECT_EQ(dev_->demand_position(), 0);
  // 027: deceleration 1721h = 20 m/s².
  Mc(mc::WriteLiveParameter(upid::kQuickStopDeceleration, 2'000'000));
  Mc(GoTo(200));
  Ms(100);  // 1 m/s
  Mc(mc::PredefVaiStop());
  const int stop_ms = RunToEnd();
  EXPECT_NEAR(stop_ms, 50, 1);  // 1 m/s / 20 m/s²
}

TEST_F(MotionTest, AfterActualCommand_WaitsForRunningMotion_Lmc20) {
  Mc(GoTo(100));
  Ms(20);
  const linudp::Reply r = Mc(mc::VaiGoToPosAfterActualCommand(0, 1'000'000, 1'000'000, 500'000));
  EXPECT_TRUE(mc::StatusWord{*r.status_word}.event_handler_active());
  EXPECT_TRUE(mc::StateVar::FromRaw(*r.state_var).event_handler_active());
  double peak = 0;
  for (int i = 0; i < 1000 && DemandMm() > 0.0 - 1e-9; ++i) {
    Ms(1);
    peak = std::max(peak, DemandMm());
    if (!Sw().event_handler_active()) break;
  }
  EXPECT_NEAR(peak, 100.0, 1e-6);             // the first motion ended at 100 mm
  EXPECT_FALSE(Sw().event_handler_active());  // D-12: self-clearing
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 0);
}

TEST_F(MotionTest, ClearEvent_DisarmsAfterActual) {
  Mc(GoTo(100));
  Mc(mc::VaiGoToPosAfterActualCommand(0, 1'000'000, 1'000'000, 500'000));
  Mc(mc::ClearEventEvaluation());
  EXPECT_FALSE(Sw().event_handler_active());
  RunToEnd();
  Ms(10);
  EXPECT_EQ(dev_->demand_position(), 1'000'000);
}

TEST_F(MotionTest, Abort_QuickStopNoResumption_Lmc24) {
  Mc(GoTo(200));
  Ms(100);
  Cw(mc::kOperational & ~mc::kAbortN);
  EXPECT_EQ(Main(), 12);
  Ms(50);
  EXPECT_FALSE(Sw().motion_active());
  const double stopped = DemandMm();
  EXPECT_LT(stopped, 100.0);
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  Ms(200);
  EXPECT_DOUBLE_EQ(DemandMm(), stopped);
}

TEST_F(MotionTest, FreezeAndResume_CompletesMove_Lmc25) {
  Mc(GoTo(100));
  Ms(50);
  Cw(mc::kOperational & ~mc::kFreezeN);
  EXPECT_EQ(Main(), 13);
  Ms(100);
  EXPECT_FALSE(Sw().motion_active());
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  EXPECT_TRUE(Sw().motion_active());
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 1'000'000);
}

TEST_F(MotionTest, DisableOperationDuringMotion_StopsAtOnce_Lmc27) {
  Mc(GoTo(200));
  Ms(100);
  Cw(mc::kOperationDisabled);
  EXPECT_EQ(Main(), 6);
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_DOUBLE_EQ(DemandVelocity(), 0.0);
  Mc(GoTo(0));
  EXPECT_EQ(dev_->error_code(), mc::kMotionCommandInWrongState);
}

TEST_F(MotionTest, DecEqAcc_SameAsVaiWithEqualLimits_Lmc43) {
  Mc(mc::McCommand{0x0C, 0x0, {1'000'000, 1'000'000, 1'000'000}});
  const int a = RunToEnd();
  Mc(GoTo(0, 1'000'000, 1'000'000, 1'000'000));
  const int b = RunToEnd();
  EXPECT_NEAR(a, b, 1);
}

TEST_F(MotionTest, Vai16Bit_ScaledByParameters_D14) {
  // 1455h = 100 (10 um), 1456h = 1000 (1 mm/s), 1457h = 1000 (0.01 m/s²): 5 mm, 1 m/s, 10 m/s².
  Mc(mc::McCommand{0x09, 0x0, {500, 1000, 1000, 1000}});
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 50'000);
}

TEST_F(MotionTest, InfiniteMotion_RunsAtPredefSpeedUntilStop_02E) {
  Mc(mc::WriteLiveParameter(upid::kPredefVelocity, 100'000));  // 0.1 m/s
  Mc(mc::PredefVaiInfinitePositive());
  Ms(500);
  EXPECT_TRUE(Sw().motion_active());
  EXPECT_NEAR(DemandVelocity(), 100.0, 1e-6);
  Mc(mc::PredefVaiStop());
  RunToEnd();
  EXPECT_NEAR(DemandVelocity(), 0.0, 1e-9);
}

TEST_F(MotionTest, BeyondMaximalPosition_Error0008ViaQuickStop_D34) {
  Mc(mc::WriteLiveParameter(upid::kMaximalPosition, 1'500'000));  // 150 mm
  Mc(GoTo(200));
  bool saw_14 = false;
  for (int i = 0; i < 1000 && Main() != 4; ++i) {
    Ms(1);
    saw_14 = saw_14 || Main() == 14;
  }
  EXPECT_TRUE(saw_14);
  EXPECT_EQ(Main(), 4);
  EXPECT_EQ(dev_->error_code(), mc::kMaxPosOvershot);
  EXPECT_EQ(Sv().raw(), 0x0408);
  EXPECT_GT(DemandMm(), 150.0);
  EXPECT_LT(DemandMm(), 200.0);
}

TEST_F(MotionTest, BlockedMotor_PositionLagError000B) {
  Mc(GoTo(100));
  Ms(20);
  dev_->SetMotorBlocked(true);
  for (int i = 0; i < 500 && Main() == 8; ++i) Ms(1);
  EXPECT_EQ(dev_->error_code(), mc::kPosLagAlwaysTooBig);
  Ms(200);
  EXPECT_EQ(Main(), 4);
  EXPECT_EQ(dev_->current_ma(), 0);
}

TEST_F(MotionTest, CurrentFollowsAcceleration) {
  Mc(GoTo(200));
  Ms(10);
  // 0.5 kg x 10 m/s² / 20 N/A = 0.25 A.
  EXPECT_EQ(dev_->current_ma(), 250);
  Ms(100);
  EXPECT_EQ(dev_->current_ma(), 0);  // cruising
}

TEST_F(MotionTest, RisingTrigger_IncrementTargetRepeats_Lmc21_Lmc22) {
  Mc(mc::WriteLiveParameter(upid::kTriggerMode, 1));
  Mc(mc::McCommand{0x01, 0xB, {100'000, 1'000'000, 1'000'000, 1'000'000}});
  EXPECT_TRUE(Sw().event_handler_active());
  Ms(50);
  EXPECT_FALSE(Sw().motion_active());
  for (int i = 0; i < 3; ++i) {
    dev_->SetTriggerInput(true);
    dev_->SetTriggerInput(false);
    RunToEnd();
  }
  EXPECT_EQ(dev_->demand_position(), 300'000);
  Mc(mc::ClearEventEvaluation());
  EXPECT_FALSE(Sw().event_handler_active());
  dev_->SetTriggerInput(true);
  Ms(100);
  EXPECT_EQ(dev_->demand_position(), 300'000);
}

TEST_F(MotionTest, PositiveTransition_ChangesLimitsKeepsTarget_01E) {
  // At 20 mm the velocity limit drops from 0.5 m/s to 0.2 m/s.
  Mc(mc::McCommand{0x01, 0xE, {200'000, 200'000, 1'000'000, 1'000'000}});
  EXPECT_TRUE(Sw().event_handler_active());
  Mc(GoTo(100, 500'000, 1'000'000, 1'000'000));
  for (int i = 0; i < 2000 && DemandMm() < 70.0; ++i) Ms(1);
  EXPECT_NEAR(DemandVelocity(), 200.0, 1e-6);
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 1'000'000);
}

}  // namespace
}  // namespace drivegw::sim::linmot::testing
