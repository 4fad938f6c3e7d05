// CanopenMaster bus hygiene (decision 1482, reliability gap 13): extended-ID frames, remote
// frames and error frames carrying CANopen-looking identifiers and data, and malformed heartbeats
// (wrong DLC, a state byte that is no NMT state) reach the master on the user-space bus (error
// frames through the channel, as a controller reports them): each is counted and ignored, none
// is taken for an SDO answer, heartbeat, boot-up, TPDO or EMCY, none keeps supervision alive.
#include <array>
#include <cstdint>
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/adapters/canopen/master/test_node.h"

namespace drivegw::canopen::testing {
namespace {

using ::testing::ElementsAre;

struct HygieneBench {
  explicit HygieneBench(uint8_t id, const Clock* clock = &SteadyClock::Instance())
      : bus(UniqueBus()) {
    node = TestNode::Start(bus, id);
    EXPECT_NE(node, nullptr);
    auto channel = transport::OpenCanChannel(bus);
    EXPECT_TRUE(channel.ok()) << channel.status();
    if (!channel.ok()) return;
    MasterOptions o;
    o.clock = clock;
    auto m = CanopenMaster::Open(std::make_unique<FaultyChannel>(*std::move(channel), faults), o);
    EXPECT_TRUE(m.ok()) << m.status();
    if (!m.ok()) return;
    master = *m;
    EXPECT_TRUE(master->AddNodeObserver(id, &observer).ok());
  }
  // Every frame sent or injected before was handled (and timers serviced): two EMCY round trips.
  void Barrier() {
    for (int i = 0; i < 2; ++i) {
      const size_t n = observer.emcys().size();
      node->SendEmcy(0x0000, 0);
      ASSERT_TRUE(WaitFor([&] { return observer.emcys().size() == n + 1; }));
    }
  }
  void Inject(const transport::CanFrame& frame) {
    faults->Inject(frame);
    master->Wake();
  }

  std::shared_ptr<Faults> faults = std::make_shared<Faults>();
  CanBusConfig bus;
  std::unique_ptr<TestNode> node;
  std::shared_ptr<CanopenMaster> master;
  RecordingObserver observer;
};

transport::CanFrame Extended(uint32_t id, std::vector<uint8_t> bytes) {
  return transport::MakeCanFrame(id, bytes, /*extended=*/true);
}

transport::CanFrame ErrorFrame(uint32_t id, std::vector<uint8_t> bytes) {
  transport::CanFrame f = transport::MakeCanFrame(id, bytes);
  f.error = true;
  return f;
}

TEST(CanopenMasterHygiene, ExtendedRemoteAndErrorFramesAreCountedNeverTakenAsMessages) {
  HygieneBench b(5);
  ASSERT_NE(b.master, nullptr);
  b.node->Set(0x6041, 0, {0x37, 0x02});
  // An upload waits for its answer while the look-alikes arrive.
  b.node->SetHolding(true);
  absl::StatusOr<uint16_t> read = absl::UnknownError("not run");
  std::thread t([&] { read = b.master->ReadU16(5, 0x6041, 0, Far()); });
  ASSERT_TRUE(WaitFor([&] { return b.node->held() == 1; }));
  const MasterCounters before = b.master->counters();

  // Expedited upload answer 0xBEEF, heartbeat OPERATIONAL, boot-up, TPDO1, EMCY 0x8611: as
  // 29-bit frames, as remote frames and as error frames with the same identifier and data.
  const std::vector<uint8_t> sdo = {0x4B, 0x41, 0x60, 0x00, 0xEF, 0xBE, 0x00, 0x00};
  const std::vector<uint8_t> emcy = {0x11, 0x86, 0x80, 0, 0, 0, 0, 0};
  b.node->Send(Extended(0x585, sdo));
  b.node->Send(Extended(0x705, {0x05}));
  b.node->Send(Extended(0x705, {0x00}));
  b.node->Send(Extended(0x185, {0x37, 0x02}));
  b.node->Send(Extended(0x085, emcy));
  b.node->Send(transport::MakeCanRtrFrame(0x585, 8));  // SDO channel: not an answer
  b.node->Send(transport::MakeCanRtrFrame(0x705, 1));  // node guarding of another master
  b.node->Send(transport::MakeCanRtrFrame(0x185, 2));  // TPDO request
  b.node->Send(transport::MakeCanRtrFrame(0x085, 8));  // EMCY has no remote form
  b.Inject(ErrorFrame(0x585, sdo));
  b.Inject(ErrorFrame(0x705, {0x05}));
  b.Inject(ErrorFrame(0x085, emcy));
  b.Barrier();

  const MasterCounters after = b.master->counters();
  // 5 extended + 2 remote (guarding, TPDO) + 3 error frames; the EMCY remote frame is a
  // malformed EMCY; the SDO remote frame is no answer of the running transfer.
  EXPECT_EQ(after.other_traffic - before.other_traffic, 10u);
  EXPECT_EQ(after.error_frames - before.error_frames, 3u);
  EXPECT_EQ(after.malformed - before.malformed, 1u);
  EXPECT_EQ(after.sdo_unexpected - before.sdo_unexpected, 1u);
  EXPECT_EQ(after.heartbeats, 0u);
  EXPECT_EQ(after.bootups, 0u);
  EXPECT_EQ(after.tpdo_received, 0u);
  EXPECT_EQ(after.emcy - before.emcy, 2u);  // the barrier's two
  EXPECT_EQ(b.observer.heartbeats(), 0u);
  EXPECT_TRUE(b.observer.events().empty());
  EXPECT_TRUE(b.observer.tpdos().empty());
  // Only the barrier's EMCYs (code 0000h), never the 8611h look-alikes.
  ASSERT_EQ(b.observer.emcys().size(), 2u);
  for (const EmcyEvent& e : b.observer.emcys()) EXPECT_EQ(e.emcy.error_code, 0x0000);
  EXPECT_FALSE(b.master->node_state(5).has_value());

  // The transfer is still waiting: its real answer completes it.
  b.node->Release();
  t.join();
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(*read, 0x0237);
  EXPECT_EQ(b.master->counters().sdo_failures, 0u);
}

TEST(CanopenMasterHygiene, MalformedHeartbeatsAreCountedNeverTakenAsStateOrLife) {
  ManualClock clock;
  HygieneBench b(7, &clock);
  ASSERT_NE(b.master, nullptr);
  ASSERT_TRUE(b.master->SetHeartbeatConsumer(7, 300ms).ok());
  b.node->SendHeartbeat(NmtState::kOperational);
  ASSERT_TRUE(WaitFor([&] { return b.observer.heartbeats() == 1; }));
  const MasterCounters before = b.master->counters();

  clock.Advance(200ms);
  // DLC 0, DLC 2, DLC 8 with a boot-up byte, state bytes 03h and 7Eh (CiA 301 §7.2.8.3.2: 00h,
  // 04h, 05h, 7Fh only), and an unknown state with the toggle bit.
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{}));
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{0x05, 0x00}));
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{0, 0, 0, 0, 0, 0, 0, 0}));
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{0x03}));
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{0x7E}));
  b.node->Send(transport::MakeCanFrame(0x707, std::vector<uint8_t>{0x81}));
  b.Barrier();
  MasterCounters after = b.master->counters();
  EXPECT_EQ(after.malformed - before.malformed, 6u);
  EXPECT_EQ(after.heartbeats, 1u);
  EXPECT_EQ(after.bootups, 0u);
  EXPECT_EQ(b.observer.heartbeats(), 1u);
  EXPECT_TRUE(b.observer.events().empty());  // no boot-up, no loss yet
  EXPECT_EQ(b.master->node_state(7), NmtState::kOperational);

  // 301 ms after the last valid heartbeat: lost, although malformed ones came 101 ms ago.
  clock.Advance(101ms);
  b.master->Wake();
  ASSERT_TRUE(WaitFor([&] { return b.observer.HasEvent(NodeEvent::kHeartbeatLost); }));
  EXPECT_THAT(b.observer.events(), ElementsAre(NodeEvent::kHeartbeatLost));
}

}  // namespace
}  // namespace drivegw::canopen::testing
