// The worked telegrams of linmot-linudp.md §9 as bytes through DecodeRequest -> Handle ->
// EncodeReply, plus the reply-header rules.
#include <vector>

#include "sim/linmot/parameters.h"
#include "tests/sim/linmot/device_fixture.h"

namespace drivegw::sim::linmot::testing {
namespace {

class TelegramTest : public DeviceFixture {
 protected:
  std::vector<uint8_t> Exchange(const std::vector<uint8_t>& bytes, size_t min_payload = 14) {
    auto request = linudp::DecodeRequest(bytes);
    EXPECT_TRUE(request.ok()) << request.status();
    auto reply = dev_->Handle(request.value_or(linudp::Request{}));
    EXPECT_TRUE(reply.has_value());
    return linudp::EncodeReply(reply.value_or(linudp::Reply{}), min_payload);
  }
  static uint16_t U16(const std::vector<uint8_t>& b, size_t off) {
    return static_cast<uint16_t>(b[off] | (b[off + 1] << 8));
  }
  static int32_t I32(const std::vector<uint8_t>& b, size_t off) {
    return static_cast<int32_t>(uint32_t{b[off]} | (uint32_t{b[off + 1]} << 8) |
                                (uint32_t{b[off + 2]} << 16) | (uint32_t{b[off + 3]} << 24));
  }
};

TEST_F(TelegramTest, StatusPoll_Telegram1_26Bytes) {
  const auto reply = Exchange({0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00, 0x00});
  ASSERT_EQ(reply.size(), 26u);
  EXPECT_EQ(std::vector<uint8_t>(reply.begin(), reply.begin() + 8),
            (std::vector<uint8_t>{0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00, 0x00}));
  EXPECT_EQ(U16(reply, 8), dev_->status_word());
  EXPECT_EQ(U16(reply, 10), dev_->state_var());
  EXPECT_EQ(I32(reply, 12), 100'000);  // actual: initial 10 mm
  EXPECT_EQ(I32(reply, 16), 100'000);  // demand
  EXPECT_EQ(U16(reply, 22), dev_->warn_word());
  EXPECT_EQ(U16(reply, 24), 0);
}

TEST_F(TelegramTest, ControlWordOnly_Telegram2_ZeroFilledTo14) {
  const auto reply = Exchange({0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x3F, 0x00});
  ASSERT_EQ(reply.size(), 14u);
  EXPECT_EQ(std::vector<uint8_t>(reply.begin(), reply.begin() + 8),
            (std::vector<uint8_t>{0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00}));
  EXPECT_EQ(U16(reply, 8), dev_->status_word());
  EXPECT_TRUE(mc::StatusWord{U16(reply, 8)}.switch_on_locked());  // LMC-01 at power-up
  EXPECT_EQ(std::vector<uint8_t>(reply.begin() + 10, reply.end()),
            (std::vector<uint8_t>{0, 0, 0, 0}));
}

TEST_F(TelegramTest, MotionCommand_Telegram3_AcceptedWithEchoOne) {
  Ready();
  std::vector<uint8_t> req = {0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01,
                              0x01, 0xA0, 0x86, 0x01, 0x00, 0x40, 0x42, 0x0F, 0x00,
                              0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00};
  req.resize(40, 0x00);
  const auto reply = Exchange(req);
  ASSERT_EQ(reply.size(), 14u);
  EXPECT_EQ(std::vector<uint8_t>(reply.begin(), reply.begin() + 8),
            (std::vector<uint8_t>{0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00}));
  const auto sv = mc::StateVar::FromRaw(U16(reply, 10));
  EXPECT_EQ(sv.main_state, 0x08);
  EXPECT_EQ(sv.count_echo(), 1);
  EXPECT_EQ(reply[12], 0);
  EXPECT_EQ(reply[13], 0);
  Ms(200);
  EXPECT_EQ(dev_->demand_position(), 100'000);  // 10 mm
}

TEST_F(TelegramTest, RtcReadRam_Telegram4) {
  // 1450h is the manual's example UPID; the simulator does not know it (A-14: 0xC0) ...
  const auto unknown = Exchange({0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x03, 0x11, 0x50,
                                 0x14, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(unknown, (std::vector<uint8_t>{0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x03,
                                           0xC0, 0x50, 0x14, 0x00, 0x00, 0x00, 0x00}));
  // ... the same layout with a known UPID (146Fh, 300 mm = 0x002DC6C0) reads the value.
  const auto known = Exchange({0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x04, 0x11, 0x6F,
                               0x14, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(known, (std::vector<uint8_t>{0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x04, 0x00,
                                         0x6F, 0x14, 0xC0, 0xC6, 0x2D, 0x00}));
}

TEST_F(TelegramTest, FullCyclic_Telegram5_50BytesAtFixedOffsets) {
  std::vector<uint8_t> req = {0x07, 0x00, 0x00, 0x00, 0xFF, 0x01, 0x00, 0x00, 0x3E, 0x00};
  req.resize(42, 0x00);  // MC block: NOP count 0 (no change)
  const std::vector<uint8_t> rtc = {0x01, 0x11, 0x8D, 0x1B, 0x00, 0x00, 0x00, 0x00};
  req.insert(req.end(), rtc.begin(), rtc.end());
  ASSERT_EQ(req.size(), 50u);
  const auto reply = Exchange(req);
  ASSERT_EQ(reply.size(), 50u);
  EXPECT_EQ(I32(reply, 0), 0x07);
  EXPECT_EQ(I32(reply, 4), 0x1FF);
  EXPECT_EQ(mc::StateVar::FromRaw(U16(reply, 10)).main_state, 2);  // 003Eh: 0 -> 1 -> 2
  EXPECT_EQ(I32(reply, 12), 100'000);
  EXPECT_EQ(reply[42], 0x01);  // RTC count echo
  EXPECT_EQ(reply[43], 0x00);  // status OK
  EXPECT_EQ(U16(reply, 44), 0x1B8D);
  EXPECT_EQ(I32(reply, 46), 100'000);  // actual position via RTC
}

TEST_F(TelegramTest, ReplyHeader_MasksReservedBitsAndForcesRtcBit_A02_A03) {
  // Request: reserved request bits 3-31 and response bits 9-31 set; RTC block without resp 8.
  std::vector<uint8_t> req = {0xF8, 0xFF, 0xFF, 0xFF, 0x01, 0xFE, 0xFF, 0xFF};
  const auto reply = Exchange(req);  // masked: request 0, response 0x001 -> only status word
  EXPECT_EQ(I32(reply, 0), 0);
  EXPECT_EQ(I32(reply, 4), 0x001);
  std::vector<uint8_t> rtc_req = {0x04, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
                                  0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  const auto rtc_reply = Exchange(rtc_req);
  EXPECT_EQ(I32(rtc_reply, 0), 0x04);
  EXPECT_EQ(I32(rtc_reply, 4), 0x101);  // bit 8 added
  ASSERT_EQ(rtc_reply.size(), 18u);
  EXPECT_EQ(rtc_reply[10], 0x01);  // RTC block after the status word
}

TEST_F(TelegramTest, ManualPadding_64Bytes_A06) {
  const auto reply =
      Exchange({0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00}, linudp::kManualReplyPayload);
  EXPECT_EQ(reply.size(), 64u);
}

}  // namespace
}  // namespace drivegw::sim::linmot::testing
