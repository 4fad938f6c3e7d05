// Fault-injection properties for STOBER over CANopen (issue 11, decision 1421): the simulated
// axis's CAN channel is wrapped in ImpairedCanChannel (10 % loss of the frames it receives and
// of those it sends, plus duplicates and reordering), a scripted enable and moves go through the
// Drive interface, and the SIMULATOR's motion log (MotionCore::started_targets) and position
// judge: (a) no positioning started that the client did not request (a repeated RPDO or Execute
// edge must not start a move twice, e.g. a relative move), (b) every DONE finished in the
// simulator at its target, (c) after the loss stops the node is online and a move completes.
// The configuration itself (about 30 SDO transfers) runs under the loss and completes within
// kConfigureBound thanks to the bounded SDO retry (decision 1481).
// A corrupt-mode run: DLC-cut frames are refused (counted) and never taken as a state.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "adapters/stober/drive.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/param_id.h"
#include "adapters/transport/impaired_can_channel.h"
#include "sim/stober/server.h"
#include "tests/adapters/stober/test_axis.h"
#include "tests/support/lossy_link.h"
#include "tests/support/wait_status.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;
namespace ss = drivegw::sim::stober;

constexpr auto kWait = 15s;  // generous: the host runs at load 6-10
// Decision 1481: under 10 % loss each way about one exchange in five needs a retry (300 ms each
// here) and a configuration fails only when one transfer loses four tries in a row; a few
// seconds typically, bounded generously for the loaded host.
constexpr auto kConfigureBound = 12s;
constexpr char kGroup[] = "239.74.163.98";
constexpr uint8_t kNode = 9;

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

class StoberFaultTest : public ::testing::Test {
 protected:
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  void Start(const transport::Impairment& sim_receives, const transport::Impairment& sim_sends) {
    std::printf("node receives: %s; node sends: %s\n",
                transport::ImpairmentString(sim_receives).c_str(),
                transport::ImpairmentString(sim_sends).c_str());
    CanBusConfig bus;
    bus.kind = CanBusConfig::Kind::kUdpMulticast;
    bus.group = kGroup;
    bus.port = RandomPort();
    ss::AxisServerOptions o;
    o.node_id = kNode;
    o.can = bus;
    auto inner = transport::OpenCanChannel(bus);
    ASSERT_TRUE(inner.ok()) << inner.status();
    auto impaired = transport::ImpairedCanChannel::Wrap(*std::move(inner), sim_sends, sim_receives);
    ASSERT_TRUE(impaired.ok()) << impaired.status();
    link_ = impaired->get();
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance(), *std::move(impaired));
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    server_->WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });

    DriveConfig c;
    SetTestAxis(c, "st1", bus, kNode);
    // 10 % loss each way plus held (reordered) frames and a loaded host: 10 periods, so the
    // consumer does not take the node offline by chance (it did at 4 periods in one run).
    c.canopen.heartbeat_timeout = 500ms;
    c.canopen.sdo_timeout = 300ms;
    c.timeouts.homing = 5000ms;
    // Decision 1207 allows timeouts.accept (+ a few A150) per Execute edge and one re-edge; the
    // default 100 ms spans about two RPDO/TPDO exchanges, so a bench for a lossy link raises it
    // like the DeviceNet one (decision 1422).
    c.timeouts.accept = 500ms;
    auto drive = CreateStoberDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_.reset(static_cast<StoberDrive*>(drive->release()));
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(drive_->Activate().ok());
    WaitOnline();
    configure_time_ = std::chrono::steady_clock::now() - t0;
  }
  void WaitOnline() {
    const DriveStatus s = test_support::WaitStatus(
        *drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, kWait);
    ASSERT_NE(s.state, DriveState::kOffline) << s.native.text;
  }

  std::vector<double> Started() {
    std::vector<double> out;
    server_->WithAxis([&](ss::MotionCore& c) { out = c.started_targets(); });
    return out;
  }
  double SimPosition() {
    double p = 0;
    server_->WithAxis([&](ss::MotionCore& c) { p = *c.Read(P("I80")); });
    return p;
  }

  void EnableUnderLoss() { ASSERT_TRUE(test_support::EnableUnderLoss(*drive_, kWait)); }

  CommandState RunMove(const MotionCommand& cmd, double target_mm) {
    auto r = drive_->Move(cmd);
    if (!r.ok()) {
      std::printf("move to %.3f refused: %s; simulator started %s\n", target_mm,
                  std::string(r.status().message()).c_str(),
                  ::testing::PrintToString(Started()).c_str());
      return CommandState::kBusy;
    }
    const CommandInfo final = test_support::WaitCommandFinal(*drive_, r->id, kWait);
    if (final.state == CommandState::kDone) {
      // (b) DONE means the simulated core stands at the target.
      EXPECT_NEAR(SimPosition(), target_mm, 1e-6) << "DONE before arriving at " << target_mm;
    } else {
      std::printf("move to %.3f ended %d: %s; simulator started %s\n", target_mm,
                  static_cast<int>(final.state), final.message.c_str(),
                  ::testing::PrintToString(Started()).c_str());
    }
    return final.state;
  }

  std::unique_ptr<ss::AxisServer> server_;
  std::unique_ptr<StoberDrive> drive_;
  transport::ImpairedCanChannel* link_ = nullptr;         // owned by server_
  std::chrono::steady_clock::duration configure_time_{};  // Activate → online
};

MotionCommand Abs(double mm) { return MoveAbsolute{mm, 500, 5000, 5000}; }
MotionCommand Rel(double mm) { return MoveRelative{mm, 500, 5000, 5000}; }

bool Near(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::fabs(a[i] - b[i]) > 1e-6) return false;
  }
  return true;
}

TEST_F(StoberFaultTest, TenPercentLossBothWays_NoUnrequestedMotion_NoFalseDone_Recovers) {
  transport::Impairment in{.drop_probability = 0.1,
                           .duplicate_probability = 0.05,
                           .reorder_probability = 0.02,
                           .seed = 7};
  transport::Impairment out{.drop_probability = 0.1,
                            .duplicate_probability = 0.05,
                            .reorder_probability = 0.02,
                            .seed = 8};
  if (const char* e = std::getenv("DGW_FAULT_SPEC_IN")) in = *transport::ParseImpairment(e);
  if (const char* e = std::getenv("DGW_FAULT_SPEC_OUT")) out = *transport::ParseImpairment(e);
  // Configuration (about 30 SDO transfers, decision 1194) runs under the loss: a lost exchange
  // is retried (canopen.sdo_retries, default 3; decision 1481) instead of failing the whole
  // configuration, which before practically never completed (decision 1423 finding 1).
  Start(in, out);
  const auto configured_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(configure_time_).count();
  const auto before = *drive_->master_counters();
  std::printf(
      "configured under loss in %lld ms: %llu SDO transfers, %llu retries, %llu failed, "
      "%llu configuration attempts failed\n",
      static_cast<long long>(configured_ms), (unsigned long long)before.sdo_transfers,
      (unsigned long long)before.sdo_retries, (unsigned long long)before.sdo_failures,
      (unsigned long long)drive_->counters().configure_failures);
  EXPECT_LT(configure_time_, kConfigureBound);
  EnableUnderLoss();
  // Each step is absolute or relative; the expected target of a relative one is the position
  // the simulator really reached last. A move may end ERROR under loss (decision 1207: the node
  // did not take the Execute edge, even after one re-edge); then the simulator must not have
  // started it either, and the script goes on from where the axis stands.
  struct Step {
    bool relative;
    double mm;
  };
  const std::vector<Step> script = {
      {false, 20}, {true, 5},   {true, 5},   {false, 50}, {true, -10},
      {false, 15}, {true, 7.5}, {true, 2.5}, {false, 40}, {true, -4},
  };
  std::vector<double> expected;
  double base = SimPosition();
  int done = 0, failed = 0;
  for (const Step& s : script) {
    const double target = s.relative ? base + s.mm : s.mm;
    const MotionCommand cmd = s.relative ? Rel(s.mm) : Abs(s.mm);
    const CommandState st = RunMove(cmd, target);
    if (st == CommandState::kDone) {
      ++done;
      expected.push_back(target);
      base = target;
      continue;
    }
    ++failed;
    // Not DONE. Either the simulator never started it (e.g. the Execute edge was lost), or it
    // started exactly this requested target once and the link failed afterwards (the handle
    // says why, e.g. "heartbeat lost"): a requested motion, not an unrequested one. Anything
    // else — another target, or this one twice — violates (a).
    const std::vector<double> started = Started();
    if (started.size() == expected.size() + 1 && std::fabs(started.back() - target) < 1e-6) {
      expected.push_back(target);
      WaitOnline();
      test_support::WaitStatus(
          *drive_, [](const DriveStatus& s) { return !s.motion_active; }, kWait);
      base = SimPosition();
      if (drive_->GetStatus().state != DriveState::kEnabled) EnableUnderLoss();
      continue;
    }
    if (started.size() != expected.size()) {
      ADD_FAILURE() << "move to " << target << " reported " << static_cast<int>(st)
                    << " but the simulator started " << ::testing::PrintToString(started);
      return;
    }
    if (drive_->GetStatus().state == DriveState::kOffline) WaitOnline();
  }
  EXPECT_GE(done, 3) << "too few moves completed to judge";
  std::printf("%d moves DONE, %d ended ERROR or were refused (none started)\n", done, failed);
  // (a) exactly the requested positionings, once each, in order.
  EXPECT_TRUE(Near(Started(), expected))
      << ::testing::PrintToString(Started()) << " vs " << ::testing::PrintToString(expected);

  const auto ic = link_->impaired_counters();
  const auto mc = drive_->master_counters();
  ASSERT_TRUE(mc.has_value());
  const StoberDriveCounters dc = drive_->counters();
  std::printf(
      "node received: dropped %llu duplicated %llu reordered %llu of %llu; node sent: dropped "
      "%llu duplicated %llu reordered %llu of %llu; master sdo ok %llu failed %llu timeouts %llu "
      "retries %llu stale %llu rpdo %llu tpdo %llu heartbeat lost %llu; drive execute retries "
      "%llu configurations %llu; Done withheld (decision 1484) %llu\n",
      (unsigned long long)ic.receive.dropped, (unsigned long long)ic.receive.duplicated,
      (unsigned long long)ic.receive.reordered, (unsigned long long)ic.receive.decided,
      (unsigned long long)ic.send.dropped, (unsigned long long)ic.send.duplicated,
      (unsigned long long)ic.send.reordered, (unsigned long long)ic.send.decided,
      (unsigned long long)mc->sdo_transfers, (unsigned long long)mc->sdo_failures,
      (unsigned long long)mc->sdo_timeouts, (unsigned long long)mc->sdo_retries,
      (unsigned long long)mc->sdo_stale_responses, (unsigned long long)mc->rpdo_sent,
      (unsigned long long)mc->tpdo_received, (unsigned long long)mc->heartbeat_lost,
      (unsigned long long)dc.execute_retries, (unsigned long long)dc.configurations,
      (unsigned long long)dc.done_withheld);
  EXPECT_GT(ic.receive.dropped, 0u);
  EXPECT_GT(ic.send.dropped, 0u);

  // (c) the loss stops: online, and a new move completes.
  ASSERT_TRUE(link_->SetImpairment({}, {}).ok());
  WaitOnline();
  if (drive_->GetStatus().state != DriveState::kEnabled) EnableUnderLoss();
  ASSERT_EQ(RunMove(Abs(60), 60), CommandState::kDone);
  expected.push_back(60);
  EXPECT_TRUE(Near(Started(), expected)) << ::testing::PrintToString(Started());
}

TEST_F(StoberFaultTest, CorruptFrames_RefusedCountedNeverTakenAsState) {
  // 10 % of the node's frames reach the gateway with a cut DLC (decision 1421), seed 11.
  Start({}, {});
  ASSERT_TRUE(
      link_->SetImpairment(transport::Impairment{.corrupt_probability = 0.1, .seed = 11}, {}).ok());
  EnableUnderLoss();
  ASSERT_EQ(RunMove(Abs(33), 33), CommandState::kDone);
  const auto ic = link_->impaired_counters();
  const auto mc = *drive_->master_counters();
  std::printf(
      "node sent corrupted %llu of %llu; master malformed %llu sdo failures %llu sdo "
      "timeouts %llu other %llu\n",
      (unsigned long long)ic.send.corrupted, (unsigned long long)ic.send.decided,
      (unsigned long long)mc.malformed, (unsigned long long)mc.sdo_failures,
      (unsigned long long)mc.sdo_timeouts, (unsigned long long)mc.other_traffic);
  EXPECT_GT(ic.send.corrupted, 0u);
  // Refused: cut TPDOs by the drive, cut heartbeats/EMCY by the master, cut SDO responses end
  // their transfer; none became a state.
  const StoberDriveCounters dc = drive_->counters();
  std::printf("drive malformed TPDOs %llu\n", (unsigned long long)dc.malformed_tpdos);
  EXPECT_GT(dc.malformed_tpdos + mc.malformed + mc.sdo_failures, 0u);
  // The position TPDO (inhibit 10 ms, decision 1175) may trail the status TPDO's Done.
  const DriveStatus s = test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return std::abs(s.position_mm - 33) < 1e-6; }, kWait);
  EXPECT_NEAR(s.position_mm, 33, 1e-6);
  EXPECT_NEAR(SimPosition(), 33, 1e-6);
  EXPECT_EQ(Started().size(), 1u);
}

}  // namespace
}  // namespace drivegw::stober
