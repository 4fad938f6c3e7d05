// SdoClientTransfer and SdoServer wired together in memory (CiA 301 §7.2.4.3), and each of them
// against hand-made peers for toggle errors, wrong multiplexer echoes, aborts and timeouts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <numeric>

#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {
namespace {

using ::testing::HasSubstr;
using transport::CanFrame;
using transport::FormatCanFrame;
using Bytes = std::vector<uint8_t>;

// A tiny object dictionary: 1008h:00 read-only, 2000h:xx read-write, 6061h write-only.
class FakeObjects : public ObjectAccess {
 public:
  absl::StatusOr<Bytes> Read(uint16_t index, uint8_t sub) override {
    ++reads;
    if (index == 0x6061) return SdoAbortStatus(SdoAbortCode::kWriteOnly, "6061h");
    auto it = objects.find({index, sub});
    if (it == objects.end()) return absl::NotFoundError("no such object");
    return it->second;
  }
  absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) override {
    ++writes;
    if (index == 0x1008) return SdoAbortStatus(SdoAbortCode::kReadOnly, "1008h");
    if (index == 0x6040 && !data.empty() && data[0] > 0x8F) return absl::OutOfRangeError("cw");
    objects[{index, sub}] = Bytes(data.begin(), data.end());
    return absl::OkStatus();
  }
  std::map<std::pair<uint16_t, uint8_t>, Bytes> objects;
  int reads = 0;
  int writes = 0;
};

Bytes Pattern(size_t n) {
  Bytes b(n);
  std::iota(b.begin(), b.end(), uint8_t{0x10});
  return b;
}

CanFrame Resp(uint16_t id, const SdoFrame& f) {
  auto frame = ToCanFrame(f, SdoDirection::kResponse, SdoChannel{5, 0x605, id});
  EXPECT_TRUE(frame.ok()) << frame.status();
  return *frame;
}

class SdoTransferTest : public ::testing::Test {
 protected:
  // Runs the client against the server until it finishes; counts frames both ways.
  SdoStep Run(SdoClientTransfer& client) {
    CanFrame request = client.Start();
    for (int guard = 0; guard < 10000; ++guard) {
      ++requests;
      EXPECT_EQ(request.id, 0x605u);
      EXPECT_EQ(request.dlc, 8);
      auto response = server.OnFrame(request);
      if (!response) return {};
      ++responses;
      EXPECT_EQ(response->id, 0x585u);
      SdoStep step = client.OnFrame(*response);
      if (step.kind != SdoStep::Kind::kSend) return step;
      request = *step.frame;
    }
    ADD_FAILURE() << "transfer does not end";
    return {};
  }

  SdoChannel channel = DefaultSdoChannel(5).value();
  FakeObjects objects;
  SdoServer server{channel, objects};
  int requests = 0;
  int responses = 0;
};

// Frames per transfer: expedited 1 exchange; segmented 1 + ceil(n / 7), at least one segment.
int ExpectedExchanges(size_t n) {
  if (n >= 1 && n <= 4) return 1;
  return 1 + static_cast<int>(std::max<size_t>(1, (n + 6) / 7));
}

TEST_F(SdoTransferTest, DownloadThenUploadEverySize) {
  for (size_t n : {0, 1, 4, 5, 7, 8, 100}) {
    SCOPED_TRACE(n);
    requests = responses = 0;
    const Bytes data = Pattern(n);
    auto down = SdoClientTransfer::Download(channel, 0x2000, static_cast<uint8_t>(n), data);
    SdoStep step = Run(down);
    ASSERT_EQ(step.kind, SdoStep::Kind::kDone) << step.status;
    EXPECT_TRUE(down.finished());
    EXPECT_EQ((objects.objects[{0x2000, static_cast<uint8_t>(n)}]), data);
    EXPECT_EQ(requests, ExpectedExchanges(n));
    EXPECT_EQ(responses, requests);
    EXPECT_FALSE(server.busy());

    requests = responses = 0;
    auto up = SdoClientTransfer::Upload(channel, 0x2000, static_cast<uint8_t>(n));
    step = Run(up);
    ASSERT_EQ(step.kind, SdoStep::Kind::kDone) << step.status;
    EXPECT_EQ(step.data, data);
    EXPECT_EQ(requests, ExpectedExchanges(n));
    EXPECT_FALSE(server.busy());
    // A late duplicate is not for the finished transfer.
    EXPECT_EQ(up.OnFrame(Resp(0x585, UploadSegment(false, {}, true))).kind,
              SdoStep::Kind::kIgnored);
  }
}

TEST_F(SdoTransferTest, ExpeditedDownloadIsByteExact) {
  const Bytes cw = {0x0F, 0x00};
  auto down = SdoClientTransfer::Download(channel, 0x6040, 0, cw);
  const CanFrame first = down.Start();
  EXPECT_EQ(FormatCanFrame(first), "605#2B4060000F000000");
  auto response = server.OnFrame(first);
  ASSERT_TRUE(response);
  EXPECT_EQ(FormatCanFrame(*response), "585#6040600000000000");
  EXPECT_EQ(down.OnFrame(*response).kind, SdoStep::Kind::kDone);
}

TEST_F(SdoTransferTest, SegmentedUploadIsByteExact) {
  objects.objects[{0x1008, 0}] = Bytes{'S', 'D', '6', ' ', 'd', 'r', 'i', 'v', 'e'};
  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  std::vector<std::string> wire;
  CanFrame request = up.Start();
  SdoStep step;
  do {
    wire.push_back(FormatCanFrame(request));
    auto response = server.OnFrame(request);
    ASSERT_TRUE(response);
    wire.push_back(FormatCanFrame(*response));
    step = up.OnFrame(*response);
    if (step.frame) request = *step.frame;
  } while (step.kind == SdoStep::Kind::kSend);
  ASSERT_EQ(step.kind, SdoStep::Kind::kDone);
  EXPECT_THAT(wire, ::testing::ElementsAre("605#4008100000000000", "585#4108100009000000",
                                           "605#6000000000000000", "585#0053443620647269",
                                           "605#7000000000000000", "585#1B76650000000000"));
}

TEST_F(SdoTransferTest, ServerAbortFailsTheClientNamingTheCode) {
  auto up = SdoClientTransfer::Upload(channel, 0x2FFF, 0);
  SdoStep step = Run(up);
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_FALSE(step.frame.has_value());  // the server aborted; nothing to send back
  EXPECT_EQ(step.status.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(step.status.message(),
            "sdo upload 0x2FFF:00 node 5: server aborted: SDO abort 0x06020000 object does not "
            "exist in the object dictionary");
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kNoObject);

  auto ro = SdoClientTransfer::Download(channel, 0x1008, 0, Pattern(12));
  step = Run(ro);
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kReadOnly);
  EXPECT_THAT(step.status.message(), HasSubstr("attempt to write a read only object"));
  EXPECT_FALSE(server.busy());

  auto range = SdoClientTransfer::Download(channel, 0x6040, 0, Bytes{0xFF, 0x00});
  step = Run(range);
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_THAT(step.status.message(),
              HasSubstr("SDO abort 0x06090030 value range of parameter exceeded"));
  EXPECT_EQ(step.status.code(), absl::StatusCode::kOutOfRange);

  auto wo = SdoClientTransfer::Upload(channel, 0x6061, 0);
  step = Run(wo);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kWriteOnly);
}

TEST_F(SdoTransferTest, ClientAbortsAWrongToggleWith05030000) {
  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  up.Start();
  SdoStep step = up.OnFrame(Resp(0x585, InitiateUploadSegmented(0x1008, 0, 20)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kSend);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#6000000000000000");
  step = up.OnFrame(Resp(0x585, UploadSegment(false, Pattern(7), false)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kSend);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#7000000000000000");
  // The server repeats toggle 0 where 1 is due.
  step = up.OnFrame(Resp(0x585, UploadSegment(false, Pattern(7), false)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  ASSERT_TRUE(step.frame);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8008100000000305");
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kToggleBit);
  EXPECT_THAT(step.status.message(), HasSubstr("toggle bit not alternated"));
  EXPECT_TRUE(up.finished());
}

// The master's retry (decision 1481): Start() after a time-out is a new transfer from the
// initiate — toggle 0 again, no bytes kept, no announced size kept from the timed-out try.
TEST_F(SdoTransferTest, StartAfterATimeoutBeginsTheTransferAgain) {
  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  EXPECT_EQ(FormatCanFrame(up.Start()), "605#4008100000000000");
  ASSERT_EQ(up.OnFrame(Resp(0x585, InitiateUploadSegmented(0x1008, 0, 20))).kind,
            SdoStep::Kind::kSend);
  ASSERT_EQ(up.OnFrame(Resp(0x585, UploadSegment(false, Pattern(7), false))).kind,
            SdoStep::Kind::kSend);
  ASSERT_EQ(up.Timeout().kind, SdoStep::Kind::kFailed);  // the 2nd segment never came

  EXPECT_EQ(FormatCanFrame(up.Start()), "605#4008100000000000");
  EXPECT_FALSE(up.finished());
  // This time the server indicates no size and sends 3 bytes in one segment.
  SdoFrame unsized = InitiateUploadSegmented(0x1008, 0, 0);
  unsized.size_indicated = false;
  SdoStep step = up.OnFrame(Resp(0x585, unsized));
  ASSERT_EQ(step.kind, SdoStep::Kind::kSend);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#6000000000000000");  // toggle 0 again
  step = up.OnFrame(Resp(0x585, UploadSegment(false, Pattern(3), true)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kDone) << step.status;
  EXPECT_EQ(step.data, Pattern(3));
}

TEST_F(SdoTransferTest, ClientAbortsAWrongDownloadSegmentToggle) {
  auto down = SdoClientTransfer::Download(channel, 0x2000, 1, Pattern(10));
  down.Start();
  SdoStep step = down.OnFrame(Resp(0x585, InitiateDownloadResponse(0x2000, 1)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kSend);
  step = down.OnFrame(Resp(0x585, DownloadSegmentResponse(true)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8000200100000305");
}

TEST_F(SdoTransferTest, ServerAbortsAWrongToggleWith05030000) {
  const CanFrame init =
      *ToCanFrame(InitiateDownloadSegmented(0x2000, 2, 14), SdoDirection::kRequest, channel);
  ASSERT_EQ(FormatCanFrame(*server.OnFrame(init)), "585#6000200200000000");
  const CanFrame bad =
      *ToCanFrame(DownloadSegment(true, Pattern(7), false), SdoDirection::kRequest, channel);
  auto abort = server.OnFrame(bad);
  ASSERT_TRUE(abort);
  EXPECT_EQ(FormatCanFrame(*abort), "585#8000200200000305");
  EXPECT_FALSE(server.busy());
  EXPECT_EQ(objects.writes, 0);

  // Upload side: the second segment request repeats toggle 0.
  objects.objects[{0x2000, 3}] = Pattern(20);
  server.OnFrame(*ToCanFrame(InitiateUploadRequest(0x2000, 3), SdoDirection::kRequest, channel));
  const CanFrame t0 = *ToCanFrame(UploadSegmentRequest(false), SdoDirection::kRequest, channel);
  ASSERT_EQ(server.OnFrame(t0)->data[0] & 0xE0, 0x00);
  EXPECT_EQ(FormatCanFrame(*server.OnFrame(t0)), "585#8000200300000305");
}

TEST_F(SdoTransferTest, WrongIndexEchoIsAborted) {
  auto up = SdoClientTransfer::Upload(channel, 0x6041, 0);
  up.Start();
  SdoStep step = up.OnFrame(Resp(0x585, InitiateUploadExpedited(0x6040, 0, Bytes{0x37, 0x06})));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  ASSERT_TRUE(step.frame);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8041600043000406");
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kParameterIncompatible);
  EXPECT_THAT(step.status.message(), HasSubstr("response names 0x6040:00"));

  auto down = SdoClientTransfer::Download(channel, 0x6040, 0, Bytes{0x06, 0x00});
  down.Start();
  step = down.OnFrame(Resp(0x585, InitiateDownloadResponse(0x6040, 1)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kParameterIncompatible);
}

TEST_F(SdoTransferTest, UnexpectedCommandAndSizeMismatchAreAborted) {
  auto down = SdoClientTransfer::Download(channel, 0x6040, 0, Bytes{0x06, 0x00});
  down.Start();
  SdoStep step = down.OnFrame(Resp(0x585, UploadSegment(false, Pattern(3), true)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kInvalidCommand);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8040600001000405");

  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  up.Start();
  up.OnFrame(Resp(0x585, InitiateUploadSegmented(0x1008, 0, 10)));
  step = up.OnFrame(Resp(0x585, UploadSegment(false, Pattern(7), true)));
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kLengthMismatch);

  auto big = SdoClientTransfer::Upload(channel, 0x1008, 0, /*max_size=*/16);
  big.Start();
  step = big.OnFrame(Resp(0x585, InitiateUploadSegmented(0x1008, 0, 17)));
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kOutOfMemory);

  auto cs7 = SdoClientTransfer::Upload(channel, 0x1008, 0);
  cs7.Start();
  CanFrame junk = Resp(0x585, InitiateDownloadResponse(0x1008, 0));
  junk.data[0] = 0xE0;
  step = cs7.OnFrame(junk);
  EXPECT_EQ(AbortCodeOf(step.status), SdoAbortCode::kInvalidCommand);
}

TEST_F(SdoTransferTest, ForeignFramesAreIgnored) {
  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  up.Start();
  EXPECT_EQ(up.OnFrame(Resp(0x586, InitiateUploadExpedited(0x1008, 0, Bytes{1}))).kind,
            SdoStep::Kind::kIgnored);
  CanFrame short_frame = Resp(0x585, InitiateUploadExpedited(0x1008, 0, Bytes{1}));
  short_frame.dlc = 4;
  EXPECT_EQ(up.OnFrame(short_frame).kind, SdoStep::Kind::kIgnored);
  EXPECT_FALSE(server.OnFrame(short_frame).has_value());
  EXPECT_FALSE(server.OnFrame(Resp(0x585, InitiateUploadRequest(0x1008, 0))).has_value());
  EXPECT_EQ(up.OnFrame(Resp(0x585, InitiateUploadExpedited(0x1008, 0, Bytes{1}))).kind,
            SdoStep::Kind::kDone);
}

TEST_F(SdoTransferTest, TimeoutsProduceTheTimeoutAbort) {
  auto up = SdoClientTransfer::Upload(channel, 0x1008, 0);
  EXPECT_EQ(up.Timeout().kind, SdoStep::Kind::kIgnored);  // not started
  up.Start();
  SdoStep step = up.Timeout();
  ASSERT_EQ(step.kind, SdoStep::Kind::kFailed);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8008100000000405");
  EXPECT_EQ(step.status.code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(step.status.message(), HasSubstr("SDO abort 0x05040000 SDO protocol timed out"));
  EXPECT_EQ(up.Timeout().kind, SdoStep::Kind::kIgnored);

  EXPECT_FALSE(server.Timeout().has_value());
  server.OnFrame(
      *ToCanFrame(InitiateDownloadSegmented(0x2000, 9, 30), SdoDirection::kRequest, channel));
  ASSERT_TRUE(server.busy());
  auto abort = server.Timeout();
  ASSERT_TRUE(abort);
  EXPECT_EQ(FormatCanFrame(*abort), "585#8000200900000405");
  EXPECT_FALSE(server.busy());

  auto cancelled = SdoClientTransfer::Download(channel, 0x2000, 1, Pattern(3));
  cancelled.Start();
  step = cancelled.Cancel(SdoAbortCode::kGeneral);
  EXPECT_EQ(FormatCanFrame(*step.frame), "605#8000200100000008");
}

TEST_F(SdoTransferTest, ServerRefusesBlockAndOrphanSegmentsAndHonoursClientAbort) {
  auto req = [&](const std::vector<uint8_t>& b) { return transport::MakeCanFrame(0x605, b); };
  EXPECT_EQ(FormatCanFrame(*server.OnFrame(req({0xC6, 0x00, 0x20, 0x01, 0x10, 0, 0, 0}))),
            "585#8000200101000405");
  EXPECT_EQ(FormatCanFrame(*server.OnFrame(req({0xA0, 0x00, 0x20, 0x01, 0x7F, 0, 0, 0}))),
            "585#8000200101000405");
  EXPECT_EQ(FormatCanFrame(*server.OnFrame(req({0xE0, 0x00, 0x20, 0x04, 0, 0, 0, 0}))),
            "585#8000200401000405");
  EXPECT_EQ(FormatCanFrame(*server.OnFrame(req({0x60, 0, 0, 0, 0, 0, 0, 0}))).substr(0, 6),
            "585#80");
  EXPECT_EQ(server.OnFrame(req({0x00, 1, 2, 3, 4, 5, 6, 7}))->data[7], 0x05);

  // A client abort mid-download: no answer, the server drops the transfer.
  server.OnFrame(
      *ToCanFrame(InitiateDownloadSegmented(0x2000, 1, 30), SdoDirection::kRequest, channel));
  ASSERT_TRUE(server.busy());
  EXPECT_FALSE(server
                   .OnFrame(*ToCanFrame(AbortFrame(0x2000, 1, SdoAbortCode::kGeneral),
                                        SdoDirection::kRequest, channel))
                   .has_value());
  EXPECT_FALSE(server.busy());

  // A new initiate abandons a transfer in progress (decision 1105).
  server.OnFrame(
      *ToCanFrame(InitiateDownloadSegmented(0x2000, 1, 30), SdoDirection::kRequest, channel));
  auto again = SdoClientTransfer::Download(channel, 0x2000, 7, Pattern(9));
  ASSERT_EQ(Run(again).kind, SdoStep::Kind::kDone);
  EXPECT_EQ((objects.objects[{0x2000, 7}]), Pattern(9));
}

TEST_F(SdoTransferTest, ServerLimitsDownloadSizeAndChecksAnnouncedLength) {
  FakeObjects small_objects;
  SdoServer small(channel, small_objects, 16);
  auto too_big = SdoClientTransfer::Download(channel, 0x2000, 1, Pattern(17));
  CanFrame f = too_big.Start();
  auto r = small.OnFrame(f);
  EXPECT_EQ(FormatCanFrame(*r), "585#8000200105000405");

  // Announced 10, the last segment after 7.
  ASSERT_TRUE(server.OnFrame(
      *ToCanFrame(InitiateDownloadSegmented(0x2000, 1, 10), SdoDirection::kRequest, channel)));
  auto mismatch = server.OnFrame(
      *ToCanFrame(DownloadSegment(false, Pattern(7), true), SdoDirection::kRequest, channel));
  EXPECT_EQ(FormatCanFrame(*mismatch), "585#8000200110000706");
  EXPECT_EQ(objects.writes, 0);
}

}  // namespace
}  // namespace drivegw::canopen
