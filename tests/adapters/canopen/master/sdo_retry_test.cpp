// CanopenMaster bounded SDO retry (decision 1481) against in-test nodes on the UDP bus: exactly
// one lost request or answer is repeated after the 0504 0000h abort, a non-idempotent download
// is not, exhausted retries end with the error naming object and node, a late answer to an
// earlier try is not taken for the next transfer's, and without loss every transfer still takes
// one request frame.
#include <algorithm>
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
using ::testing::Not;

struct Bench {
  Bench(Duration timeout, int retries, uint8_t id = 5) : bus(UniqueBus()) {
    node = TestNode::Start(bus, id);
    EXPECT_NE(node, nullptr);
    MasterOptions o;
    o.sdo_timeout = timeout;
    o.sdo_retries = retries;
    auto m = CanopenMaster::Open(bus, o);
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *m;
  }
  CanBusConfig bus;
  std::unique_ptr<TestNode> node;
  std::shared_ptr<CanopenMaster> master;
};

// The first byte of each request frame the node saw on 600h + id.
std::vector<uint8_t> Commands(const TestNode& node, uint32_t id) {
  std::vector<uint8_t> out;
  for (const auto& f : node.frames_with_id(id)) out.push_back(f.data[0]);
  return out;
}

TEST(CanopenMasterSdoRetry, NoLossOneRequestFramePerTransfer) {
  Bench b(100ms, 2);
  ASSERT_NE(b.master, nullptr);
  b.node->Set(0x6041, 0, {0x37, 0x02});
  b.node->Set(0x1000, 0, {0x92, 0x01, 0x02, 0x00});
  ASSERT_TRUE(b.master->ReadU16(5, 0x6041, 0, Far()).ok());
  ASSERT_TRUE(b.master->ReadU32(5, 0x1000, 0, Far()).ok());
  ASSERT_TRUE(b.master->WriteU16(5, 0x1017, 0, 100, Far(), SdoRetry::kIdempotent).ok());
  ASSERT_TRUE(b.master->ConfigureErrorBehaviour(5, ErrorBehaviour::kPreOperational, Far()).ok());
  // The protocol minimum: one request per expedited transfer, nothing else (bench P3).
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x605).size() >= 4; }));
  std::this_thread::sleep_for(150ms);  // longer than sdo_timeout: no retry may follow
  EXPECT_THAT(Commands(*b.node, 0x605), ElementsAre(0x40, 0x40, 0x2B, 0x2F));
  EXPECT_EQ(b.master->counters().sdo_retries, 0u);
  EXPECT_EQ(b.master->counters().sdo_aborts_sent, 0u);
}

TEST(CanopenMasterSdoRetry, LostRequestIsRepeatedAfterTheAbort) {
  Bench b(100ms, 2);
  ASSERT_NE(b.master, nullptr);
  b.node->Set(0x6041, 0, {0x37, 0x02});
  b.node->DropRequests(1);
  auto r = b.master->ReadU16(5, 0x6041, 0, Far());
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(*r, 0x0237);
  // Initiate (lost), abort 0504 0000h naming the object, the initiate again.
  const auto frames = b.node->frames_with_id(0x605);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_THAT(frames[0].payload(), ElementsAre(0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0));
  EXPECT_THAT(frames[1].payload(), ElementsAre(0x80, 0x41, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05));
  EXPECT_THAT(frames[2].payload(), ElementsAre(0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0));
  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.sdo_retries, 1u);
  EXPECT_EQ(c.sdo_timeouts, 1u);
  EXPECT_EQ(c.sdo_transfers, 1u);
  EXPECT_EQ(c.sdo_failures, 0u);
}

TEST(CanopenMasterSdoRetry, LostAnswerOfAnIdempotentWriteWritesTheSameValueAgain) {
  Bench b(100ms, 2);
  ASSERT_NE(b.master, nullptr);
  b.node->DropAnswers(1);
  ASSERT_TRUE(b.master->WriteU16(5, 0x1017, 0, 100, Far(), SdoRetry::kIdempotent).ok());
  const auto writes = b.node->writes();
  ASSERT_EQ(writes.size(), 2u);
  EXPECT_EQ(writes[0].data, writes[1].data);
  EXPECT_EQ(*b.node->Get(0x1017, 0), (std::vector<uint8_t>{100, 0}));
  EXPECT_THAT(Commands(*b.node, 0x605), ElementsAre(0x2B, 0x80, 0x2B));
  EXPECT_EQ(b.master->counters().sdo_retries, 1u);
}

TEST(CanopenMasterSdoRetry, DownloadNotMarkedIdempotentIsNotRepeated) {
  Bench b(100ms, 2);
  ASSERT_NE(b.master, nullptr);
  b.node->DropAnswers(1);
  const absl::Status s = b.master->WriteU16(5, 0x1010, 1, 0x6173, Far());
  EXPECT_EQ(s.code(), absl::StatusCode::kDeadlineExceeded) << s;
  EXPECT_THAT(s.message(), HasSubstr("sdo download 0x1010:01 node 5, no response within 100 ms"));
  EXPECT_THAT(s.message(), Not(HasSubstr("tries")));
  EXPECT_EQ(b.node->writes().size(), 1u);
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x605).size() >= 2; }));
  EXPECT_THAT(Commands(*b.node, 0x605), ElementsAre(0x2B, 0x80));
  EXPECT_EQ(b.master->counters().sdo_retries, 0u);
}

TEST(CanopenMasterSdoRetry, ExhaustedRetriesEndWithTheErrorNamingObjectAndNode) {
  Bench b(100ms, 2, 9);
  ASSERT_NE(b.master, nullptr);
  b.node->SetSilent(true);
  auto r = b.master->Upload(9, 0x1017, 0, Far());
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded) << r.status();
  EXPECT_THAT(r.status().message(),
              HasSubstr("sdo upload 0x1017:00 node 9, no response within 100 ms (3 tries)"));
  EXPECT_EQ(AbortCodeOf(r.status()), SdoAbortCode::kTimeout);
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x609).size() >= 6; }));
  EXPECT_THAT(Commands(*b.node, 0x609), ElementsAre(0x40, 0x80, 0x40, 0x80, 0x40, 0x80));
  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.sdo_retries, 2u);
  EXPECT_EQ(c.sdo_timeouts, 3u);
  EXPECT_EQ(c.sdo_failures, 1u);
}

// Node 5 holds its requests: an upload of 6041h runs and an upload of `second` waits behind it.
// Ready once the first was retried (initiate, abort, initiate held): nothing answered yet.
struct TwoUploads {
  TwoUploads(Bench& bench, uint16_t second) : b(bench) {
    b.node->Set(0x6041, 0, {0x37, 0x02});
    b.node->SetHolding(true);
    a = std::thread([this] { first_result = b.master->Upload(5, 0x6041, 0, Far()); });
    ready = WaitFor([&] { return b.node->held() == 1; });
    q = std::thread([this, second] { second_result = b.master->Upload(5, second, 0, Far()); });
    ready = ready && WaitFor([&] { return b.node->held() >= 3; });
  }
  ~TwoUploads() {
    b.node->Release();
    Join();
  }
  void Join() {
    if (a.joinable()) a.join();
    if (q.joinable()) q.join();
  }
  Bench& b;
  bool ready = false;
  std::thread a, q;
  absl::StatusOr<std::vector<uint8_t>> first_result = absl::UnknownError("not run");
  absl::StatusOr<std::vector<uint8_t>> second_result = absl::UnknownError("not run");
};

// The node answers late: the first try's answer arrives after the retry went out. It completes
// the transfer (same object, same value); the retry's answer then arrives while the next
// transfer runs and must neither be taken for its answer nor fail it.
TEST(CanopenMasterSdoRetry, LateAnswerToAnEarlierTryIsNotTakenForTheNextTransfer) {
  Bench b(300ms, 5);
  ASSERT_NE(b.master, nullptr);
  b.node->Set(0x1000, 0, {0x92, 0x01, 0x02, 0x00});
  TwoUploads t(b, 0x1000);
  ASSERT_TRUE(t.ready);
  // Both initiates' answers at once; the second upload's request is held until they are out, so
  // the late answer is on the bus before its own.
  b.node->Release(/*keep_holding=*/true);
  ASSERT_TRUE(WaitFor([&] {
    const auto f = b.node->frames_with_id(0x605);
    return !f.empty() && f.back().data[0] == 0x40 && f.back().data[1] == 0x00 &&
           f.back().data[2] == 0x10;
  }));
  b.node->Release();
  t.Join();
  ASSERT_TRUE(t.first_result.ok()) << t.first_result.status();
  EXPECT_THAT(*t.first_result, ElementsAre(0x37, 0x02));
  ASSERT_TRUE(t.second_result.ok()) << t.second_result.status();
  EXPECT_THAT(*t.second_result, ElementsAre(0x92, 0x01, 0x02, 0x00));
  const MasterCounters c = b.master->counters();
  EXPECT_GE(c.sdo_stale_responses, 1u);
  EXPECT_EQ(c.sdo_failures, 0u);
  EXPECT_EQ(c.sdo_aborts_received, 0u);
}

// The next transfer reads the same object: it waits one sdo_timeout, so the retry's late answer
// arrives while nothing runs (counted as unexpected) instead of answering it.
TEST(CanopenMasterSdoRetry, SameObjectAfterARetryWaitsOutTheLateAnswer) {
  Bench b(300ms, 5);
  ASSERT_NE(b.master, nullptr);
  TwoUploads t(b, 0x6041);
  ASSERT_TRUE(t.ready);
  b.node->Release();
  t.Join();
  ASSERT_TRUE(t.first_result.ok()) << t.first_result.status();
  ASSERT_TRUE(t.second_result.ok()) << t.second_result.status();
  EXPECT_THAT(*t.second_result, ElementsAre(0x37, 0x02));
  // Every initiate was answered: one answer completed the first read, one the second (its own
  // initiate, the last one); all others are late answers to the first read's earlier tries.
  const std::vector<uint8_t> commands = Commands(*b.node, 0x605);
  const auto initiates = std::count(commands.begin(), commands.end(), 0x40);
  ASSERT_GE(initiates, 3);
  EXPECT_EQ(b.master->counters().sdo_unexpected, static_cast<uint64_t>(initiates - 2));
  EXPECT_EQ(b.master->counters().sdo_stale_responses, 0u);
  EXPECT_EQ(b.master->counters().sdo_failures, 0u);
}

}  // namespace
}  // namespace drivegw::canopen::testing
