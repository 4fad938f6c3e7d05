// Tests of the control word, status word, warn word and state var (linmot-mc.md §2, §3).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "adapters/linmot/mc/control_word.h"
#include "adapters/linmot/mc/state_var.h"
#include "adapters/linmot/mc/status_word.h"
#include "adapters/linmot/mc/warn_word.h"

namespace drivegw::linmot::mc {
namespace {

using ::testing::ElementsAre;
using ::testing::IsEmpty;

TEST(ControlWord, BitMasks_MatchSection31) {
  EXPECT_EQ(kSwitchOn, 0x0001);
  EXPECT_EQ(kVoltageEnable, 0x0002);
  EXPECT_EQ(kQuickStopN, 0x0004);
  EXPECT_EQ(kEnableOperation, 0x0008);
  EXPECT_EQ(kAbortN, 0x0010);
  EXPECT_EQ(kFreezeN, 0x0020);
  EXPECT_EQ(kGoToPosition, 0x0040);
  EXPECT_EQ(kErrorAcknowledge, 0x0080);
  EXPECT_EQ(kJogPlus, 0x0100);
  EXPECT_EQ(kJogMinus, 0x0200);
  EXPECT_EQ(kSpecialMode, 0x0400);
  EXPECT_EQ(kHome, 0x0800);
  EXPECT_EQ(kClearanceCheck, 0x1000);
  EXPECT_EQ(kGoToInitialPosition, 0x2000);
  EXPECT_EQ(kPhaseSearch, 0x8000);
}

TEST(ControlWord, RecommendedWords_MatchSection27) {
  EXPECT_EQ(kAllOff, 0x0000);
  EXPECT_EQ(kSwitchedOff, 0x003E);
  EXPECT_EQ(kOperational, 0x003F);
  EXPECT_EQ(kHoming, 0x083F);
  EXPECT_EQ(kAcknowledge, 0x00BF);
  EXPECT_EQ(kOperationDisabled, 0x0037);
}

TEST(StatusWord, EachAccessor_ReadsItsOwnBit) {
  using Getter = bool (StatusWord::*)() const;
  const Getter getters[16] = {
      &StatusWord::operation_enabled,    &StatusWord::switch_on_active,
      &StatusWord::enable_operation,     &StatusWord::error,
      &StatusWord::voltage_enable,       &StatusWord::quick_stop_n,
      &StatusWord::switch_on_locked,     &StatusWord::warning,
      &StatusWord::event_handler_active, &StatusWord::special_motion_active,
      &StatusWord::in_target_position,   &StatusWord::homed,
      &StatusWord::fatal_error,          &StatusWord::motion_active,
      &StatusWord::range_indicator_1,    &StatusWord::range_indicator_2,
  };
  for (int bit = 0; bit < 16; ++bit) {
    const StatusWord sw{static_cast<uint16_t>(1u << bit)};
    for (int g = 0; g < 16; ++g) {
      EXPECT_EQ((sw.*getters[g])(), g == bit) << "bit " << bit << " getter " << g;
    }
  }
}

TEST(StatusWord, With_SetsAndClearsMask) {
  StatusWord sw{};
  sw = sw.With(StatusWord::kHomed, true).With(StatusWord::kMotionActive, true);
  EXPECT_EQ(sw.raw, 0x2800);
  sw = sw.With(StatusWord::kHomed, false);
  EXPECT_EQ(sw.raw, 0x2000);
}

TEST(WarnWord, SetBitNames_NoneSet_Empty) { EXPECT_THAT(WarnWord{0}.SetBitNames(), IsEmpty()); }

TEST(WarnWord, SetBitNames_SeveralSet_LowestFirstInManualWords) {
  const WarnWord w{static_cast<uint16_t>(WarnWord::kMotorNotHomed | WarnWord::kMotorHotSensor |
                                         WarnWord::kRrHotCalculated)};
  EXPECT_TRUE(w.any());
  EXPECT_THAT(w.SetBitNames(),
              ElementsAre("Motor Hot Sensor", "Motor Not Homed", "RR Hot Calculated"));
}

TEST(WarnWord, WarnBitName_OutOfRange_Unknown) {
  EXPECT_STREQ(WarnBitName(16), "Unknown Warn Bit");
  EXPECT_STREQ(WarnBitName(-1), "Unknown Warn Bit");
  EXPECT_STREQ(WarnBitName(4), "Position Lag Always");
}

TEST(StateVar, FromRaw_Example0x0835_Section21) {
  // linmot-mc.md §2.1: 0x0835 = state 8, echo 5, Motion Active 1, In Target 0, Event Handler 1,
  // Homed 0.
  const StateVar sv = StateVar::FromRaw(0x0835);
  EXPECT_EQ(sv.main_state, 8);
  EXPECT_EQ(sv.sub_state, 0x35);
  EXPECT_TRUE(sv.operation_enabled());
  EXPECT_EQ(sv.state(), MainState::kOperationEnabled);
  EXPECT_EQ(sv.count_echo(), 5);
  EXPECT_TRUE(sv.motion_active());
  EXPECT_FALSE(sv.in_target_position());
  EXPECT_TRUE(sv.event_handler_active());
  EXPECT_FALSE(sv.homed());
  EXPECT_EQ(sv.raw(), 0x0835);
}

TEST(StateVar, OperationEnabled_BuildsSubStateFlags) {
  EXPECT_EQ(StateVar::OperationEnabled(5, true, true, false, false).raw(), 0x0835);
  EXPECT_EQ(StateVar::OperationEnabled(0x1F, false, false, true, true).raw(), 0x08CF);
}

TEST(StateVar, RawRoundTrip_AllValues_Identity) {
  for (uint32_t raw = 0; raw <= 0xFFFF; ++raw) {
    ASSERT_EQ(StateVar::FromRaw(static_cast<uint16_t>(raw)).raw(), raw);
  }
}

TEST(StateVar, ErrorState_SubStateIsErrorCode) {
  const StateVar sv = StateVar::FromRaw(0x0486);  // LMC-06
  EXPECT_EQ(sv.state(), MainState::kError);
  EXPECT_EQ(sv.sub_state, 0x86);
}

TEST(MainStateName, AllStates_Named) {
  EXPECT_STREQ(MainStateName(uint8_t{0}), "Not Ready To Switch On");
  EXPECT_STREQ(MainStateName(MainState::kOperationEnabled), "Operation Enabled");
  EXPECT_STREQ(MainStateName(MainState::kBrakeReleaseDelay), "Brake Release Delay");
  EXPECT_STREQ(MainStateName(MainState::kBrakeSetDelay), "Brake Set Delay");
  for (uint8_t s = 0; s < kMainStateCount; ++s) {
    EXPECT_STRNE(MainStateName(s), "Unknown State") << int(s);
  }
  EXPECT_STREQ(MainStateName(uint8_t{22}), "Unknown State");
  EXPECT_STREQ(MainStateName(uint8_t{255}), "Unknown State");
}

}  // namespace
}  // namespace drivegw::linmot::mc
