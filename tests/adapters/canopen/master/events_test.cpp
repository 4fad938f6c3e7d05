// CanopenMaster events: heartbeat consumer (lost / resumed / boot-up on a manual clock), EMCY
// with names, NMT frames, heartbeat producer and 1029h helpers, bus faults (receive failure with
// reopening, bus-off) reaching every observer, observer removal, the per-bus pool.
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "adapters/canopen/master_pool.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/adapters/canopen/master/test_node.h"

namespace drivegw::canopen::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A node, a master on a manual clock (heartbeat supervision advances only when told) and an
// observer of the node.
struct ManualBench {
  ManualBench() {
    bus = UniqueBus();
    node = TestNode::Start(bus, 7);
    EXPECT_NE(node, nullptr);
    MasterOptions o;
    o.clock = &clock;
    auto m = CanopenMaster::Open(bus, o);
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *m;
    if (master) {
      EXPECT_TRUE(master->AddNodeObserver(7, &observer).ok());
    }
  }
  // The master handled every frame the node sent before, and serviced its timers after that:
  // EMCY round trips are the barrier (the receive loop services timers before each Receive).
  void Barrier() {
    for (int i = 0; i < 2; ++i) {
      const size_t n = observer.emcys().size();
      node->SendEmcy(0x0000, 0);
      ASSERT_TRUE(WaitFor([&] { return observer.emcys().size() == n + 1; }));
    }
  }
  ManualClock clock;
  CanBusConfig bus;
  std::unique_ptr<TestNode> node;
  std::shared_ptr<CanopenMaster> master;
  RecordingObserver observer;
};

TEST(CanopenMasterHeartbeat, LostResumedAndBootUp) {
  ManualBench b;
  ASSERT_NE(b.master, nullptr);
  ASSERT_TRUE(b.master->SetHeartbeatConsumer(7, 300ms).ok());
  // Supervision starts with the first heartbeat: a long silence before it is no loss.
  b.clock.Advance(10s);
  b.Barrier();
  EXPECT_TRUE(b.observer.events().empty());

  b.node->SendHeartbeat(NmtState::kPreOperational);
  ASSERT_TRUE(WaitFor([&] { return b.observer.heartbeats() == 1; }));
  EXPECT_EQ(b.master->node_state(7), NmtState::kPreOperational);
  b.clock.Advance(300ms);  // exactly the consumer time: still within it
  b.Barrier();
  EXPECT_TRUE(b.observer.events().empty());

  b.clock.Advance(1ms);
  b.master->Wake();
  ASSERT_TRUE(WaitFor([&] { return b.observer.HasEvent(NodeEvent::kHeartbeatLost); }));
  EXPECT_THAT(b.observer.infos()[0].reason, HasSubstr("no heartbeat from node 7 for 301 ms"));
  EXPECT_EQ(b.observer.infos()[0].node, 7);

  b.node->SendHeartbeat(NmtState::kOperational);
  ASSERT_TRUE(WaitFor([&] { return b.observer.HasEvent(NodeEvent::kHeartbeatResumed); }));
  EXPECT_EQ(b.master->node_state(7), NmtState::kOperational);

  b.node->SendHeartbeat(NmtState::kBootUp);
  ASSERT_TRUE(WaitFor([&] { return b.observer.HasEvent(NodeEvent::kBootUp); }));
  EXPECT_EQ(b.master->node_state(7), NmtState::kBootUp);
  // After a boot-up supervision waits for the next heartbeat (decision 1114).
  b.clock.Advance(10s);
  b.Barrier();
  EXPECT_THAT(b.observer.events(), ElementsAre(NodeEvent::kHeartbeatLost,
                                               NodeEvent::kHeartbeatResumed, NodeEvent::kBootUp));
  b.node->SendHeartbeat(NmtState::kPreOperational);
  ASSERT_TRUE(WaitFor([&] { return b.observer.heartbeats() == 3; }));
  b.clock.Advance(301ms);
  b.master->Wake();
  ASSERT_TRUE(WaitFor([&] { return b.observer.events().size() == 4; }));
  EXPECT_EQ(b.observer.events().back(), NodeEvent::kHeartbeatLost);

  const MasterCounters c = b.master->counters();
  EXPECT_EQ(c.heartbeats, 3u);
  EXPECT_EQ(c.heartbeat_lost, 2u);
  EXPECT_EQ(c.bootups, 1u);
}

TEST(CanopenMasterHeartbeat, ConsumerOffAndOtherNodes) {
  ManualBench b;
  ASSERT_NE(b.master, nullptr);
  b.node->SendHeartbeat(NmtState::kOperational);  // no consumer time: never lost
  ASSERT_TRUE(WaitFor([&] { return b.observer.heartbeats() == 1; }));
  b.clock.Advance(1h);
  b.Barrier();
  EXPECT_TRUE(b.observer.events().empty());
  // Heartbeats of node 8 do not reach node 7's observer; a malformed one is counted.
  auto other = TestNode::Start(b.bus, 8);
  ASSERT_NE(other, nullptr);
  other->SendHeartbeat(NmtState::kBootUp);
  other->Send(transport::MakeCanFrame(0x708, std::vector<uint8_t>{0x03}));
  ASSERT_TRUE(WaitFor([&] { return b.master->counters().malformed == 1; }));
  ASSERT_TRUE(WaitFor([&] { return b.master->counters().bootups == 1; }));
  EXPECT_TRUE(b.observer.events().empty());
  EXPECT_EQ(b.master->SetHeartbeatConsumer(0, 1s).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->SetHeartbeatConsumer(7, -1s).code(), absl::StatusCode::kInvalidArgument);
}

TEST(CanopenMasterEmcy, DecodedWithName) {
  ManualBench b;
  ASSERT_NE(b.master, nullptr);
  b.node->SendEmcy(0x8611, 0x21, {1, 2, 3, 4, 5});
  ASSERT_TRUE(WaitFor([&] { return b.observer.emcys().size() == 1; }));
  const EmcyEvent e = b.observer.emcys()[0];
  EXPECT_EQ(e.emcy.node, 7);
  EXPECT_EQ(e.emcy.error_code, 0x8611);
  EXPECT_EQ(e.emcy.error_register, 0x21);
  EXPECT_THAT(e.emcy.manufacturer, ElementsAre(1, 2, 3, 4, 5));
  EXPECT_EQ(e.name, "EMCY 0x8611 following error");
  EXPECT_EQ(b.master->counters().emcy, 1u);
}

TEST(CanopenMasterNmt, CommandFrames) {
  ManualBench b;
  ASSERT_NE(b.master, nullptr);
  ASSERT_TRUE(b.master->SendNmt(NmtCommand::kStart, 7).ok());
  ASSERT_TRUE(b.master->SendNmt(NmtCommand::kResetNode, 0).ok());
  EXPECT_EQ(b.master->SendNmt(NmtCommand::kStop, 128).code(), absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(WaitFor([&] { return b.node->frames_with_id(0x000).size() == 2; }));
  EXPECT_THAT(b.node->frames_with_id(0x000)[0].payload(), ElementsAre(0x01, 7));
  EXPECT_THAT(b.node->frames_with_id(0x000)[1].payload(), ElementsAre(0x81, 0));
  EXPECT_EQ(b.master->counters().nmt_sent, 2u);
}

TEST(CanopenMasterHeartbeat, ProducerAndErrorBehaviourHelpers) {
  auto bus = UniqueBus();
  auto node = TestNode::Start(bus, 4);
  ASSERT_NE(node, nullptr);
  auto m = CanopenMaster::Open(bus);
  ASSERT_TRUE(m.ok());
  CanopenMaster& master = **m;
  ASSERT_TRUE(master.ConfigureHeartbeatProducer(4, 100, Far()).ok());
  EXPECT_EQ(node->Get(0x1017, 0), (std::vector<uint8_t>{100, 0}));
  ASSERT_TRUE(master.ConfigureErrorBehaviour(4, ErrorBehaviour::kStopped, Far()).ok());
  EXPECT_EQ(node->Get(0x1029, 1), std::vector<uint8_t>{2});
  EXPECT_EQ(master.ConfigureErrorBehaviour(4, ErrorBehaviour::kNoChange, Far(), 0).code(),
            absl::StatusCode::kInvalidArgument);
  // A node that keeps another producer time is caught by the read-back.
  node->StoreOnWrite(0x1017, 0, {0xFA, 0x00});
  absl::Status s = master.ConfigureHeartbeatProducer(4, 100, Far());
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("wrote 100 ms, reads back 250 ms"));
}

TEST(CanopenMasterBus, ReceiveFailureReopensAndNotifiesEveryObserver) {
  auto bus = UniqueBus();
  auto node = TestNode::Start(bus, 5);
  ASSERT_NE(node, nullptr);
  node->Set(0x6041, 0, {0x37, 0x02});
  auto faults = std::make_shared<Faults>();
  auto first = transport::OpenCanChannel(bus);
  ASSERT_TRUE(first.ok());
  MasterOptions o;
  o.bus_retry_min = 5ms;
  o.bus_retry_max = 20ms;
  auto m = CanopenMaster::Open(
      std::make_unique<FaultyChannel>(*std::move(first), faults), o,
      [bus, faults]() -> absl::StatusOr<std::unique_ptr<transport::CanChannel>> {
        auto c = transport::OpenCanChannel(bus);
        if (!c.ok()) return c.status();
        return std::make_unique<FaultyChannel>(*std::move(c), faults);
      });
  ASSERT_TRUE(m.ok());
  CanopenMaster& master = **m;
  RecordingObserver a, b;
  ASSERT_TRUE(master.AddNodeObserver(5, &a).ok());
  ASSERT_TRUE(master.AddNodeObserver(6, &b).ok());

  faults->fail_receive = true;
  master.Wake();
  ASSERT_TRUE(WaitFor(
      [&] { return a.HasEvent(NodeEvent::kLinkLost) && b.HasEvent(NodeEvent::kLinkLost); }));
  EXPECT_FALSE(master.link_up());
  EXPECT_EQ(b.infos()[0].node, 6);
  EXPECT_THAT(a.infos()[0].reason, HasSubstr("injected receive failure"));
  auto refused = master.Upload(5, 0x6041, 0, Far());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kUnavailable);
  ASSERT_TRUE(WaitFor([&] { return faults->opened.load() >= 3; }));  // reopened, with back-off

  faults->fail_receive = false;
  ASSERT_TRUE(WaitFor([&] { return a.HasEvent(NodeEvent::kLinkRestored); }));
  ASSERT_TRUE(WaitFor([&] { return b.HasEvent(NodeEvent::kLinkRestored); }));
  EXPECT_TRUE(master.link_up());
  EXPECT_THAT(a.events(), ElementsAre(NodeEvent::kLinkLost, NodeEvent::kLinkRestored));
  auto v = master.ReadU16(5, 0x6041, 0, Far());
  ASSERT_TRUE(v.ok()) << v.status();
  EXPECT_EQ(*v, 0x0237);
  const MasterCounters c = master.counters();
  EXPECT_EQ(c.link_lost_events, 1u);
  EXPECT_GE(c.reopens, 1u);
  EXPECT_GE(c.receive_errors, 2u);
}

TEST(CanopenMasterBus, BusOffFailsTheRunningTransferAndRecovers) {
  auto bus = UniqueBus();
  auto node = TestNode::Start(bus, 5);
  ASSERT_NE(node, nullptr);
  node->Set(0x6041, 0, {0x37, 0x02});
  auto faults = std::make_shared<Faults>();
  auto ch = transport::OpenCanChannel(bus);
  ASSERT_TRUE(ch.ok());
  MasterOptions o;
  o.sdo_timeout = 10s;
  auto m = CanopenMaster::Open(std::make_unique<FaultyChannel>(*std::move(ch), faults), o);
  ASSERT_TRUE(m.ok());
  CanopenMaster& master = **m;
  RecordingObserver a;
  ASSERT_TRUE(master.AddNodeObserver(5, &a).ok());
  node->SetHolding(true);
  absl::StatusOr<uint16_t> r = absl::UnknownError("not run");
  std::thread t([&] { r = master.ReadU16(5, 0x6041, 0, Far()); });
  ASSERT_TRUE(WaitFor([&] { return node->held() == 1; }));
  faults->state = static_cast<int>(transport::CanBusState::kBusOff);
  master.Wake();
  t.join();  // ends with the bus-off, not the 10 s time-out
  EXPECT_EQ(r.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(r.status().message(), HasSubstr("sdo upload 0x6041:00 node 5"));
  EXPECT_THAT(r.status().message(), HasSubstr("bus-off"));
  ASSERT_TRUE(WaitFor([&] { return a.HasEvent(NodeEvent::kBusOff); }));
  EXPECT_EQ(master.SendRpdo(5, 1, std::vector<uint8_t>{1}).code(), absl::StatusCode::kUnavailable);

  faults->state = -1;
  master.Wake();
  ASSERT_TRUE(WaitFor([&] { return a.HasEvent(NodeEvent::kLinkRestored); }));
  node->Release();  // the stale request is answered: nobody waits for it any more
  ASSERT_TRUE(WaitFor([&] { return master.counters().sdo_unexpected >= 1; }));
  node->Set(0x6041, 0, {0x21, 0x06});
  auto v = master.ReadU16(5, 0x6041, 0, Far());
  ASSERT_TRUE(v.ok()) << v.status();
  EXPECT_EQ(*v, 0x0621);
  EXPECT_EQ(master.counters().bus_off_events, 1u);
}

TEST(CanopenMasterBus, HeartbeatSupervisionPausesDuringALinkFault) {
  auto bus = UniqueBus();
  auto node = TestNode::Start(bus, 7);
  ASSERT_NE(node, nullptr);
  auto faults = std::make_shared<Faults>();
  auto ch = transport::OpenCanChannel(bus);
  ASSERT_TRUE(ch.ok());
  ManualClock clock;
  MasterOptions o;
  o.clock = &clock;
  o.bus_retry_min = 5ms;
  o.bus_retry_max = 10ms;
  auto m = CanopenMaster::Open(std::make_unique<FaultyChannel>(*std::move(ch), faults), o);
  ASSERT_TRUE(m.ok());
  CanopenMaster& master = **m;
  RecordingObserver obs;
  ASSERT_TRUE(master.AddNodeObserver(7, &obs).ok());
  ASSERT_TRUE(master.SetHeartbeatConsumer(7, 300ms).ok());
  node->SendHeartbeat(NmtState::kOperational);
  ASSERT_TRUE(WaitFor([&] { return obs.heartbeats() == 1; }));

  faults->fail_receive = true;
  master.Wake();
  ASSERT_TRUE(WaitFor([&] { return obs.HasEvent(NodeEvent::kLinkLost); }));
  clock.Advance(5s);  // our outage, not the node's: no heartbeat loss
  faults->fail_receive = false;
  ASSERT_TRUE(WaitFor([&] { return obs.HasEvent(NodeEvent::kLinkRestored); }));
  for (int i = 1; i <= 2; ++i) {  // barrier: timers serviced after the restore
    node->SendEmcy(0x0000, 0);
    ASSERT_TRUE(WaitFor([&] { return obs.emcys().size() == static_cast<size_t>(i); }));
  }
  EXPECT_THAT(obs.events(), ElementsAre(NodeEvent::kLinkLost, NodeEvent::kLinkRestored));
  // Supervision restarts with the first heartbeat after the fault.
  node->SendHeartbeat(NmtState::kOperational);
  ASSERT_TRUE(WaitFor([&] { return obs.heartbeats() == 2; }));
  clock.Advance(301ms);
  master.Wake();
  ASSERT_TRUE(WaitFor([&] { return obs.events().size() == 3; }));
  EXPECT_EQ(obs.events().back(), NodeEvent::kHeartbeatLost);
}

TEST(CanopenMasterObservers, RemovedObserverIsNotCalled) {
  ManualBench b;
  ASSERT_NE(b.master, nullptr);
  RecordingObserver second;
  auto id = b.master->AddNodeObserver(7, &second);
  ASSERT_TRUE(id.ok());
  b.node->SendEmcy(0x1000, 1);
  ASSERT_TRUE(WaitFor([&] { return second.emcys().size() == 1; }));
  b.master->RemoveNodeObserver(*id);
  b.node->SendEmcy(0x1000, 1);
  ASSERT_TRUE(WaitFor([&] { return b.observer.emcys().size() == 2; }));
  EXPECT_EQ(second.emcys().size(), 1u);
  EXPECT_EQ(b.master->AddNodeObserver(7, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(b.master->AddNodeObserver(0, &second).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(CanopenMasterPool, OneMasterPerBus) {
  auto bus = UniqueBus();
  auto a = CanopenMasterPool::Instance().Acquire(bus);
  auto b = CanopenMasterPool::Instance().Acquire(bus);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->get(), b->get());
  CanBusConfig other = bus;
  other.port = static_cast<uint16_t>(bus.port + 1);
  auto c = CanopenMasterPool::Instance().Acquire(other);
  ASSERT_TRUE(c.ok());
  EXPECT_NE(a->get(), c->get());
  EXPECT_EQ((*a)->bus_name(), transport::CanSpecString(bus));
  const CanopenMaster* before = a->get();
  a->reset();
  b->reset();
  auto again = CanopenMasterPool::Instance().Acquire(bus);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE((*again)->link_up());
  (void)before;
}

}  // namespace
}  // namespace drivegw::canopen::testing
