// SDO frames byte for byte, every command specifier of CiA 301 §7.2.4.3 in both directions, and
// the abort codes of Table 22.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {
namespace {

using ::testing::HasSubstr;
using Bytes = std::array<uint8_t, 8>;

constexpr SdoDirection kReq = SdoDirection::kRequest;
constexpr SdoDirection kResp = SdoDirection::kResponse;

Bytes Encode(const SdoFrame& f, SdoDirection d) {
  auto b = EncodeSdo(f, d);
  EXPECT_TRUE(b.ok()) << b.status();
  return b.value_or(Bytes{});
}

std::vector<uint8_t> V(std::initializer_list<uint8_t> b) { return b; }

TEST(SdoFrameTest, InitiateDownloadExpeditedSetsNEAndS) {
  // ccs 1, n = 4 - size, e = 1, s = 1: 2Fh/2Bh/27h/23h for 1..4 bytes.
  EXPECT_EQ(Encode(InitiateDownloadExpedited(0x6060, 0, V({0x01})), kReq),
            (Bytes{0x2F, 0x60, 0x60, 0x00, 0x01, 0, 0, 0}));
  EXPECT_EQ(Encode(InitiateDownloadExpedited(0x6040, 0, V({0x0F, 0x00})), kReq),
            (Bytes{0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0, 0}));
  EXPECT_EQ(Encode(InitiateDownloadExpedited(0x2000, 3, V({1, 2, 3})), kReq),
            (Bytes{0x27, 0x00, 0x20, 0x03, 1, 2, 3, 0}));
  EXPECT_EQ(Encode(InitiateDownloadExpedited(0x607A, 0, V({0x10, 0x27, 0, 0})), kReq),
            (Bytes{0x23, 0x7A, 0x60, 0x00, 0x10, 0x27, 0x00, 0x00}));
}

TEST(SdoFrameTest, SegmentedInitiatesCarryTheSize) {
  EXPECT_EQ(Encode(InitiateDownloadSegmented(0x1008, 0, 20), kReq),
            (Bytes{0x21, 0x08, 0x10, 0x00, 20, 0, 0, 0}));
  EXPECT_EQ(Encode(InitiateUploadSegmented(0x1008, 0, 0x01020304), kResp),
            (Bytes{0x41, 0x08, 0x10, 0x00, 0x04, 0x03, 0x02, 0x01}));
}

TEST(SdoFrameTest, ResponsesAndRequestsWithoutData) {
  EXPECT_EQ(Encode(InitiateDownloadResponse(0x6040, 0), kResp),
            (Bytes{0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(InitiateUploadRequest(0x6041, 0), kReq),
            (Bytes{0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(DownloadSegmentResponse(false), kResp), (Bytes{0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(DownloadSegmentResponse(true), kResp), (Bytes{0x30, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(UploadSegmentRequest(false), kReq), (Bytes{0x60, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(UploadSegmentRequest(true), kReq), (Bytes{0x70, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(SdoFrameTest, InitiateUploadExpeditedResponses) {
  EXPECT_EQ(Encode(InitiateUploadExpedited(0x6041, 0, V({0x37, 0x06})), kResp),
            (Bytes{0x4B, 0x41, 0x60, 0x00, 0x37, 0x06, 0, 0}));
  EXPECT_EQ(Encode(InitiateUploadExpedited(0x6061, 0, V({0xFF})), kResp),
            (Bytes{0x4F, 0x61, 0x60, 0x00, 0xFF, 0, 0, 0}));
  EXPECT_EQ(Encode(InitiateUploadExpedited(0x2000, 1, V({1, 2, 3})), kResp),
            (Bytes{0x47, 0x00, 0x20, 0x01, 1, 2, 3, 0}));
  EXPECT_EQ(Encode(InitiateUploadExpedited(0x6064, 0, V({1, 2, 3, 4})), kResp),
            (Bytes{0x43, 0x64, 0x60, 0x00, 1, 2, 3, 4}));
}

TEST(SdoFrameTest, SegmentsCarryToggleNAndC) {
  // ccs 0 / scs 0: t bit 4, n bits 3..1 = 7 - size, c bit 0.
  EXPECT_EQ(Encode(DownloadSegment(false, V({1, 2, 3, 4, 5, 6, 7}), false), kReq),
            (Bytes{0x00, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(Encode(DownloadSegment(true, V({8, 9, 10}), true), kReq),
            (Bytes{0x19, 8, 9, 10, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(UploadSegment(true, V({1, 2, 3, 4, 5, 6, 7}), false), kResp),
            (Bytes{0x10, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(Encode(UploadSegment(false, V({0x41}), true), kResp),
            (Bytes{0x0D, 0x41, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Encode(UploadSegment(true, {}, true), kResp), (Bytes{0x1F, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(SdoFrameTest, AbortBothDirections) {
  const Bytes wire = {0x80, 0x40, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06};
  EXPECT_EQ(Encode(AbortFrame(0x6040, 0, SdoAbortCode::kValueRange), kReq), wire);
  EXPECT_EQ(Encode(AbortFrame(0x6040, 0, SdoAbortCode::kValueRange), kResp), wire);
  auto f = DecodeSdo(wire, kResp);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->command, SdoCommand::kAbort);
  EXPECT_EQ(f->index, 0x6040);
  EXPECT_EQ(f->abort_code, 0x06090030u);
}

TEST(SdoFrameTest, DecodeDistinguishesDirections) {
  // 0x60 is an upload segment request (ccs 3) but an initiate download response (scs 3).
  const Bytes b = {0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0};
  EXPECT_EQ(DecodeSdo(b, kReq)->command, SdoCommand::kUploadSegment);
  EXPECT_EQ(DecodeSdo(b, kResp)->command, SdoCommand::kInitiateDownload);
  // 0x20: download segment response (scs 1) vs segmented initiate download without size.
  const Bytes c = {0x20, 0x00, 0x20, 0x01, 0, 0, 0, 0};
  EXPECT_EQ(DecodeSdo(c, kResp)->command, SdoCommand::kDownloadSegment);
  auto init = DecodeSdo(c, kReq);
  EXPECT_EQ(init->command, SdoCommand::kInitiateDownload);
  EXPECT_FALSE(init->expedited);
  EXPECT_FALSE(init->size_indicated);
}

TEST(SdoFrameTest, DecodesDataSizes) {
  auto exp = DecodeSdo(Bytes{0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0xAA, 0xBB}, kReq);
  ASSERT_TRUE(exp.ok());
  EXPECT_TRUE(exp->expedited);
  EXPECT_EQ(std::vector<uint8_t>(exp->bytes().begin(), exp->bytes().end()), V({0x0F, 0x00}));
  // e = 1, s = 0: size unspecified, all four bytes (decision 1102).
  auto unsized = DecodeSdo(Bytes{0x42, 0x41, 0x60, 0x00, 1, 2, 3, 4}, kResp);
  ASSERT_TRUE(unsized.ok());
  EXPECT_EQ(unsized->data_size, 4);
  auto seg = DecodeSdo(Bytes{0x0B, 1, 2, 0xEE, 0xEE, 0xEE, 0xEE, 0xEE}, kResp);
  ASSERT_TRUE(seg.ok());
  EXPECT_EQ(seg->data_size, 2);
  EXPECT_TRUE(seg->last);
  EXPECT_FALSE(seg->toggle);
}

TEST(SdoFrameTest, BlockAndUnknownCommandSpecifiers) {
  EXPECT_EQ(DecodeSdo(Bytes{0xA0, 0x00, 0x10, 0x01, 0, 0, 0, 0}, kReq)->command,
            SdoCommand::kBlockUpload);
  EXPECT_EQ(DecodeSdo(Bytes{0xC6, 0x00, 0x10, 0x01, 0, 0, 0, 0}, kReq)->command,
            SdoCommand::kBlockDownload);
  EXPECT_EQ(DecodeSdo(Bytes{0xA4, 0x00, 0x10, 0x01, 0, 0, 0, 0}, kResp)->command,
            SdoCommand::kBlockDownload);
  EXPECT_EQ(DecodeSdo(Bytes{0xC4, 0x00, 0x10, 0x01, 0, 0, 0, 0}, kResp)->command,
            SdoCommand::kBlockUpload);
  EXPECT_EQ(DecodeSdo(Bytes{0xE0, 0, 0, 0, 0, 0, 0, 0}, kReq).status().message(),
            "canopen sdo request.command_specifier: 7 is unknown (0..6)");
  const std::vector<uint8_t> five = {0x40, 0, 0x10, 0, 0};
  EXPECT_EQ(DecodeSdo(five, kReq).status().message(), "canopen sdo frame: 5 bytes, need 8");
  SdoFrame block;
  block.command = SdoCommand::kBlockDownload;
  EXPECT_THAT(EncodeSdo(block, kReq).status().message(), HasSubstr("decision 1101"));
}

TEST(SdoFrameTest, EncodeRefusesImpossibleData) {
  SdoFrame f = InitiateDownloadExpedited(0x6040, 0, V({1}));
  f.data_size = 0;
  EXPECT_THAT(EncodeSdo(f, kReq).status().message(), HasSubstr("outside 1..4"));
  f.data_size = 5;
  EXPECT_FALSE(EncodeSdo(f, kReq).ok());
  SdoFrame s = DownloadSegment(false, {}, true);
  s.data_size = 8;
  EXPECT_THAT(EncodeSdo(s, kReq).status().message(), HasSubstr("8 bytes exceed 7"));
}

TEST(SdoFrameTest, ToCanFrameUsesTheChannelIds) {
  auto ch = DefaultSdoChannel(5);
  ASSERT_TRUE(ch.ok());
  EXPECT_EQ(ch->request_id, 0x605);
  EXPECT_EQ(ch->response_id, 0x585);
  auto req = ToCanFrame(InitiateUploadRequest(0x1000, 0), kReq, *ch);
  EXPECT_EQ(transport::FormatCanFrame(*req), "605#4000100000000000");
  auto resp = ToCanFrame(InitiateDownloadResponse(0x1000, 0), kResp, *ch);
  EXPECT_EQ(transport::FormatCanFrame(*resp), "585#6000100000000000");
  EXPECT_FALSE(DefaultSdoChannel(0).ok());
}

TEST(SdoAbortTest, NamesAndTableCompleteness) {
  EXPECT_EQ(AbortCodeName(SdoAbortCode::kValueRange),
            "SDO abort 0x06090030 value range of parameter exceeded");
  EXPECT_EQ(AbortCodeName(SdoAbortCode::kToggleBit),
            "SDO abort 0x05030000 toggle bit not alternated");
  EXPECT_EQ(AbortCodeName(static_cast<SdoAbortCode>(0x12345678)),
            "SDO abort 0x12345678 unknown abort code");
  std::set<uint32_t> seen;
  for (SdoAbortCode c : AllAbortCodes()) {
    EXPECT_NE(AbortCodeDescription(c), "unknown abort code") << std::hex << uint32_t(c);
    EXPECT_TRUE(IsKnownAbortCode(static_cast<uint32_t>(c)));
    seen.insert(static_cast<uint32_t>(c));
  }
  EXPECT_EQ(seen.size(), 31u);
  for (uint32_t c :
       {0x05030000u, 0x05040000u, 0x05040001u, 0x06010000u, 0x06010001u, 0x06010002u, 0x06020000u,
        0x06040041u, 0x06040042u, 0x06040043u, 0x06040047u, 0x06060000u, 0x06070010u, 0x06070012u,
        0x06070013u, 0x06090011u, 0x06090030u, 0x06090031u, 0x06090032u, 0x06090036u, 0x060A0023u,
        0x08000000u, 0x08000020u, 0x08000021u, 0x08000022u, 0x08000023u, 0x08000024u}) {
    EXPECT_EQ(seen.count(c), 1u) << std::hex << c;
  }
  EXPECT_FALSE(IsKnownAbortCode(0));
}

TEST(SdoAbortTest, StatusCarriesTheCodeAndMapsToAbslCodes) {
  const absl::Status s = SdoAbortStatus(SdoAbortCode::kNoObject, "sdo upload 0x2000:00");
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(s.message(),
            "sdo upload 0x2000:00: SDO abort 0x06020000 object does not exist in the object "
            "dictionary");
  EXPECT_EQ(AbortCodeOf(s), SdoAbortCode::kNoObject);
  EXPECT_EQ(AbortCodeOf(absl::NotFoundError("x")), std::nullopt);
  struct Row {
    SdoAbortCode code;
    absl::StatusCode status;
  };
  const Row rows[] = {
      {SdoAbortCode::kTimeout, absl::StatusCode::kDeadlineExceeded},
      {SdoAbortCode::kNoSubIndex, absl::StatusCode::kNotFound},
      {SdoAbortCode::kReadOnly, absl::StatusCode::kPermissionDenied},
      {SdoAbortCode::kValueTooHigh, absl::StatusCode::kOutOfRange},
      {SdoAbortCode::kMaxLessThanMin, absl::StatusCode::kOutOfRange},
      {SdoAbortCode::kLengthTooLow, absl::StatusCode::kInvalidArgument},
      {SdoAbortCode::kNotMappable, absl::StatusCode::kInvalidArgument},
      {SdoAbortCode::kOutOfMemory, absl::StatusCode::kResourceExhausted},
      {SdoAbortCode::kDeviceState, absl::StatusCode::kFailedPrecondition},
      {SdoAbortCode::kToggleBit, absl::StatusCode::kAborted},
      {SdoAbortCode::kGeneral, absl::StatusCode::kAborted},
  };
  for (const Row& r : rows) {
    EXPECT_EQ(SdoAbortStatus(r.code, "").code(), r.status) << AbortCodeName(r.code);
  }
  // Server side: plain statuses map to abort codes (decision 1104).
  EXPECT_EQ(AbortCodeForStatus(absl::NotFoundError("")), SdoAbortCode::kNoObject);
  EXPECT_EQ(AbortCodeForStatus(absl::PermissionDeniedError("")), SdoAbortCode::kUnsupportedAccess);
  EXPECT_EQ(AbortCodeForStatus(absl::OutOfRangeError("")), SdoAbortCode::kValueRange);
  EXPECT_EQ(AbortCodeForStatus(absl::FailedPreconditionError("")), SdoAbortCode::kDeviceState);
  EXPECT_EQ(AbortCodeForStatus(absl::InternalError("")), SdoAbortCode::kGeneral);
  EXPECT_EQ(AbortCodeForStatus(SdoAbortStatus(SdoAbortCode::kWriteOnly, "")),
            SdoAbortCode::kWriteOnly);
}

}  // namespace
}  // namespace drivegw::canopen
