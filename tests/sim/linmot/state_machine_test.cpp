// StateMachine alone: transitions of linmot-mc.md §2.3 with D-03..D-06, no motion attached.
#include "sim/linmot/state_machine.h"

#include <chrono>

#include "adapters/linmot/mc/control_word.h"
#include "gtest/gtest.h"

namespace drivegw::sim::linmot {
namespace {

using std::chrono::milliseconds;
constexpr SmInputs kStill{};

class StateMachineTest : public ::testing::Test {
 protected:
  StateMachine sm_{milliseconds(300)};
  void SetUp() override { sm_.PowerUp(); }
  void ToState6() {
    sm_.SetControlWord(mc::kAllOff, kStill);
    sm_.SetControlWord(mc::kSwitchedOff, kStill);
    sm_.SetControlWord(mc::kOperationDisabled, kStill);
    sm_.Tick(milliseconds(300), kStill);
    ASSERT_EQ(sm_.main_state(), 6);
  }
};

TEST_F(StateMachineTest, PowerUp_NoControlWordYet_StaysInZero) {
  EXPECT_EQ(sm_.main_state(), 0);
  sm_.Tick(milliseconds(100), kStill);
  EXPECT_EQ(sm_.main_state(), 0);
  EXPECT_TRUE(sm_.switch_on_locked());
}

TEST_F(StateMachineTest, SwitchedOffWord_CascadesZeroOneTwo) {
  // §2.7 step 1: 003Eh from state 0 releases the lock and reaches 2 at once.
  sm_.SetControlWord(mc::kSwitchedOff, kStill);
  EXPECT_EQ(sm_.main_state(), 2);
}

TEST_F(StateMachineTest, HwTests_TakeConfiguredTime_ThenReadyToOperate) {
  sm_.SetControlWord(mc::kSwitchedOff, kStill);
  const SmEffects fx = sm_.SetControlWord(mc::kOperationDisabled, kStill);
  EXPECT_EQ(sm_.main_state(), 5);
  EXPECT_FALSE(fx.power_on);  // state 5 runs before the power stage is on
  sm_.Tick(milliseconds(299), kStill);
  EXPECT_EQ(sm_.main_state(), 5);
  const SmEffects on = sm_.Tick(milliseconds(1), kStill);
  EXPECT_EQ(sm_.main_state(), 6);
  EXPECT_TRUE(on.power_on);
}

TEST_F(StateMachineTest, ClearingEnableOperation_InEight_StopsSetpoints) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  EXPECT_EQ(sm_.main_state(), 8);
  const SmEffects fx = sm_.SetControlWord(mc::kOperationDisabled, {.moving = true});
  EXPECT_EQ(sm_.main_state(), 6);  // T9
  EXPECT_TRUE(fx.stop_setpoints);
  EXPECT_FALSE(fx.power_off);
}

TEST_F(StateMachineTest, Off3WhileMoving_QuickStopsThenSwitchOnDisabled) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  const SmEffects fx =
      sm_.SetControlWord(mc::kOperational & ~mc::kQuickStopN, {.moving = true});  // D-05 OFF3
  EXPECT_TRUE(fx.quick_stop);
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_TRUE(sm_.off3_stopping());
  const SmEffects off = sm_.Tick(milliseconds(1), kStill);
  EXPECT_EQ(sm_.main_state(), 1);
  EXPECT_TRUE(off.power_off);
}

TEST_F(StateMachineTest, Off1_GoesToReadyToSwitchOn) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  const SmEffects fx = sm_.SetControlWord(mc::kOperational & ~mc::kSwitchOn, kStill);
  EXPECT_EQ(sm_.main_state(), 2);  // D-05 OFF1, no brake
  EXPECT_TRUE(fx.power_off);
}

TEST_F(StateMachineTest, ErrorWhileMoving_QuickStopThenError) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  const SmEffects fx = sm_.RaiseError(0x000B, false, /*quick_stop_first=*/true);
  EXPECT_EQ(sm_.main_state(), 14);
  EXPECT_TRUE(fx.quick_stop);
  EXPECT_EQ(fx.log_error, 0x000B);
  sm_.Tick(milliseconds(1), {.moving = true});
  EXPECT_EQ(sm_.main_state(), 14);
  sm_.Tick(milliseconds(1), kStill);
  EXPECT_EQ(sm_.main_state(), 4);
  EXPECT_EQ(sm_.sub_state(), 0x0B);
}

TEST_F(StateMachineTest, Acknowledge_RisingEdgeOnly_TargetPerD04) {
  ToState6();
  sm_.SetControlWord(mc::kAcknowledge, kStill);  // bit 7 held before the error
  sm_.RaiseError(0x0086, false, false);
  EXPECT_EQ(sm_.main_state(), 4);
  sm_.SetControlWord(mc::kAcknowledge, kStill);
  sm_.Tick(milliseconds(200), kStill);
  EXPECT_EQ(sm_.main_state(), 4);
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kAcknowledge, kStill);
  EXPECT_EQ(sm_.main_state(), 0);  // D-04: bit 0 = 1 -> Switch On Locked
  EXPECT_EQ(sm_.error_code(), 0);
}

TEST_F(StateMachineTest, Acknowledge_WithSwitchOnClear_GoesToOneThenTwo) {
  sm_.SetControlWord(mc::kSwitchedOff, kStill);
  sm_.RaiseError(0x0001, false, false);
  sm_.SetControlWord(mc::kSwitchedOff | mc::kErrorAcknowledge, kStill);
  EXPECT_EQ(sm_.main_state(), 2);  // 4 -> 1 -> 2 (bits 1, 2 set)
}

TEST_F(StateMachineTest, FatalError_IgnoresAcknowledge) {
  ToState6();
  sm_.RaiseError(0x000D, true, false);
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kAcknowledge, kStill);
  EXPECT_EQ(sm_.main_state(), 4);
  EXPECT_TRUE(sm_.fatal());
}

TEST_F(StateMachineTest, PtcError_AcknowledgeBlockedWhileWarnBitSet) {
  ToState6();
  sm_.RaiseError(0x0006, false, false);
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kAcknowledge, {.acknowledge_blocked = true});
  EXPECT_EQ(sm_.main_state(), 4);
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kAcknowledge, kStill);
  EXPECT_EQ(sm_.main_state(), 0);
}

TEST_F(StateMachineTest, SetupError_StateThreeUntilSwitchOn_ThenErrorLogged) {
  sm_.SetControlWord(mc::kSwitchedOff, kStill);
  sm_.RaiseSetupError(0x0063, false);
  EXPECT_EQ(sm_.main_state(), 3);
  EXPECT_EQ(sm_.sub_state(), 0x63);
  const SmEffects fx = sm_.SetControlWord(mc::kOperational, kStill);  // D-03
  EXPECT_EQ(sm_.main_state(), 4);
  EXPECT_EQ(fx.log_error, 0x0063);
}

TEST_F(StateMachineTest, Homing_ReleasedBeforeFinished_CancelsAndReturnsToEight) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  const SmEffects start = sm_.SetControlWord(mc::kHoming, kStill);
  EXPECT_EQ(sm_.main_state(), 9);
  EXPECT_TRUE(start.start_homing);
  const SmEffects fx = sm_.SetControlWord(mc::kOperational, {.moving = true});
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_TRUE(fx.cancel_homing);  // D-06
}

TEST_F(StateMachineTest, Homing_Finished_SubStateFAndWaitsForRelease) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kHoming, kStill);
  sm_.Tick(milliseconds(1), {.procedure_finished = true});
  EXPECT_EQ(sm_.main_state(), 9);
  EXPECT_EQ(sm_.sub_state(), 0x0F);
  const SmEffects fx = sm_.SetControlWord(mc::kOperational, kStill);
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_FALSE(fx.cancel_homing);
}

TEST_F(StateMachineTest, AbortAndFreeze_TransitionsAndEffects) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  SmEffects fx = sm_.SetControlWord(mc::kOperational & ~mc::kAbortN, {.moving = true});
  EXPECT_EQ(sm_.main_state(), 12);
  EXPECT_TRUE(fx.quick_stop && fx.clear_motion);
  fx = sm_.SetControlWord(mc::kOperational, kStill);
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_FALSE(fx.resume);
  fx = sm_.SetControlWord(mc::kOperational & ~mc::kFreezeN, {.moving = true});
  EXPECT_EQ(sm_.main_state(), 13);
  EXPECT_TRUE(fx.quick_stop && fx.freeze);
  fx = sm_.SetControlWord(mc::kOperational, kStill);
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_TRUE(fx.resume);
}

TEST_F(StateMachineTest, JogAndGoToPosition_LevelBitsAndSubStates_T17_T18) {
  ToState6();
  sm_.SetControlWord(mc::kOperational, kStill);
  SmEffects fx = sm_.SetControlWord(mc::kOperational | mc::kJogPlus, kStill);
  EXPECT_EQ(sm_.main_state(), 16);
  EXPECT_TRUE(fx.start_procedure);
  EXPECT_EQ(sm_.sub_state(), 0x01);  // moving
  sm_.Tick(milliseconds(1), {.procedure_finished = true});
  EXPECT_EQ(sm_.sub_state(), 0x0F);
  fx = sm_.SetControlWord(mc::kOperational, kStill);
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_FALSE(fx.cancel_procedure);
  sm_.SetControlWord(mc::kOperational | mc::kGoToPosition, kStill);
  EXPECT_EQ(sm_.main_state(), 15);
  fx = sm_.SetControlWord(mc::kOperational, {.moving = true});
  EXPECT_EQ(sm_.main_state(), 8);
  EXPECT_TRUE(fx.cancel_procedure);  // released before finished (D-06)
}

TEST_F(StateMachineTest, GoToInitialPosition_RisingEdgeOnly_T12) {
  ToState6();
  sm_.SetControlWord(mc::kOperational | mc::kGoToInitialPosition, kStill);  // held while 6 -> 8
  EXPECT_EQ(sm_.main_state(), 8);
  sm_.SetControlWord(mc::kOperational, kStill);
  sm_.SetControlWord(mc::kOperational | mc::kGoToInitialPosition, kStill);
  EXPECT_EQ(sm_.main_state(), 11);
}

}  // namespace
}  // namespace drivegw::sim::linmot
