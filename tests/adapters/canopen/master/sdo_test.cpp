// CanopenMaster SDO client against in-test nodes on the UDP bus: expedited and segmented
// transfers, typed helpers, server aborts, time-outs with the abort frame on the bus, caller
// deadlines, queueing per node, foreign frames, two nodes at once.
#include <string>
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/adapters/canopen/master/test_node.h"

namespace drivegw::canopen::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<uint8_t> Bytes(const std::string& s) { return {s.begin(), s.end()}; }

struct Bench {
  explicit Bench(MasterOptions options = {}, std::vector<uint8_t> ids = {5}) {
    bus = UniqueBus();
    for (uint8_t id : ids) {
      nodes.push_back(TestNode::Start(bus, id));
      EXPECT_NE(nodes.back(), nullptr);
    }
    auto m = CanopenMaster::Open(bus, options);
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *m;
  }
  TestNode& node(size_t i = 0) { return *nodes[i]; }

  CanBusConfig bus;
  std::vector<std::unique_ptr<TestNode>> nodes;
  std::shared_ptr<CanopenMaster> master;
};

TEST(CanopenMasterSdo, ExpeditedUploadAndDownloadWithTypedHelpers) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  b.node().Set(0x6041, 0, {0x37, 0x02});
  b.node().Set(0x1000, 0, {0x92, 0x01, 0x02, 0x00});
  b.node().Set(0x6064, 0, {0xFE, 0xFF, 0xFF, 0xFF});
  b.node().Set(0x6060, 0, {0x01});

  auto raw = b.master->Upload(5, 0x6041, 0, Far());
  ASSERT_TRUE(raw.ok()) << raw.status();
  EXPECT_THAT(*raw, ElementsAre(0x37, 0x02));
  EXPECT_EQ(*b.master->ReadU16(5, 0x6041, 0, Far()), 0x0237);
  EXPECT_EQ(*b.master->ReadU32(5, 0x1000, 0, Far()), 0x00020192u);
  EXPECT_EQ(*b.master->ReadI32(5, 0x6064, 0, Far()), -2);
  EXPECT_EQ(*b.master->ReadU8(5, 0x6060, 0, Far()), 1);

  ASSERT_TRUE(b.master->WriteU16(5, 0x6040, 0, 0x000F, Far()).ok());
  ASSERT_TRUE(b.master->WriteI32(5, 0x607A, 0, -1000, Far()).ok());
  ASSERT_TRUE(b.master->WriteU8(5, 0x6060, 0, 6, Far()).ok());
  ASSERT_TRUE(b.master->WriteU32(5, 0x6081, 0, 123456, Far()).ok());
  const auto writes = b.node().writes();
  ASSERT_EQ(writes.size(), 4u);
  EXPECT_EQ(writes[0], (SdoWrite{0x6040, 0, {0x0F, 0x00}}));
  EXPECT_EQ(writes[1], (SdoWrite{0x607A, 0, {0x18, 0xFC, 0xFF, 0xFF}}));
  EXPECT_EQ(writes[2], (SdoWrite{0x6060, 0, {0x06}}));
  EXPECT_EQ(writes[3], (SdoWrite{0x6081, 0, {0x40, 0xE2, 0x01, 0x00}}));
  // Expedited: one request and one response per transfer (decision 1102).
  EXPECT_EQ(b.node().frames_with_id(0x605).size(), 9u);

  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.sdo_transfers, 9u);
  EXPECT_EQ(c.sdo_failures, 0u);
  EXPECT_GE(c.frames_in, 9u);
  EXPECT_GE(c.frames_out, 9u);
}

TEST(CanopenMasterSdo, TypedReadsCheckTheWidth) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  b.node().Set(0x2000, 0, {0x34, 0x12, 0x00, 0x00});  // zero padding: fine as u16
  b.node().Set(0x2001, 0, {0x34, 0x12, 0x01, 0x00});  // wider than u16
  b.node().Set(0x2002, 0, {0x34});                    // narrower than u16
  EXPECT_EQ(*b.master->ReadU16(5, 0x2000, 0, Far()), 0x1234);
  auto wide = b.master->ReadU16(5, 0x2001, 0, Far());
  EXPECT_EQ(wide.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(wide.status().message(), HasSubstr("0x2001:00 node 5"));
  auto narrow = b.master->ReadU16(5, 0x2002, 0, Far());
  EXPECT_EQ(narrow.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(narrow.status().message(), HasSubstr("1 byte(s), u16 needs 2"));
}

TEST(CanopenMasterSdo, SegmentedUploadAndDownload) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  const std::string name = "STOBER SC6 drive controller";  // 27 bytes: 4 segments
  b.node().Set(0x1008, 0, Bytes(name));
  auto up = b.master->Upload(5, 0x1008, 0, Far());
  ASSERT_TRUE(up.ok()) << up.status();
  EXPECT_EQ(std::string(up->begin(), up->end()), name);

  std::vector<uint8_t> blob(100);
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 7);
  ASSERT_TRUE(b.master->Download(5, 0x2100, 1, blob, Far()).ok());
  EXPECT_EQ(b.node().Get(0x2100, 1), blob);
  // 0 bytes: segmented with size 0 and one empty last segment (decision 1102).
  ASSERT_TRUE(b.master->Download(5, 0x2100, 2, {}, Far()).ok());
  EXPECT_EQ(b.node().Get(0x2100, 2), std::vector<uint8_t>{});
  auto back = b.master->Upload(5, 0x2100, 1, Far());
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, blob);
  // Upload 27 bytes: initiate + 4 segment requests; download 100 bytes: initiate + 15 segments.
  EXPECT_EQ(b.node().frames_with_id(0x605).size(), 5u + 16u + 2u + 16u);
}

TEST(CanopenMasterSdo, ServerAbortCarriesTheCodeName) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  b.node().Set(0x6041, 0, {0, 0}, /*read_only=*/true);
  b.node().AbortOn(0x607A, 0, SdoAbortCode::kValueRange);

  absl::Status ro = b.master->WriteU16(5, 0x6041, 0, 1, Far());
  EXPECT_EQ(ro.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(ro.message(), HasSubstr("sdo download 0x6041:00 node 5"));
  EXPECT_THAT(ro.message(), HasSubstr(AbortCodeName(SdoAbortCode::kReadOnly)));
  EXPECT_EQ(AbortCodeOf(ro), SdoAbortCode::kReadOnly);

  absl::Status range = b.master->WriteI32(5, 0x607A, 0, 1 << 30, Far());
  EXPECT_EQ(range.code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(range.message(), HasSubstr("SDO abort 0x06090030 value range of parameter exceeded"));

  auto missing = b.master->Upload(5, 0x5FFF, 3, Far());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.status().message(), HasSubstr("0x5FFF:03 node 5"));
  EXPECT_EQ(AbortCodeOf(missing.status()), SdoAbortCode::kNoObject);

  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.sdo_aborts_received, 3u);
  EXPECT_EQ(c.sdo_failures, 3u);
  EXPECT_EQ(c.sdo_aborts_sent, 0u);
  // The channel is free again after an abort.
  EXPECT_EQ(*b.master->ReadU16(5, 0x6041, 0, Far()), 0);
}

TEST(CanopenMasterSdo, SilentNodeTimesOutWithAbortFrameOnTheBus) {
  MasterOptions o;
  o.sdo_timeout = 100ms;
  Bench b(o, {9});
  ASSERT_NE(b.master, nullptr);
  b.node().SetSilent(true);
  auto r = b.master->Upload(9, 0x6041, 0, Far());
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded) << r.status();
  EXPECT_THAT(r.status().message(), HasSubstr("sdo upload 0x6041:00 node 9"));
  EXPECT_THAT(r.status().message(), HasSubstr("no response within 100 ms"));
  EXPECT_EQ(AbortCodeOf(r.status()), SdoAbortCode::kTimeout);
  // Initiate upload, then abort 0504 0000h naming the object (CiA 301 §7.2.4.3.17).
  ASSERT_TRUE(WaitFor([&] { return b.node().frames_with_id(0x609).size() == 2; }));
  const auto frames = b.node().frames_with_id(0x609);
  EXPECT_THAT(frames[0].payload(), ElementsAre(0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0));
  EXPECT_THAT(frames[1].payload(), ElementsAre(0x80, 0x41, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05));
  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.sdo_timeouts, 1u);
  EXPECT_EQ(c.sdo_aborts_sent, 1u);

  // The node comes back: the next transfer works.
  b.node().SetSilent(false);
  b.node().Set(0x6041, 0, {0x40, 0x02});
  EXPECT_EQ(*b.master->ReadU16(9, 0x6041, 0, Far()), 0x0240);
}

TEST(CanopenMasterSdo, SegmentTimeoutMidTransfer) {
  MasterOptions o;
  o.sdo_timeout = 100ms;
  Bench b(o);
  ASSERT_NE(b.master, nullptr);
  b.node().Set(0x1008, 0, Bytes("a name longer than four bytes"));
  b.node().SetHolding(true);
  std::thread release([&] {
    // Answer the initiate, then go silent: the first segment request goes unanswered.
    WaitFor([&] { return b.node().held() == 1; });
    b.node().SetSilent(true);
    b.node().Release();
  });
  auto r = b.master->Upload(5, 0x1008, 0, Far());
  release.join();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded);
  ASSERT_TRUE(WaitFor([&] { return b.node().frames_with_id(0x605).size() == 3; }));
  const auto frames = b.node().frames_with_id(0x605);
  EXPECT_EQ(frames[1].data[0], 0x60);  // upload segment request, toggle 0
  EXPECT_EQ(frames[2].data[0], 0x80);  // abort
}

TEST(CanopenMasterSdo, CallerDeadlineDuringTransferAborts) {
  MasterOptions o;
  o.sdo_timeout = 10s;
  Bench b(o);
  ASSERT_NE(b.master, nullptr);
  b.node().SetSilent(true);
  auto r = b.master->Upload(5, 0x6041, 0, SteadyClock::Instance().Now() + 100ms);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(r.status().message(), HasSubstr("caller's deadline passed during the transfer"));
  ASSERT_TRUE(WaitFor([&] { return b.node().frames_with_id(0x605).size() == 2; }));
  EXPECT_EQ(b.node().frames_with_id(0x605)[1].data[0], 0x80);
}

TEST(CanopenMasterSdo, OneTransferPerNodeQueuedAndExpiredInTheQueue) {
  MasterOptions o;
  o.sdo_timeout = 10s;
  Bench b(o);
  ASSERT_NE(b.master, nullptr);
  b.node().Set(0x6041, 0, {0x21, 0x06});
  b.node().SetHolding(true);
  absl::StatusOr<uint16_t> first = absl::UnknownError("not run");
  std::thread t([&] { first = b.master->ReadU16(5, 0x6041, 0, Far()); });
  ASSERT_TRUE(WaitFor([&] { return b.node().held() == 1; }));
  // The channel is busy: this one waits behind it and its deadline passes in the queue. It never
  // reached the bus.
  auto second = b.master->Upload(5, 0x6061, 0, SteadyClock::Instance().Now() + 50ms);
  EXPECT_EQ(second.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(second.status().message(),
              HasSubstr("sdo upload 0x6061:00 node 5: the caller's deadline passed while "
                        "waiting behind 1 transfer(s)"));
  EXPECT_EQ(b.node().held(), 1u);
  b.node().Release();
  t.join();
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(*first, 0x0621);
  EXPECT_EQ(b.node().frames_with_id(0x605).size(), 1u);
}

TEST(CanopenMasterSdo, ForeignAndWrongNodeFramesAreIgnored) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  auto other = transport::OpenCanChannel(b.bus);
  ASSERT_TRUE(other.ok());
  b.node().Set(0x6041, 0, {0x37, 0x02});
  b.node().SetHolding(true);
  absl::StatusOr<uint16_t> r = absl::UnknownError("not run");
  std::thread t([&] { r = b.master->ReadU16(5, 0x6041, 0, Far()); });
  ASSERT_TRUE(WaitFor([&] { return b.node().held() == 1; }));
  const std::vector<uint8_t> wrong_node = {0x4B, 0x41, 0x60, 0x00, 0xFF, 0xFF, 0, 0};
  const std::vector<uint8_t> short_frame = {0x4B, 0x41, 0x60, 0x00, 0xFF};
  ASSERT_TRUE((*other)->Send(transport::MakeCanFrame(0x586, wrong_node)).ok());   // node 6
  ASSERT_TRUE((*other)->Send(transport::MakeCanFrame(0x585, short_frame)).ok());  // DLC 5
  ASSERT_TRUE((*other)->Send(transport::MakeCanFrame(0x205, wrong_node)).ok());   // an RPDO
  ASSERT_TRUE(WaitFor([&] { return b.master->counters().sdo_unexpected >= 2; }));
  b.node().Release();
  t.join();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(*r, 0x0237);
  EXPECT_GE(b.master->counters().other_traffic, 1u);
}

TEST(CanopenMasterSdo, TwoNodesConcurrentlyAndQueuedPerNode) {
  Bench b({}, {5, 6});
  ASSERT_NE(b.master, nullptr);
  for (size_t i = 0; i < 2; ++i) {
    b.node(i).Set(0x1008, 0, Bytes("node " + std::to_string(b.node(i).id()) + " long name"));
    b.node(i).Set(0x6041, 0, {b.node(i).id(), 0x02});
  }
  constexpr int kRounds = 15;
  std::atomic<int> bad{0};
  std::vector<std::thread> threads;
  // Two callers per node: the second always finds the node's channel busy sometimes.
  for (uint8_t id : {5, 6}) {
    for (int caller = 0; caller < 2; ++caller) {
      threads.emplace_back([&, id, caller] {
        for (int i = 0; i < kRounds; ++i) {
          if (caller == 0) {
            auto v = b.master->ReadU16(id, 0x6041, 0, Far());
            if (!v.ok() || *v != (0x0200 | id)) ++bad;
          } else {
            auto s = b.master->Upload(id, 0x1008, 0, Far());
            if (!s.ok() ||
                std::string(s->begin(), s->end()) != "node " + std::to_string(id) + " long name") {
              ++bad;
            }
            std::vector<uint8_t> data(9, static_cast<uint8_t>(i));
            if (!b.master->Download(id, 0x2200, 1, data, Far()).ok()) ++bad;
          }
        }
      });
    }
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(bad.load(), 0);
  // A new initiate never reached a node in the middle of a segmented transfer.
  EXPECT_EQ(b.node(0).overlaps(), 0u);
  EXPECT_EQ(b.node(1).overlaps(), 0u);
  EXPECT_EQ(b.master->counters().sdo_transfers, 2u * 3u * kRounds);
  EXPECT_EQ(b.master->counters().sdo_failures, 0u);
}

TEST(CanopenMasterSdo, BlockingCallsRefusedOnTheReceiveThread) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  RecordingObserver obs;
  absl::Status inside = absl::UnknownError("not called");
  std::atomic<bool> called{false};
  std::atomic<bool> done{false};
  obs.on_heartbeat = [&] {
    if (called.exchange(true)) return;
    inside = b.master->Upload(5, 0x1000, 0, Far()).status();
    done = true;
  };
  ASSERT_TRUE(b.master->AddNodeObserver(5, &obs).ok());
  b.node().SendHeartbeat(NmtState::kPreOperational);
  ASSERT_TRUE(WaitFor([&] { return done.load(); }));
  EXPECT_EQ(inside.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(inside.message(), HasSubstr("receive thread"));
}

TEST(CanopenMasterSdo, InvalidNodeAndStoppedMaster) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  EXPECT_EQ(b.master->Upload(0, 0x1000, 0, Far()).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->Upload(128, 0x1000, 0, Far()).status().code(),
            absl::StatusCode::kInvalidArgument);
  b.master->Stop();
  EXPECT_EQ(b.master->Upload(5, 0x1000, 0, Far()).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace drivegw::canopen::testing
