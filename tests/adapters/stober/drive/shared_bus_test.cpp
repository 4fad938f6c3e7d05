// Two STOBER drives on one CANopen bus (one shared CanopenMaster, decision 1111), the simulated
// nodes 3 and 4 on the UDP multicast bus: when node 4 dies its drive goes DOWN and waits for the
// heartbeat, and when it is activated while dead it is probed at the back-off with bounded SDO
// tries (decision 1481); meanwhile drive 3 keeps its SDO round-trip rate — the STOBER counterpart
// of
// DnSession.SharedBus_DeadDriveDownProbedAtBackoff_OthersKeepTheirRate (decision 1482).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include "adapters/stober/drive.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "sim/stober/server.h"
#include "tests/adapters/stober/test_axis.h"
#include "tests/support/wait_status.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;
namespace ss = drivegw::sim::stober;

constexpr char kGroup[] = "239.74.163.96";

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

std::unique_ptr<ss::AxisServer> StartNode(const CanBusConfig& bus, uint8_t node) {
  ss::AxisServerOptions o;
  o.node_id = node;
  o.can = bus;
  auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
  EXPECT_TRUE(server.ok()) << server.status();
  return server.ok() ? std::move(*server) : nullptr;
}

std::unique_ptr<StoberDrive> StartDrive(const CanBusConfig& bus, const char* name, uint8_t node) {
  DriveConfig c;
  SetTestAxis(c, name, bus, node);
  c.canopen.heartbeat_timeout = 200ms;
  c.canopen.sdo_timeout = 100ms;
  auto drive = CreateStoberDrive(c, SteadyClock::Instance());
  EXPECT_TRUE(drive.ok()) << drive.status();
  if (!drive.ok()) return nullptr;
  std::unique_ptr<StoberDrive> out(static_cast<StoberDrive*>(drive->release()));
  EXPECT_TRUE(out->Activate().ok());
  return out;
}

// SDO round trips of `drive` (I89 reads, one every 5 ms like a polling client: a CPU-bound loop
// would measure the loaded host, not the bus) completed within `window`.
int ReadsIn(StoberDrive& drive, std::chrono::milliseconds window) {
  const CanOpenAddress a = *ToCanOpen(P("I89"));
  const ParameterRef ref{static_cast<uint32_t>(a.index) << 8 | a.sub_index, false};
  const auto end = std::chrono::steady_clock::now() + window;
  int n = 0;
  while (std::chrono::steady_clock::now() < end) {
    if (drive.ReadParameter(ref).ok()) ++n;
    std::this_thread::sleep_for(5ms);
  }
  return n;
}

bool IsUp(const DriveStatus& s) {
  return s.state != DriveState::kOffline && s.health && s.health->state == HealthState::kUp;
}

TEST(StoberSharedBus, DeadDriveDownProbedAtBackoff_OtherKeepsItsRate) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = RandomPort();
  auto node3 = StartNode(bus, 3);
  auto node4 = StartNode(bus, 4);
  ASSERT_TRUE(node3 && node4);
  auto s1 = StartDrive(bus, "s1", 3);
  auto s2 = StartDrive(bus, "s2", 4);
  ASSERT_TRUE(s1 && s2);
  ASSERT_TRUE(IsUp(test_support::WaitStatus(*s1, IsUp, 10s)));
  ASSERT_TRUE(IsUp(test_support::WaitStatus(*s2, IsUp, 10s)));

  const int before = ReadsIn(*s1, 500ms);
  ASSERT_GT(before, 20);  // about 100 (5 ms pacing), far more than 20 even loaded

  // Node 4 dies while configured: heartbeat lost, drive s2 DOWN. It waits for the heartbeat to
  // come back (decision 1200): no SDO goes to the dead node at all.
  node4->SetSilent(true);
  auto is_down = [](const DriveStatus& s) {
    return s.health && s.health->state == HealthState::kDown;
  };
  DriveStatus down = test_support::WaitStatus(*s2, is_down, 10s);
  ASSERT_TRUE(is_down(down)) << down.native.text;
  uint64_t timeouts_before = s1->master_counters()->sdo_timeouts;
  int after = ReadsIn(*s1, 500ms);
  EXPECT_EQ(s1->master_counters()->sdo_timeouts - timeouts_before, 0u);
  // The live drive keeps its rate (>= 80 %): nothing of the dead node's waits on the bus's
  // receive thread or on node 3's SDO channel.
  EXPECT_GE(after * 10, before * 8) << after << " reads after, " << before << " before";
  EXPECT_TRUE(IsUp(s1->GetStatus()));

  // Drive s2 activated again while node 4 stays dead: never configured, so it probes with the
  // first upload of its configuration at the back-off.
  s2->Deactivate();
  s2 = StartDrive(bus, "s2", 4);
  ASSERT_TRUE(s2);
  down = test_support::WaitStatus(*s2, is_down, 10s);
  ASSERT_TRUE(is_down(down)) << down.native.text;
  timeouts_before = s1->master_counters()->sdo_timeouts;
  after = ReadsIn(*s1, 1500ms);
  const uint64_t timeouts = s1->master_counters()->sdo_timeouts - timeouts_before;
  EXPECT_GE(after * 10, 3 * before * 8)
      << after << " reads in 1.5 s after, " << before << " in 0.5 s before";
  EXPECT_TRUE(IsUp(s1->GetStatus()));
  // Each probe is (1 + sdo_retries) = 4 tries of 100 ms, then the back-off (500 ms,
  // StoberHealthConfig): one cycle per 900 ms, at most 8 time-outs in any 1.5 s window (the live
  // drive has none); probing without the back-off would time out 15 times.
  std::printf(
      "node 3 reads: %d in 0.5 s before, %d in 1.5 s while node 4 was probed; %llu "
      "SDO time-outs of node 4\n",
      before, after, static_cast<unsigned long long>(timeouts));
  EXPECT_LE(timeouts, 10u) << timeouts << " SDO time-outs of the dead node in 1.5 s";
  EXPECT_GE(timeouts, 4u) << "the dead drive was not probed";
  EXPECT_TRUE(is_down(s2->GetStatus()));

  s2->Deactivate();
  s1->Deactivate();
  node4->Stop();
  node3->Stop();
}

}  // namespace
}  // namespace drivegw::stober
