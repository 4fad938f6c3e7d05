// Stale telegrams, LinUDP (decision 1461, finding 1424): a telegram the network delivers after a
// newer one must not make the drive run a motion the client did not ask for. The MC interface
// executes a block whenever its count differs from the last one interpreted (linmot-mc.md §4.3),
// so the gateway sends a motion block only until the drive echoes its count, and halts and
// reports FAULT when the echo shows that an older block ran anyway. A forwarding proxy between
// the gateway and the simulator records the gateway's real telegrams and delivers one of them
// late; the simulator's own motion log and position are the judge.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/transport/udp_socket.h"
#include "sim/linmot/device.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotServer;

constexpr auto kWait = 20s;  // generous: the host runs at load 6-10
constexpr double kIncPerMm = 10000;

// Forwards gateway -> simulator and back on loopback, keeping every request in order; Inject
// delivers a recorded request again, as a network that held it back would.
class RecordingProxy {
 public:
  RecordingProxy(transport::Endpoint sim, transport::UdpSocket socket)
      : sim_(sim), socket_(std::move(socket)) {
    thread_ = std::thread([this] { Run(); });
  }
  ~RecordingProxy() {
    socket_.Shutdown();
    thread_.join();
  }
  uint16_t port() const { return socket_.local_endpoint().port; }
  size_t request_count() {
    std::lock_guard lock(mu_);
    return requests_.size();
  }
  std::vector<std::vector<uint8_t>> requests_from(size_t first) {
    std::lock_guard lock(mu_);
    if (first >= requests_.size()) return {};
    return {requests_.begin() + static_cast<std::ptrdiff_t>(first), requests_.end()};
  }
  void Inject(const std::vector<uint8_t>& bytes) { ASSERT_TRUE(socket_.SendTo(sim_, bytes).ok()); }

 private:
  void Run() {
    for (;;) {
      auto d = socket_.Receive(50ms);
      if (!d.ok()) return;  // Shutdown
      if (!d->has_value()) continue;
      if ((*d)->from == sim_) {
        std::optional<transport::Endpoint> to;
        {
          std::lock_guard lock(mu_);
          to = gateway_;
        }
        if (to) (void)socket_.SendTo(*to, (*d)->bytes);
        continue;
      }
      {
        std::lock_guard lock(mu_);
        gateway_ = (*d)->from;
        requests_.push_back((*d)->bytes);
      }
      (void)socket_.SendTo(sim_, (*d)->bytes);
    }
  }

  const transport::Endpoint sim_;
  transport::UdpSocket socket_;
  std::mutex mu_;
  std::optional<transport::Endpoint> gateway_;
  std::vector<std::vector<uint8_t>> requests_;
  std::thread thread_;
};

class LinUdpStaleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto server = LinMotServer::Start(test_support::LinUdpSimOptions(), SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    auto socket =
        transport::UdpSocket::Bind(transport::Endpoint{transport::Endpoint::kLoopback, 0});
    ASSERT_TRUE(socket.ok()) << socket.status();
    proxy_ = std::make_unique<RecordingProxy>(
        transport::Endpoint{transport::Endpoint::kLoopback, server_->port()}, std::move(*socket));
    DriveConfig c = test_support::LinUdpDriveConfig(proxy_->port());
    auto drive = CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    proxy_.reset();
  }

  sim::linmot::DeviceSnapshot Sim() { return server_->Snapshot().device; }
  std::vector<int64_t> StartedTargets() {
    std::vector<int64_t> out;
    server_->WithDevice([&](sim::linmot::LinMotDevice& d) { out = d.started_targets(); });
    return out;
  }
  const LinMotUdpDrive& Udp() const { return dynamic_cast<const LinMotUdpDrive&>(*drive_); }
  static bool WaitFor(const std::function<bool()>& pred) {
    return test_support::WaitFor(pred, kWait);
  }
  // Moves and waits for DONE, the simulator standing at `target_mm`.
  void MoveDone(const MotionCommand& cmd, double target_mm) {
    auto r = drive_->Move(cmd);
    ASSERT_TRUE(r.ok()) << r.status();
    const CommandInfo final = test_support::WaitCommandFinal(*drive_, r->id, kWait);
    ASSERT_EQ(final.state, CommandState::kDone) << final.message;
    ASSERT_NEAR(Sim().actual_position_mm, target_mm, 0.05);
  }
  // Delivers `stale` to the simulator and waits until it was handled and a few more cycles of
  // the gateway's own telegrams followed (each of which would re-execute the current command if
  // it still carried its block).
  void DeliverLate(const std::vector<uint8_t>& stale) {
    const uint64_t received = server_->Snapshot().server.datagrams_received;
    proxy_->Inject(stale);
    ASSERT_TRUE(
        WaitFor([&] { return server_->Snapshot().server.datagrams_received >= received + 20; }));
  }
  static int64_t Inc(double mm) { return std::llround(mm * kIncPerMm); }

  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<RecordingProxy> proxy_;
  std::unique_ptr<Drive> drive_;
};

// A cyclic telegram sent after move A was accepted, delivered after move B: before decision 1461
// it still carried A's block (count A), so the drive ran A again and the next telegram ran B
// again (targets s+10, 30, 40, 30 for a relative 10 from s and an absolute 30).
TEST_F(LinUdpStaleTest, TelegramFromBeforeNewerMove_DeliveredLate_NothingReExecuted) {
  const double start_mm = Sim().demand_position_mm;
  MoveDone(MoveRelative{10, 400, 10000, 10000}, start_mm + 10);
  // The gateway's latest telegram after A finished: what a switch holding one datagram back
  // would deliver after the next one.
  const size_t after_a = proxy_->request_count();
  ASSERT_TRUE(WaitFor([&] { return proxy_->request_count() >= after_a + 3; }));
  const std::vector<uint8_t> stale = proxy_->requests_from(after_a).back();
  MoveDone(MoveAbsolute{30, 400, 10000, 10000}, 30);
  const uint64_t executed = Sim().mc_commands_executed;

  DeliverLate(stale);

  EXPECT_EQ(StartedTargets(), (std::vector<int64_t>{Inc(start_mm + 10), Inc(30)}));
  EXPECT_EQ(Sim().mc_commands_executed, executed);
  EXPECT_NEAR(Sim().demand_position_mm, 30, 1e-3);
  EXPECT_EQ(Udp().stale_motion_commands(), 0u);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kEnabled);
}

// The case omission leaves: a telegram sent while A waited for its acceptance (so it carries A's
// block) arrives after B was accepted. The drive executes it; the gateway sees the count echo go
// back to A's count, halts the axis with /Abort before it gets far, reports FAULT naming the
// cause and counts it; AcknowledgeFault releases the halt without resuming anything.
TEST_F(LinUdpStaleTest, MotionBlockDeliveredAfterNewerMove_HaltedFaultedCounted) {
  const size_t before_a = proxy_->request_count();
  // A: slow, so that a re-run from B's 10 mm to 50 mm needs half a second.
  MoveDone(MoveRelative{40, 100, 1000, 1000}, Sim().demand_position_mm + 40);
  std::optional<std::vector<uint8_t>> carrying_a;
  for (const auto& bytes : proxy_->requests_from(before_a)) {
    auto req = DecodeRequest(bytes);
    ASSERT_TRUE(req.ok()) << req.status();
    if (req->motion_command) {
      carrying_a = bytes;
      break;
    }
  }
  ASSERT_TRUE(carrying_a.has_value()) << "no telegram carried move A";
  MoveDone(MoveAbsolute{10, 400, 10000, 10000}, 10);  // B
  const auto started_before = StartedTargets();

  DeliverLate(*carrying_a);

  // The drive did run the stale block (the protocol cannot refuse it) ...
  const auto started = StartedTargets();
  ASSERT_EQ(started.size(), started_before.size() + 1);
  EXPECT_EQ(started.back(), Inc(50));
  // ... and the gateway stopped it far from its 50 mm target: /Abort, state 12, standing.
  ASSERT_TRUE(WaitFor([&] { return !Sim().motion_active; }));
  EXPECT_EQ(Sim().main_state, 12);
  EXPECT_LT(Sim().actual_position_mm, 20);
  std::printf("stale move from 10 mm towards 50 mm halted at %.3f mm\n", Sim().actual_position_mm);
  const DriveStatus st = test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return s.state == DriveState::kFault; }, kWait);
  ASSERT_EQ(st.state, DriveState::kFault);
  EXPECT_EQ(st.fault.code, kFaultStaleMotionCommand);
  EXPECT_NE(st.fault.text.find("stale motion command re-executed (network reordering)"),
            std::string::npos)
      << st.fault.text;
  EXPECT_EQ(Udp().stale_motion_commands(), 1u);
  // No motion and no Enable until acknowledged.
  auto refused = drive_->Move(MoveAbsolute{5, 400, 10000, 10000});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_FALSE(drive_->Enable().ok());

  const double held_mm = Sim().demand_position_mm;
  auto ack = drive_->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(
      test_support::WaitStatus(
          *drive_, [](const DriveStatus& s) { return s.state == DriveState::kEnabled; }, kWait)
          .state,
      DriveState::kEnabled);
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(StartedTargets(), started);  // T14: nothing resumed
  EXPECT_NEAR(Sim().demand_position_mm, held_mm, 1e-3);
  MoveDone(MoveAbsolute{5, 400, 10000, 10000}, 5);
  EXPECT_EQ(Udp().stale_motion_commands(), 1u);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
