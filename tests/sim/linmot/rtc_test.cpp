// RTC parameter channel through LinMotDevice::Handle: linmot-linudp.md §5 with,
// and the RAM/ROM rule D-31; error log commands 0x70-0x74.
#include "adapters/linmot/mc/error_codes.h"
#include "sim/linmot/parameters.h"
#include "tests/sim/linmot/device_fixture.h"

namespace drivegw::sim::linmot::testing {
namespace {

using linudp::RtcCommand;

class RtcTest : public DeviceFixture {
 protected:
  std::optional<linudp::Reply> RtcRaw(uint8_t count, RtcCommand id, uint16_t w2, uint32_t value = 0,
                                      uint32_t response = linudp::kRespRtc) {
    linudp::Request r;
    r.response_definition = response;
    r.rtc = linudp::RtcRequest{count, static_cast<uint8_t>(id), w2,
                               static_cast<uint16_t>(value & 0xFFFF),
                               static_cast<uint16_t>(value >> 16)};
    return dev_->Handle(r);
  }
  // A new RTC command with the next count 1..15.
  linudp::RtcReply Rtc(RtcCommand id, uint16_t w2 = 0, uint32_t value = 0) {
    count_ = static_cast<uint8_t>(count_ % 15 + 1);
    auto reply = RtcRaw(count_, id, w2, value);
    EXPECT_TRUE(reply.has_value() && reply->rtc.has_value());
    const linudp::RtcReply rtc = reply && reply->rtc ? *reply->rtc : linudp::RtcReply{};
    EXPECT_EQ(rtc.count, count_);
    return rtc;
  }
  static int32_t Value(const linudp::RtcReply& r) {
    return static_cast<int32_t>(uint32_t{r.word3} | (uint32_t{r.word4} << 16));
  }
  uint8_t count_ = 0;
};

TEST_F(RtcTest, ReadRam_KnownUpid_ReturnsValueAndEchoesUpid) {
  const auto r = Rtc(RtcCommand::kReadRamValueByUpid, upid::kMaximalPosition);
  EXPECT_EQ(r.status, linudp::kRtcStatusDone);
  EXPECT_EQ(r.word2, upid::kMaximalPosition);
  EXPECT_EQ(Value(r), 3'000'000);
}

TEST_F(RtcTest, Errors_A14) {
  EXPECT_EQ(Rtc(RtcCommand::kReadRamValueByUpid, 0x1450).status, 0xC0);  // unknown UPID
  EXPECT_EQ(Rtc(static_cast<RtcCommand>(0x99)).status, 0xC0);            // unknown command
  EXPECT_EQ(Rtc(RtcCommand::kWriteRamValueByUpid, upid::kTriggerMode, 9).status, 0xC2);
  EXPECT_EQ(Rtc(RtcCommand::kWriteRamValueByUpid, upid::kActualPosition, 1).status, 0xC3);
  EXPECT_EQ(Rtc(RtcCommand::kGetNextUpidListItem).status, 0xC5);  // 0x21 without 0x20
  EXPECT_EQ(Rtc(RtcCommand::kReadRomValueByUpid, upid::kActualPosition).status, 0xC3);
}

TEST_F(RtcTest, RamRomAndRestart_D31_A11) {
  EXPECT_EQ(Rtc(RtcCommand::kWriteRamValueByUpid, upid::kPredefVelocity, 111).status, 0);
  EXPECT_EQ(Value(Rtc(RtcCommand::kReadRamValueByUpid, upid::kPredefVelocity)), 111);
  EXPECT_EQ(Value(Rtc(RtcCommand::kReadRomValueByUpid, upid::kPredefVelocity)), 1'000'000);
  EXPECT_EQ(Rtc(RtcCommand::kWriteRomValueByUpid, upid::kPredefVelocity, 222).status, 0);
  EXPECT_EQ(Value(Rtc(RtcCommand::kReadRamValueByUpid, upid::kPredefVelocity)), 111);
  EXPECT_EQ(Rtc(RtcCommand::kWriteRamAndRomValueByUpid, upid::kQuickStopDeceleration, 7777).status,
            0);
  // Restart: sent with count 0 after a non-zero count; silent for the boot time.
  EXPECT_FALSE(RtcRaw(0, RtcCommand::kRestartDrive, 0).has_value());
  Ms(50);
  EXPECT_FALSE(RtcRaw(0, RtcCommand::kRestartDrive, 0).has_value());
  Ms(60);
  auto after = RtcRaw(0, RtcCommand::kRestartDrive, 0);  // still held: no second restart
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->rtc->count, 0);
  EXPECT_EQ(after->rtc->status, 0);
  EXPECT_EQ(dev_->parameters().Get(upid::kPredefVelocity), 222);  // RAM := ROM
  EXPECT_EQ(dev_->parameters().Get(upid::kQuickStopDeceleration), 7777);
  EXPECT_EQ(Main(), 0);
  count_ = 0;
  EXPECT_EQ(Value(Rtc(RtcCommand::kReadRamValueByUpid, upid::kPredefVelocity)), 222);
}

TEST_F(RtcTest, SameCount_NotExecutedAgain_LastResultRepeated) {
  auto first = RtcRaw(2, RtcCommand::kWriteRamValueByUpid, upid::kCmdTabVar1, 1);
  auto again = RtcRaw(2, RtcCommand::kWriteRamValueByUpid, upid::kCmdTabVar1, 2);
  ASSERT_TRUE(first && again);
  EXPECT_EQ(dev_->parameters().Get(upid::kCmdTabVar1), 1);
  EXPECT_EQ(*first->rtc, *again->rtc);
  // response bit 8 alone reports the last result too.
  linudp::Request poll;
  poll.response_definition = linudp::kRespRtc;
  EXPECT_EQ(*Send(poll).rtc, *first->rtc);
}

TEST_F(RtcTest, BeforeFirstCommand_RtcReplyAllZero_A05) {
  linudp::Request poll;
  poll.response_definition = linudp::kRespRtc | linudp::kRespStatusWord;
  EXPECT_EQ(*Send(poll).rtc, linudp::RtcReply{});
}

TEST_F(RtcTest, MinMaxDefault) {
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetMinimalValueByUpid, upid::kTriggerMode)), 0);
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetMaximalValueByUpid, upid::kTriggerMode)), 4);
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetDefaultValueByUpid, upid::kInTargetWindow)), 100);
  EXPECT_EQ(Rtc(RtcCommand::kGetDefaultValueByUpid, 0x1450).status, 0xC0);
}

TEST_F(RtcTest, UpidList_WalksToEnd) {
  EXPECT_EQ(Rtc(RtcCommand::kStartGettingUpidList, 0xF000).status, 0);
  std::vector<uint16_t> found;
  for (int i = 0; i < 20; ++i) {
    const auto r = Rtc(RtcCommand::kGetNextUpidListItem);
    if (r.status == linudp::kRtcStatusEndOfUpidList) break;
    ASSERT_EQ(r.status, 0);
    found.push_back(r.word2);
  }
  EXPECT_EQ(found, (std::vector<uint16_t>{0xF000, 0xF001, 0xF002, 0xF003, 0xF004, 0xF005, 0xF006,
                                          0xF007, 0xF008}));
  // Modified list: ROM values that differ from their defaults.
  Rtc(RtcCommand::kWriteRomValueByUpid, upid::kCmdTabVar2, 42);
  Rtc(RtcCommand::kStartGettingModifiedUpidList, 0);
  const auto m = Rtc(RtcCommand::kGetNextModifiedUpidListItem);
  EXPECT_EQ(m.word2, upid::kCmdTabVar2);
  EXPECT_EQ(Value(m), 42);
  EXPECT_EQ(Rtc(RtcCommand::kGetNextModifiedUpidListItem).status, 0xC6);
}

TEST_F(RtcTest, ErrorLog_CountersCodesTimesText) {
  SwitchOn();
  Ms(1000);
  linudp::Request unknown;  // header 1301h: master ID 13h is not defined -> 0081h at t = 1.31 s
  unknown.motion_command = mc::McBlock{0x01, 0x13};
  Send(unknown);
  const auto counter = Rtc(RtcCommand::kGetErrorLogEntryCounter);
  EXPECT_EQ(counter.word3, 1);  // logged
  EXPECT_EQ(counter.word4, 1);  // occurred
  const auto code = Rtc(RtcCommand::kGetErrorLogEntryErrorCode, 0);
  EXPECT_EQ(code.status, 0);
  EXPECT_EQ(code.word3, mc::kUnknownMotionCommand);
  const auto low = Rtc(RtcCommand::kGetErrorLogEntryTimeLow, 0);
  EXPECT_NEAR(Value(low), 1310, 5);  // milliseconds of operating time
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetErrorLogEntryTimeHigh, 0)), 0);  // hours
  EXPECT_EQ(Rtc(RtcCommand::kGetErrorLogEntryErrorCode, 5).status, 0xC2);
  // "Unknown Motion Cmd": stringlet 0 = "Unkn".
  const auto text = Rtc(RtcCommand::kGetErrorCodeTextStringlet, 0x0081, 0);
  EXPECT_EQ(text.word3, 'U' | ('n' << 8));
  EXPECT_EQ(text.word4, 'k' | ('n' << 8));
  // Newest first (decision 603).
  ASSERT_TRUE(dev_->RaiseError(mc::kPwrVoltageTooLow).ok());
  EXPECT_EQ(Rtc(RtcCommand::kGetErrorLogEntryCounter).word4, 2);
  EXPECT_EQ(Rtc(RtcCommand::kGetErrorLogEntryErrorCode, 0).word3, 0x0003);
}

TEST_F(RtcTest, StopMcFlashSaveStartMc_A13) {
  EXPECT_EQ(Rtc(RtcCommand::kCommandTableSaveToFlash).status, 0xC3);  // MC running
  EXPECT_EQ(Rtc(RtcCommand::kStopMcAndApplicationSw).status, 0);
  Cw(mc::kSwitchedOff);
  EXPECT_EQ(Main(), 0);  // MC blocks ignored while stopped
  const auto save = Rtc(RtcCommand::kCommandTableSaveToFlash);
  EXPECT_EQ(save.status, linudp::kRtcStatusCommandRunning);
  Ms(999);
  EXPECT_EQ(RtcRaw(count_, RtcCommand::kCommandTableSaveToFlash, 0)->rtc->status, 0x02);
  Ms(1);
  EXPECT_EQ(RtcRaw(count_, RtcCommand::kCommandTableSaveToFlash, 0)->rtc->status, 0x00);
  EXPECT_EQ(Rtc(RtcCommand::kStartMcAndApplicationSw).status, 0);
  Cw(mc::kSwitchedOff);
  EXPECT_EQ(Main(), 2);
}

TEST_F(RtcTest, BusyOption_ReportsRunningFirst_A09) {
  SimOptions o = TestOptions();
  o.rtc_busy_telegrams = 2;
  Make(o);
  auto r1 = RtcRaw(1, RtcCommand::kReadRamValueByUpid, upid::kMaximalPosition);
  auto r2 = RtcRaw(1, RtcCommand::kReadRamValueByUpid, upid::kMaximalPosition);
  auto r3 = RtcRaw(1, RtcCommand::kReadRamValueByUpid, upid::kMaximalPosition);
  EXPECT_EQ(r1->rtc->status, 0x02);
  EXPECT_EQ(r2->rtc->status, 0x02);
  EXPECT_EQ(r3->rtc->status, 0x00);
  EXPECT_EQ(Value(*r3->rtc), 3'000'000);
}

TEST_F(RtcTest, CommandTable_WriteReadPresence) {
  EXPECT_EQ(Rtc(RtcCommand::kCommandTableWriteEntry, 33, 6).status, 0);
  EXPECT_EQ(Rtc(RtcCommand::kCommandTableWriteEntryData, 33, 0x04030201).status, 0x04);
  EXPECT_EQ(Rtc(RtcCommand::kCommandTableWriteEntryData, 33, 0x00000605).status, 0x00);
  const auto get = Rtc(RtcCommand::kCommandTableGetEntry, 33);
  EXPECT_EQ(get.word3, 6);
  const auto d1 = Rtc(RtcCommand::kCommandTableGetEntryData, 33);
  EXPECT_EQ(d1.status, 0x04);
  EXPECT_EQ(static_cast<uint32_t>(Value(d1)), 0x04030201u);
  const auto d2 = Rtc(RtcCommand::kCommandTableGetEntryData, 33);
  EXPECT_EQ(d2.status, 0x00);
  EXPECT_EQ(d2.word3, 0x0605);
  // Entries 32-63: bit 1 of byte 0 cleared (entry 33 used), every other bit set.
  const auto presence = Rtc(RtcCommand::kGetPresenceListEntries32To63);
  EXPECT_EQ(presence.word2, 4);
  EXPECT_EQ(presence.word3, 0xFFFD);
  EXPECT_EQ(presence.word4, 0xFFFF);
  EXPECT_EQ(Rtc(RtcCommand::kCommandTableWriteEntry, 1, 5).status, 0xD0);  // odd size
}

TEST_F(RtcTest, Curve_AddThenRead) {
  EXPECT_EQ(Rtc(RtcCommand::kStartAddingCurve, 7, 4 | (8u << 16)).status, 0);
  EXPECT_EQ(Rtc(RtcCommand::kAddCurveInfoBlock, 7, 0xAABBCCDD).status, 0x04);
  EXPECT_EQ(Rtc(RtcCommand::kAddCurveData, 7, 100).status, 0x04);
  EXPECT_EQ(Rtc(RtcCommand::kAddCurveData, 7, static_cast<uint32_t>(-100)).status, 0x00);
  EXPECT_EQ(Rtc(RtcCommand::kStartAddingCurve, 7, 4).status, 0xD4);  // already defined
  const auto start = Rtc(RtcCommand::kStartGettingCurve, 7);
  EXPECT_EQ(start.word3, 4);
  EXPECT_EQ(start.word4, 8);
  EXPECT_EQ(static_cast<uint32_t>(Value(Rtc(RtcCommand::kGetCurveInfoBlock, 7))), 0xAABBCCDDu);
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetCurveData, 7)), 100);
  EXPECT_EQ(Value(Rtc(RtcCommand::kGetCurveData, 7)), -100);
  EXPECT_EQ(Rtc(RtcCommand::kStartGettingCurve, 8).status, 0xD4);
}

TEST_F(RtcTest, MonitoringChannels_CarryConfiguredUpids_A12) {
  Rtc(RtcCommand::kWriteRamValueByUpid, upid::kMonitoringChannel1, upid::kActualPosition);
  Rtc(RtcCommand::kWriteRamValueByUpid, upid::kMonitoringChannel1 + 2, upid::kMinimalPosition);
  Rtc(RtcCommand::kWriteRamValueByUpid, upid::kMinimalPosition, static_cast<uint32_t>(-5));
  linudp::Request poll;
  poll.response_definition = linudp::kRespMonitoring;
  const auto m = *Send(poll).monitoring;
  EXPECT_EQ(m[0], 100'000);  // initial position 10 mm
  EXPECT_EQ(m[1], 0);        // channel UPID 0 -> 0
  EXPECT_EQ(m[2], -5);       // sign-extended
  EXPECT_EQ(m[3], 0);
}

}  // namespace
}  // namespace drivegw::sim::linmot::testing
