// CanopenMaster PDO configuration (the exact CiA 301 §7.2.2.4 SDO sequence on the node), TPDO
// reception and RPDO transmission on configured and predefined COB-IDs, and the SYNC producer
// (counter, listeners sending RPDOs right after each SYNC, statistics; ordering, never timing).
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "adapters/canopen/sync.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/adapters/canopen/master/test_node.h"

namespace drivegw::canopen::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

struct Bench {
  Bench() {
    bus = UniqueBus();
    node = TestNode::Start(bus, 5);
    EXPECT_NE(node, nullptr);
    auto m = CanopenMaster::Open(bus);
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *m;
    if (master) {
      EXPECT_TRUE(master->AddNodeObserver(5, &observer).ok());
    }
  }
  CanBusConfig bus;
  std::unique_ptr<TestNode> node;
  std::shared_ptr<CanopenMaster> master;
  RecordingObserver observer;
};

const PdoMapping kStatusAndPosition = {{0x6041, 0, 16}, {0x6064, 0, 32}};

TEST(CanopenMasterPdo, ConfigureTpdoSendsTheExactSequenceAndDeliversTpdos) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  PdoCommParams comm;
  comm.transmission_type = 1;  // every SYNC
  comm.inhibit_time_100us = 10;
  comm.event_timer_ms = 0;
  ASSERT_TRUE(b.master->ConfigurePdo(5, PdoKind::kTpdo, 1, comm, kStatusAndPosition, Far()).ok());
  auto expected = MappingWrites(PdoKind::kTpdo, 1, 5, comm, kStatusAndPosition);
  ASSERT_TRUE(expected.ok());
  EXPECT_EQ(b.node->writes(), *expected);
  ASSERT_EQ(b.node->writes().size(), 9u);
  EXPECT_EQ(b.node->writes().front(), (SdoWrite{0x1800, 1, {0x85, 0x01, 0x00, 0xC0}}));
  EXPECT_EQ(b.node->writes().back(), (SdoWrite{0x1800, 1, {0x85, 0x01, 0x00, 0x40}}));

  const std::vector<PdoValue> values = {{PdoType::kU16, 0x0637}, {PdoType::kI32, -5000}};
  auto payload = PackPdo(kStatusAndPosition, values);
  ASSERT_TRUE(payload.ok());
  b.node->Send(transport::MakeCanFrame(0x185, *payload));
  ASSERT_TRUE(WaitFor([&] { return b.observer.tpdos().size() == 1; }));
  const TpdoEvent e = b.observer.tpdos()[0];
  EXPECT_EQ(e.node, 5);
  EXPECT_EQ(e.number, 1);
  EXPECT_EQ(e.cob_id, 0x185);
  auto decoded =
      UnpackPdo(kStatusAndPosition, std::vector{PdoType::kU16, PdoType::kI32}, e.payload());
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(*decoded, values);
  EXPECT_EQ(b.master->counters().tpdo_received, 1u);
}

TEST(CanopenMasterPdo, ConfiguredCobIdReplacesThePredefinedOne) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  PdoCommParams comm;
  comm.cob_id = 0x1F0;
  ASSERT_TRUE(b.master->ConfigurePdo(5, PdoKind::kTpdo, 2, comm, kStatusAndPosition, Far()).ok());
  const std::vector<uint8_t> data = {1, 2, 3, 4, 5, 6};
  b.node->Send(transport::MakeCanFrame(0x285, data));  // TPDO2's predefined id: not any more
  b.node->Send(transport::MakeCanFrame(0x1F0, data));
  b.node->Send(transport::MakeCanFrame(0x385, data));  // TPDO3, still predefined
  ASSERT_TRUE(WaitFor([&] { return b.observer.tpdos().size() == 2; }));
  const auto tpdos = b.observer.tpdos();
  EXPECT_EQ(tpdos[0].number, 2);
  EXPECT_EQ(tpdos[0].cob_id, 0x1F0);
  EXPECT_EQ(tpdos[1].number, 3);
  EXPECT_EQ(tpdos[1].cob_id, 0x385);
}

TEST(CanopenMasterPdo, ConfigureFailureNamesTheStepAndTheAbort) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  b.node->AbortOn(0x1A00, 1, SdoAbortCode::kNotMappable);
  absl::Status s =
      b.master->ConfigurePdo(5, PdoKind::kTpdo, 1, PdoCommParams{}, kStatusAndPosition, Far());
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(),
              HasSubstr("canopen configure tpdo1 of node 5, write 3 of 9 (0x1A00:01)"));
  EXPECT_THAT(s.message(), HasSubstr("SDO abort 0x06040041"));
  EXPECT_EQ(AbortCodeOf(s), SdoAbortCode::kNotMappable);
  // Stopped at the failing write: COB-ID invalidated, count 0, nothing after.
  EXPECT_EQ(b.node->writes().size(), 2u);
}

TEST(CanopenMasterPdo, RpdoOnConfiguredAndPredefinedCobIds) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  PdoCommParams comm;
  comm.cob_id = 0x2A5;
  comm.transmission_type = 1;
  const PdoMapping control = {{0x6040, 0, 16}};
  ASSERT_TRUE(b.master->ConfigurePdo(5, PdoKind::kRpdo, 1, comm, control, Far()).ok());
  const std::vector<uint8_t> word = {0x0F, 0x00};
  ASSERT_TRUE(b.master->SendRpdo(5, 1, word).ok());
  ASSERT_TRUE(b.master->SendRpdo(5, 2, word).ok());  // predefined 300h + 5
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x305).size() == 1; }));
  ASSERT_EQ(b.node->frames_with_id(0x2A5).size(), 1u);
  EXPECT_THAT(b.node->frames_with_id(0x2A5)[0].payload(), ElementsAre(0x0F, 0x00));
  EXPECT_EQ(b.master->counters().rpdo_sent, 2u);

  EXPECT_EQ(b.master->SendRpdo(5, 5, word).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(b.master->SendRpdo(5, 1, std::vector<uint8_t>(9)).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->SendRpdo(5, 0, word).code(), absl::StatusCode::kInvalidArgument);
  comm.valid = false;
  ASSERT_TRUE(b.master->ConfigurePdo(5, PdoKind::kRpdo, 1, comm, control, Far()).ok());
  EXPECT_EQ(b.master->SendRpdo(5, 1, word).code(), absl::StatusCode::kFailedPrecondition);
}

TEST(CanopenMasterSync, CountedSyncsEachFollowedByTheListenersRpdo) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  std::atomic<int> listener_calls{0};
  b.master->AddSyncListener([&](const SyncEvent& e) {
    ++listener_calls;
    const std::vector<uint8_t> payload = {e.counter};
    b.master->SendRpdo(5, 1, payload).IgnoreError();
  });
  ASSERT_TRUE(b.master->StartSync(2ms, 4).ok());
  EXPECT_TRUE(b.master->sync_running());
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x080).size() >= 20; }));
  b.master->StopSync();
  EXPECT_FALSE(b.master->sync_running());
  const MasterCounters c = b.master->counters();
  // Everything sent before StopSync returned reaches the node, and nothing after.
  ASSERT_TRUE(WaitFor([&] {
    return b.node->frames_with_id(0x080).size() == c.sync_sent &&
           b.node->frames_with_id(0x205).size() == c.sync_sent;
  })) << "sync_sent "
      << c.sync_sent << ", node saw " << b.node->frames_with_id(0x080).size() << " SYNC and "
      << b.node->frames_with_id(0x205).size() << " RPDO";
  EXPECT_EQ(static_cast<uint64_t>(listener_calls.load()), c.sync_sent);
  EXPECT_GE(c.sync_sent, 20u);
  EXPECT_EQ(c.sync_send_errors, 0u);
  EXPECT_GE(c.sync_max_period_error, c.sync_last_period_error);

  // Counter 1..4 wrapping (1019h = 4), each SYNC followed by the RPDO carrying its counter.
  uint8_t expected = 1;
  std::optional<uint8_t> open_sync;
  for (const auto& f : b.node->frames()) {
    if (f.id == 0x080) {
      EXPECT_FALSE(open_sync.has_value()) << "two SYNCs without the RPDO in between";
      ASSERT_EQ(f.dlc, 1);
      EXPECT_EQ(f.data[0], expected);
      open_sync = f.data[0];
      expected = NextSyncCounter(expected, 4);
    } else if (f.id == 0x205) {
      ASSERT_TRUE(open_sync.has_value()) << "RPDO without a SYNC before it";
      EXPECT_EQ(f.data[0], *open_sync);
      open_sync.reset();
    }
  }
}

TEST(CanopenMasterSync, WithoutCounterRestartAndArguments) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  EXPECT_EQ(b.master->StartSync(500us).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->StartSync(5ms, 1).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->StartSync(5ms, 241).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(b.master->sync_running());
  ASSERT_TRUE(b.master->StartSync(3ms, 240).ok());
  ASSERT_TRUE(b.master->StartSync(2ms).ok());  // restart without counter
  ASSERT_TRUE(WaitFor([&] {
    for (const auto& f : b.node->frames_with_id(0x080)) {
      if (f.dlc == 0) return true;
    }
    return false;
  }));
  b.master->Stop();
  EXPECT_FALSE(b.master->sync_running());
}

TEST(CanopenMasterSync, RemovedListenerIsNotCalled) {
  Bench b;
  ASSERT_NE(b.master, nullptr);
  std::atomic<int> removed_calls{0};
  std::atomic<int> kept_calls{0};
  const SyncListenerId id = b.master->AddSyncListener([&](const SyncEvent&) { ++removed_calls; });
  b.master->AddSyncListener([&](const SyncEvent&) { ++kept_calls; });
  ASSERT_TRUE(b.master->StartSync(1ms).ok());
  ASSERT_TRUE(WaitFor([&] { return removed_calls.load() >= 3; }));
  b.master->RemoveSyncListener(id);
  const int after_remove = removed_calls.load();
  const int kept = kept_calls.load();
  ASSERT_TRUE(WaitFor([&] { return kept_calls.load() >= kept + 5; }));
  EXPECT_EQ(removed_calls.load(), after_remove);
  b.master->StopSync();
}

}  // namespace
}  // namespace drivegw::canopen::testing
