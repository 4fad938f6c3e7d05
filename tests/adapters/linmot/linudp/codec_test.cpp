// LinUDP V2 codec tests: §9 worked telegrams byte for byte, layouts, lengths, reserved bits.
#include "adapters/linmot/linudp/codec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace drivegw::linmot::linudp {
namespace {

using ::testing::HasSubstr;

using Bytes = std::vector<uint8_t>;

Bytes Concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// linmot-linudp.md §3.4: VAI Go To Pos 10 mm, 1 m/s, 10 m/s², 10 m/s², count 1 (§9 telegram 3).
std::array<uint8_t, 32> GoToPosBlock() {
  std::array<uint8_t, 32> mc{};
  const Bytes head = {0x01, 0x01, 0xA0, 0x86, 0x01, 0x00, 0x40, 0x42, 0x0F,
                      0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00};
  std::copy(head.begin(), head.end(), mc.begin());
  return mc;
}

// ---- §9 telegram 1: status poll -----------------------------------------------------------

TEST(WorkedTelegram, StatusPoll_Request_MatchesBytes) {
  Request req;
  req.response_definition = kRespStandard;
  const Bytes wire = {0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00, 0x00};
  EXPECT_EQ(EncodeRequest(req), wire);
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(WorkedTelegram, StatusPoll_Reply_MatchesBytes) {
  Reply reply;
  reply.request_definition = 0;
  reply.response_definition = kRespStandard;
  reply.status_word = 0x4C37;
  reply.state_var = 0x0801;
  reply.actual_position = 100000;   // 10 mm
  reply.demand_position = -250000;  // -25 mm
  reply.current = -1200;
  reply.warn_word = 0x0080;
  reply.error_code = 0x0000;
  const Bytes wire = {0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00, 0x00,  // header
                      0x37, 0x4C,                                      // status word
                      0x01, 0x08,                                      // state var
                      0xA0, 0x86, 0x01, 0x00,                          // actual position
                      0x70, 0x2F, 0xFC, 0xFF,                          // demand position
                      0x50, 0xFB,                                      // current
                      0x80, 0x00,                                      // warn word
                      0x00, 0x00};                                     // error code
  ASSERT_EQ(wire.size(), 26u);
  EXPECT_EQ(EncodeReply(reply), wire);
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
}

// ---- §9 telegram 2: control word only ------------------------------------------------------

TEST(WorkedTelegram, ControlWordOnly_Request_MatchesBytes) {
  Request req;
  req.response_definition = kRespStatusWord;
  req.control_word = 0x003F;
  const Bytes wire = {0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x3F, 0x00};
  EXPECT_EQ(EncodeRequest(req), wire);
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(WorkedTelegram, ControlWordOnly_Reply_ZeroFilledTo14) {
  Reply reply;
  reply.request_definition = kReqControlWord;
  reply.response_definition = kRespStatusWord;
  reply.status_word = 0x0C37;
  const Bytes wire = {0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0x00, 0x37, 0x0C, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(EncodeReply(reply), wire);
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
  // Without padding the telegram is 10 bytes (A-06: the gateway accepts that too).
  EXPECT_EQ(EncodeReply(reply, 0), Bytes(wire.begin(), wire.begin() + 10));
  auto unpadded = DecodeReply(Bytes(wire.begin(), wire.begin() + 10));
  ASSERT_TRUE(unpadded.ok()) << unpadded.status();
  EXPECT_EQ(*unpadded, reply);
}

// ---- §9 telegram 3: motion command --------------------------------------------------------

TEST(WorkedTelegram, MotionCommand_Request_MatchesBytes) {
  Request req;
  req.response_definition = kRespStatusWord | kRespStateVar;
  req.motion_command = GoToPosBlock();
  const Bytes wire =
      Concat({{0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01, 0x01, 0xA0, 0x86, 0x01,
               0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00},
              Bytes(14, 0x00)});
  ASSERT_EQ(wire.size(), 40u);
  EXPECT_EQ(EncodeRequest(req), wire);
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(WorkedTelegram, MotionCommand_Reply_MatchesBytes) {
  Reply reply;
  reply.request_definition = kReqMotionCommand;
  reply.response_definition = kRespStatusWord | kRespStateVar;
  reply.status_word = 0x4C37;
  reply.state_var = 0x0801;  // main state 8, count echo 1
  const Bytes wire = {0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00,
                      0x00, 0x37, 0x4C, 0x01, 0x08, 0x00, 0x00};
  EXPECT_EQ(EncodeReply(reply), wire);
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
  EXPECT_EQ(*decoded->state_var >> 8, 0x08);
  EXPECT_EQ(*decoded->state_var & 0x0F, 1);
}

// ---- §9 telegram 4: RTC read RAM -----------------------------------------------------------

TEST(WorkedTelegram, RtcReadRam_Request_MatchesBytes) {
  Request req;
  req.response_definition = kRespRtc;
  req.rtc = RtcRequest{3, static_cast<uint8_t>(RtcCommand::kReadRamValueByUpid), 0x1450, 0, 0};
  const Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0x03, 0x11, 0x50, 0x14, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(EncodeRequest(req), wire);
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(WorkedTelegram, RtcReadRam_Reply_ValueIsInt32AtWord3) {
  // Value -2 (0xFFFFFFFE): low word in word 3, high word in word 4 (§5.3 "value low / high").
  Reply reply;
  reply.request_definition = kReqRtc;
  reply.response_definition = kRespRtc;
  reply.rtc = RtcReply{3, kRtcStatusDone, 0x1450, 0xFFFE, 0xFFFF};
  const Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0x03, 0x00, 0x50, 0x14, 0xFE, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(EncodeReply(reply), wire);
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
  const int32_t value =
      static_cast<int32_t>(uint32_t{decoded->rtc->word3} | (uint32_t{decoded->rtc->word4} << 16));
  EXPECT_EQ(value, -2);
}

TEST(WorkedTelegram, RtcReadRam_BusyReply_StatusByte9Is02) {
  const Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0x03, 0x02, 0x50, 0x14, 0x00, 0x00, 0x00, 0x00};
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ASSERT_TRUE(decoded->rtc.has_value());
  EXPECT_TRUE(IsRtcBusy(decoded->rtc->status));
  EXPECT_FALSE(IsRtcError(decoded->rtc->status));
}

// ---- §9 telegram 5: full cyclic telegram ---------------------------------------------------

TEST(WorkedTelegram, FullCyclic_Request_OffsetsOfSection32) {
  Request req;
  req.response_definition = 0x1FF;
  req.control_word = 0x083F;
  req.motion_command = GoToPosBlock();
  req.rtc =
      RtcRequest{5, static_cast<uint8_t>(RtcCommand::kWriteRamValueByUpid), 0x1450, 0x5678, 0x1234};
  const Bytes wire = EncodeRequest(req);
  ASSERT_EQ(wire.size(), 50u);
  EXPECT_EQ(Bytes(wire.begin(), wire.begin() + 8),
            (Bytes{0x07, 0x00, 0x00, 0x00, 0xFF, 0x01, 0x00, 0x00}));
  EXPECT_EQ(wire[8], 0x3F);  // control word at 8
  EXPECT_EQ(wire[9], 0x08);
  EXPECT_EQ(Bytes(wire.begin() + 10, wire.begin() + 42),
            Bytes(req.motion_command->begin(), req.motion_command->end()));  // MC at 10
  EXPECT_EQ(Bytes(wire.begin() + 42, wire.end()),
            (Bytes{0x05, 0x13, 0x50, 0x14, 0x78, 0x56, 0x34, 0x12}));  // RTC at 42
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(WorkedTelegram, FullCyclic_Reply_OffsetsOfSection43) {
  Reply reply;
  reply.request_definition = 0x07;
  reply.response_definition = 0x1FF;
  reply.status_word = 0x1122;
  reply.state_var = 0x3344;
  reply.actual_position = 0x55667788;
  reply.demand_position = -1;
  reply.current = 0x0102;
  reply.warn_word = 0x0304;
  reply.error_code = 0x0506;
  reply.monitoring = std::array<int32_t, 4>{0x0A0B0C0D, -2, 0, 0x7FFFFFFF};
  reply.rtc = RtcReply{5, kRtcStatusDone, 0x1450, 0x5678, 0x1234};
  const Bytes wire = {0x07, 0x00, 0x00, 0x00, 0xFF, 0x01, 0x00, 0x00,   // 0: header
                      0x22, 0x11,                                       // 8: status word
                      0x44, 0x33,                                       // 10: state var
                      0x88, 0x77, 0x66, 0x55,                           // 12: actual position
                      0xFF, 0xFF, 0xFF, 0xFF,                           // 16: demand position
                      0x02, 0x01,                                       // 20: current
                      0x04, 0x03,                                       // 22: warn word
                      0x06, 0x05,                                       // 24: error code
                      0x0D, 0x0C, 0x0B, 0x0A,                           // 26: monitoring 1
                      0xFE, 0xFF, 0xFF, 0xFF,                           // 30: monitoring 2
                      0x00, 0x00, 0x00, 0x00,                           // 34: monitoring 3
                      0xFF, 0xFF, 0xFF, 0x7F,                           // 38: monitoring 4
                      0x05, 0x00, 0x50, 0x14, 0x78, 0x56, 0x34, 0x12};  // 42: RTC reply
  ASSERT_EQ(wire.size(), 50u);
  EXPECT_EQ(EncodeReply(reply), wire);
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
}

// ---- layouts -------------------------------------------------------------------------------

TEST(LayoutSize, KnownDefinitions_MatchReference) {
  EXPECT_EQ(RequestLayoutSize(0), 8u);
  EXPECT_EQ(RequestLayoutSize(kReqRtc), 16u);
  EXPECT_EQ(RequestLayoutSize(0x07), 50u);  // §3.2
  EXPECT_EQ(ResponseLayoutSize(0), 8u);
  EXPECT_EQ(ResponseLayoutSize(kRespStandard), 26u);  // §9 telegram 1
  EXPECT_EQ(ResponseLayoutSize(0x1FF), 50u);          // §4.3
  EXPECT_EQ(ResponseLayoutSize(kRespMonitoring), 24u);
}

TEST(LayoutSize, ReservedBits_CountNothing) {
  EXPECT_EQ(RequestLayoutSize(0xFFFFFFF8), 8u);
  EXPECT_EQ(RequestLayoutSize(0xFFFFFFFF), 50u);
  EXPECT_EQ(ResponseLayoutSize(0xFFFFFE00), 8u);
  EXPECT_EQ(ResponseLayoutSize(0xFFFFFFFF), 50u);
}

// Request with every block of `req_def` filled with recognisable values.
Request MakeRequest(uint32_t req_def, uint32_t resp_def) {
  Request req;
  req.response_definition = resp_def;
  if (req_def & kReqControlWord) req.control_word = static_cast<uint16_t>(0x8000 | req_def);
  if (req_def & kReqMotionCommand) {
    std::array<uint8_t, 32> mc;
    for (size_t i = 0; i < mc.size(); ++i) mc[i] = static_cast<uint8_t>(0xA0 + i + req_def);
    req.motion_command = mc;
  }
  if (req_def & kReqRtc) {
    req.rtc = RtcRequest{static_cast<uint8_t>(resp_def & 0x0F), 0x84,
                         static_cast<uint16_t>(0x1000 + req_def), 0xBEEF, 0xCAFE};
  }
  return req;
}

TEST(RoundTrip, EveryRequestBlockCombination_DecodesToSameRequest) {
  for (uint32_t req_def = 0; req_def <= kReqDefinedMask; ++req_def) {
    for (uint32_t resp_def : {0u, 0x1u, 0x7Fu, 0x100u, 0x1FFu}) {
      const Request req = MakeRequest(req_def, resp_def);
      EXPECT_EQ(RequestDefinitionOf(req), req_def);
      const Bytes wire = EncodeRequest(req);
      EXPECT_EQ(wire.size(), RequestLayoutSize(req_def)) << "req_def=" << req_def;
      auto decoded = DecodeRequest(wire);
      ASSERT_TRUE(decoded.ok()) << decoded.status();
      EXPECT_EQ(*decoded, req) << "req_def=" << req_def << " resp_def=" << resp_def;
    }
  }
}

// Reply carrying a distinct value in every block of `resp_def`.
Reply MakeReply(uint32_t resp_def) {
  Reply r;
  r.request_definition = resp_def & 0x7;
  r.response_definition = resp_def;
  const auto k = static_cast<int32_t>(resp_def);
  if (resp_def & kRespStatusWord) r.status_word = static_cast<uint16_t>(0x1000 + k);
  if (resp_def & kRespStateVar) r.state_var = static_cast<uint16_t>(0x0800 + (k & 0xF));
  if (resp_def & kRespActualPosition) r.actual_position = -100000 * k - 7;
  if (resp_def & kRespDemandPosition) r.demand_position = 123456789 - k;
  if (resp_def & kRespCurrent) r.current = static_cast<int16_t>(-k);
  if (resp_def & kRespWarnWord) r.warn_word = static_cast<uint16_t>(0xF000 | k);
  if (resp_def & kRespErrorCode) r.error_code = static_cast<uint16_t>(0x0100 + k);
  if (resp_def & kRespMonitoring) r.monitoring = std::array<int32_t, 4>{k, -k, k << 20, INT32_MIN};
  if (resp_def & kRespRtc) {
    r.rtc = RtcReply{static_cast<uint8_t>(k & 0xF), kRtcStatusRangeError, 0x1450,
                     static_cast<uint16_t>(k), 0x8000};
  }
  return r;
}

TEST(RoundTrip, EveryResponseBlockCombination_DecodesToSameReply) {
  for (uint32_t resp_def = 0; resp_def <= kRespDefinedMask; ++resp_def) {
    const Reply reply = MakeReply(resp_def);
    for (size_t min_payload : {size_t{0}, kMinReplyPayload, kManualReplyPayload}) {
      const Bytes wire = EncodeReply(reply, min_payload);
      EXPECT_EQ(wire.size(), std::max(ResponseLayoutSize(resp_def), min_payload))
          << "resp_def=" << resp_def;
      auto decoded = DecodeReply(wire);
      ASSERT_TRUE(decoded.ok()) << decoded.status();
      EXPECT_EQ(*decoded, reply) << "resp_def=" << resp_def << " min_payload=" << min_payload;
    }
  }
}

TEST(EncodeReply, FlaggedBlockWithoutValue_IsZeroFilled) {
  Reply reply;
  reply.response_definition = kRespStatusWord | kRespActualPosition | kRespRtc;
  reply.actual_position = 1;
  const Bytes wire = EncodeReply(reply, 0);
  EXPECT_EQ(wire, (Bytes{0, 0, 0, 0, 0x05, 0x01, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(EncodeReply, PresentBlockWithoutBit_AddsBit) {
  Reply reply;
  reply.response_definition = kRespStatusWord;
  reply.status_word = 0x0102;
  reply.error_code = 0x0304;
  const Bytes wire = EncodeReply(reply, 0);
  EXPECT_EQ(wire, (Bytes{0, 0, 0, 0, 0x41, 0, 0, 0, 0x02, 0x01, 0x04, 0x03}));
}

// ---- padding (A-06) ------------------------------------------------------------------------

TEST(EncodeReply, MinPayload14_ZeroFillsShortReply) {
  Reply reply;
  reply.response_definition = kRespStateVar;
  reply.state_var = 0xFFFF;
  const Bytes wire = EncodeReply(reply, 14);
  ASSERT_EQ(wire.size(), 14u);
  EXPECT_EQ(Bytes(wire.begin() + 10, wire.end()), Bytes(4, 0x00));
}

TEST(EncodeReply, MinPayload64_ZeroFillsToManualLength) {
  const Reply reply = MakeReply(0x1FF);
  const Bytes wire = EncodeReply(reply, kManualReplyPayload);
  ASSERT_EQ(wire.size(), 64u);
  EXPECT_EQ(Bytes(wire.begin() + 50, wire.end()), Bytes(14, 0x00));
  EXPECT_EQ(Bytes(wire.begin(), wire.begin() + 50), EncodeReply(reply, 0));
}

TEST(EncodeReply, LayoutLongerThanMinPayload_NotTruncated) {
  const Reply reply = MakeReply(kRespStandard);
  EXPECT_EQ(EncodeReply(reply, 14).size(), 26u);
}

// ---- short and long datagrams ---------------------------------------------------------------

TEST(DecodeRequest, ShorterThanHeader_InvalidArgument) {
  for (size_t n = 0; n < kHeaderSize; ++n) {
    const Bytes wire(n, 0x00);
    auto decoded = DecodeRequest(wire);
    ASSERT_FALSE(decoded.ok());
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(decoded.status().message(), HasSubstr("header"));
  }
}

TEST(DecodeRequest, ShorterThanFlaggedBlocks_InvalidArgumentNamesLengths) {
  const Bytes full = EncodeRequest(MakeRequest(0x7, 0x1FF));
  for (size_t n = kHeaderSize; n < full.size(); ++n) {
    auto decoded = DecodeRequest(std::span<const uint8_t>(full.data(), n));
    ASSERT_FALSE(decoded.ok()) << n;
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(decoded.status().message(), HasSubstr("needs 50 bytes"));
    EXPECT_THAT(decoded.status().message(), HasSubstr("has " + std::to_string(n)));
  }
}

TEST(DecodeRequest, TruncatedMcBlock_Rejected) {
  // [OA] sends short MC blocks; A-04: the simulated drive drops them.
  const Bytes wire = {0x02, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01, 0x01, 0xA0, 0x86, 0x01,
                      0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00};
  auto decoded = DecodeRequest(wire);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().message(),
            "linudp request: request definition 0x00000002 needs 40 bytes, datagram has 26");
}

TEST(DecodeRequest, TrailingBytes_Ignored) {
  const Request req = MakeRequest(kReqControlWord | kReqRtc, kRespStandard);
  Bytes wire = EncodeRequest(req);
  wire.insert(wire.end(), 20, 0xEE);
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, req);
}

TEST(DecodeReply, ShorterThanHeader_InvalidArgument) {
  auto decoded = DecodeReply(Bytes{0x00, 0x00, 0x00, 0x00, 0x7F, 0x00, 0x00});
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(decoded.status().message(), HasSubstr("7 bytes"));
}

TEST(DecodeReply, ShorterThanLayout_InvalidArgumentNamesBlockAndLengths) {
  const Bytes full = EncodeReply(MakeReply(0x1FF), 0);
  for (size_t n = kHeaderSize; n < full.size(); ++n) {
    auto decoded = DecodeReply(std::span<const uint8_t>(full.data(), n));
    ASSERT_FALSE(decoded.ok()) << n;
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(decoded.status().message(), HasSubstr("needs 50 bytes"));
    EXPECT_THAT(decoded.status().message(), HasSubstr("has " + std::to_string(n)));
  }
  auto cut = DecodeReply(std::span<const uint8_t>(full.data(), 45));  // inside the RTC block
  EXPECT_EQ(cut.status().message(),
            "linudp reply.rtc: block at offset 42 needs 8 bytes; response definition "
            "0x000001FF needs 50 bytes, datagram has 45");
  auto monitoring = DecodeReply(std::span<const uint8_t>(full.data(), 30));
  EXPECT_THAT(monitoring.status().message(), HasSubstr("reply.monitoring: block at offset 26"));
}

TEST(DecodeReply, ZeroFilled64ByteReply_TrailingZerosIgnored) {
  const Reply reply = MakeReply(kRespStatusWord | kRespRtc);
  auto decoded = DecodeReply(EncodeReply(reply, 64));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(*decoded, reply);
}

TEST(DecodeReply, LeftOverBytesAfterLayout_Ignored) {
  // linmot-linudp.md 4.5.3: replies may carry left-overs of an earlier reply.
  Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                0x03, 0x00, 0x50, 0x14, 0x01, 0x00, 0x00, 0x00};
  wire.insert(wire.end(), {0xDE, 0xAD, 0xBE, 0xEF});
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->rtc, (RtcReply{3, 0, 0x1450, 1, 0}));
  EXPECT_FALSE(decoded->status_word.has_value());
}

// ---- reserved bits (A-03) ------------------------------------------------------------------

TEST(DecodeRequest, ReservedBits_MaskedOff) {
  const Bytes wire = {0xF9, 0xFF, 0xFF, 0xFF,  // request bits 0 + reserved 3..31
                      0x7F, 0xFE, 0xFF, 0xFF,  // response bits 0-6 + reserved 9..31
                      0x3F, 0x00};
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->response_definition, kRespStandard);
  EXPECT_EQ(decoded->control_word, 0x003F);
  EXPECT_FALSE(decoded->motion_command.has_value());
  EXPECT_FALSE(decoded->rtc.has_value());
}

TEST(DecodeRequest, RtcCountReservedNibble_MaskedOff) {
  const Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0xF7, 0x13, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00};
  auto decoded = DecodeRequest(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->rtc, (RtcRequest{7, 0x13, 1, 2, 3}));
}

TEST(EncodeRequest, ReservedResponseBits_NeverSent) {
  Request req;
  req.response_definition = 0xFFFFFFFF;
  const Bytes wire = EncodeRequest(req);
  EXPECT_EQ(wire, (Bytes{0x00, 0x00, 0x00, 0x00, 0xFF, 0x01, 0x00, 0x00}));
}

TEST(EncodeRequest, RtcCountHighNibble_NotSent) {
  Request req;
  req.rtc = RtcRequest{0x1F, 0x00, 0, 0, 0};
  EXPECT_EQ(EncodeRequest(req)[8], 0x0F);
}

TEST(EncodeRequest, RtcWithoutResponseBit8_EncodedAsGiven) {
  // A-05 pairing is the session's policy (docs/decisions/201-linudp-codec-boundaries.md).
  Request req;
  req.response_definition = kRespStatusWord;
  req.rtc = RtcRequest{1, 0x11, 0x1450, 0, 0};
  const Bytes wire = EncodeRequest(req);
  EXPECT_EQ(Bytes(wire.begin(), wire.begin() + 8),
            (Bytes{0x04, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00}));
}

TEST(DecodeReply, ReservedResponseBits_KeptButCarryNoBlock) {
  const Bytes wire = {0x07, 0x00, 0x00, 0x00, 0x01, 0x02, 0x00, 0x80,  // bits 0, 9, 31
                      0x34, 0x12};
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->response_definition, 0x80000201u);
  EXPECT_EQ(decoded->request_definition, 0x07u);
  EXPECT_EQ(decoded->status_word, 0x1234);
  EXPECT_FALSE(decoded->rtc.has_value());
  // Re-encoding keeps the header as received.
  EXPECT_EQ(EncodeReply(*decoded, 0), wire);
}

TEST(DecodeReply, RequestDefinitionField_NotChecked) {
  // the gateway never rejects on bytes 0-3.
  const Bytes wire = {0xAA, 0xBB, 0xCC, 0xDD, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00};
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->request_definition, 0xDDCCBBAAu);
}

TEST(DecodeReply, RtcCountReservedNibble_MaskedOff) {
  const Bytes wire = {0x04, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00,
                      0xA3, 0xC2, 0x50, 0x14, 0x00, 0x00, 0x00, 0x00};
  auto decoded = DecodeReply(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->rtc->count, 3);
  EXPECT_EQ(decoded->rtc->status, kRtcStatusRangeError);
  EXPECT_TRUE(IsRtcError(decoded->rtc->status));
}

// ---- RTC command IDs and statuses ----------------------------------------------------------

TEST(RtcCommandFromId, EveryIdOfSection53_Known) {
  const std::vector<uint8_t> ids = {
      0x00, 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x17, 0x20, 0x21, 0x22, 0x23,
      0x30, 0x31, 0x32, 0x33, 0x34, 0x35, 0x36, 0x40, 0x41, 0x50, 0x51, 0x52, 0x53,
      0x54, 0x55, 0x60, 0x61, 0x62, 0x70, 0x71, 0x72, 0x73, 0x74, 0x80, 0x81, 0x82,
      0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8A, 0x8B, 0x8C, 0x8D, 0x8E};
  for (uint8_t id : ids) {
    auto command = RtcCommandFromId(id);
    ASSERT_TRUE(command.has_value()) << "id=" << int{id};
    EXPECT_EQ(static_cast<uint8_t>(*command), id);
    EXPECT_STRNE(RtcCommandName(*command), "unknown");
  }
  int known = 0;
  for (int id = 0; id < 256; ++id) known += RtcCommandFromId(static_cast<uint8_t>(id)) ? 1 : 0;
  EXPECT_EQ(known, static_cast<int>(ids.size()));
}

TEST(RtcCommandFromId, UnlistedIds_Nullopt) {
  for (uint8_t id : {0x01, 0x18, 0x24, 0x37, 0x42, 0x56, 0x63, 0x75, 0x8F, 0xFF}) {
    EXPECT_FALSE(RtcCommandFromId(id).has_value()) << "id=" << int{id};
  }
}

TEST(RtcCommandName, ManualWording) {
  EXPECT_STREQ(RtcCommandName(RtcCommand::kReadRamValueByUpid),
               "Read RAM Value of Parameter by UPID");
  EXPECT_STREQ(RtcCommandName(RtcCommand::kCommandTableSaveToFlash),
               "Command Table: Save to Flash");
}

TEST(RtcStatusText, EveryStatusOfSection52_Named) {
  for (uint8_t s : {0x00, 0x02, 0x04, 0x05, 0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xD0, 0xD1, 0xD4}) {
    EXPECT_STRNE(RtcStatusText(s), "unknown status") << "status=" << int{s};
  }
  EXPECT_STREQ(RtcStatusText(0xC2), "Range Error");
  EXPECT_STREQ(RtcStatusText(0x01), "unknown status");
  EXPECT_STREQ(RtcStatusText(0xC4), "unknown status");
}

TEST(RtcStatus, BusyAndErrorClasses) {
  EXPECT_TRUE(IsRtcBusy(kRtcStatusCommandRunning));
  EXPECT_TRUE(IsRtcBusy(kRtcStatusBusy));
  EXPECT_FALSE(IsRtcBusy(kRtcStatusDone));
  EXPECT_FALSE(IsRtcBusy(kRtcStatusBlockAccepted));
  EXPECT_FALSE(IsRtcError(kRtcStatusBlockAccepted));
  EXPECT_TRUE(IsRtcError(kRtcStatusUpidError));
  EXPECT_TRUE(IsRtcError(kRtcStatusCurveDefinedOrMissing));
}

}  // namespace
}  // namespace drivegw::linmot::linudp
