// Pure CiA 402 / motion-core helpers: status word decoding, enable steps, state mapping and the
// §2.15 handle rules (forced-0 cycle, cyclic commands never DONE).
#include "adapters/stober/cia402_master.h"

#include <gtest/gtest.h>

namespace drivegw::stober {
namespace {

TEST(Cia402Master, DecodesEveryPowerState) {
  EXPECT_EQ(DecodePowerState(0x0000), PowerState::kNotReadyToSwitchOn);
  EXPECT_EQ(DecodePowerState(0x0240), PowerState::kSwitchOnDisabled);
  EXPECT_EQ(DecodePowerState(0x0221), PowerState::kReadyToSwitchOn);
  EXPECT_EQ(DecodePowerState(0x0233), PowerState::kSwitchedOn);
  EXPECT_EQ(DecodePowerState(0x0237), PowerState::kOperationEnabled);
  EXPECT_EQ(DecodePowerState(0x0217), PowerState::kQuickStopActive);
  EXPECT_EQ(DecodePowerState(0x021F), PowerState::kFaultReactionActive);
  EXPECT_EQ(DecodePowerState(0x0218), PowerState::kFault);
}

TEST(Cia402Master, EnableStepsFollowTheStateMachine) {
  EXPECT_EQ(NextEnableStep(PowerState::kSwitchOnDisabled), control::kShutdown);
  EXPECT_EQ(NextEnableStep(PowerState::kReadyToSwitchOn), control::kSwitchOn);
  EXPECT_EQ(NextEnableStep(PowerState::kSwitchedOn), control::kEnableOperation);
}

TEST(Cia402Master, MapsStateFromStatusWordAndI89) {
  MotionStatus s;
  s.status_word = 0x0237;
  s.plc_state = kPlcStandstill;
  EXPECT_EQ(MapState(s), DriveState::kEnabled);
  s.plc_state = kPlcDiscrete;
  EXPECT_EQ(MapState(s), DriveState::kMoving);
  s.plc_state = kPlcHoming;
  EXPECT_EQ(MapState(s), DriveState::kHoming);
  s.plc_state = kPlcErrorStop;
  EXPECT_EQ(MapState(s), DriveState::kFault);
  s.status_word = 0x0240;
  s.plc_state = 0;
  EXPECT_EQ(MapState(s), DriveState::kDisabled);
  s.status_word = 0x0218;
  EXPECT_EQ(MapState(s), DriveState::kFault);
  s.status_word = 0x0217;  // quick stop active: ramping, then at rest
  EXPECT_EQ(MapState(s), DriveState::kMoving);
  s.flags = status_bit::kStandstill;
  EXPECT_EQ(MapState(s), DriveState::kDisabled);
}

TEST(Cia402Master, DoneOnlyAfterTheForcedZeroCycle) {
  CommandProgress p;
  p.command = mc::kMoveAbsolute;
  MotionStatus s;
  s.status_word = 0x0237;
  s.plc_state = kPlcStandstill;
  s.flags = status_bit::kDone;  // the previous command's Done
  EXPECT_EQ(Evaluate(p, s), CommandState::kBusy);
  s.flags = 0;
  s.plc_state = kPlcDiscrete;
  EXPECT_EQ(Evaluate(p, s), CommandState::kActive);
  s.flags = status_bit::kDone;
  s.plc_state = kPlcStandstill;
  EXPECT_EQ(Evaluate(p, s), CommandState::kDone);
}

TEST(Cia402Master, ErrorAfterResetAndCyclicNeverDone) {
  CommandProgress p;
  p.command = mc::kMoveAbsolute;
  p.reset_seen = true;
  MotionStatus s;
  s.status_word = 0x0237;
  s.plc_state = kPlcErrorStop;
  s.cause = 1;
  s.flags = status_bit::kError;
  EXPECT_EQ(Evaluate(p, s), CommandState::kError);
  EXPECT_EQ(CauseText(1), "position outside software limits I50..I51");

  CommandProgress c;
  c.command = mc::kCyclicPosition;
  s.plc_state = kPlcCyclic;
  s.flags = 0;
  EXPECT_EQ(Evaluate(c, s), CommandState::kActive);
  s.flags = status_bit::kDone;
  EXPECT_EQ(Evaluate(c, s), CommandState::kActive);
}

}  // namespace
}  // namespace drivegw::stober
