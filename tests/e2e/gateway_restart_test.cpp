// Safe recovery across a gateway restart (issue 11, docs/reliability.md "Safe recovery", gap 11;
// decision 1451): the simulated drive lives OUTSIDE the gateway and survives it. A gateway moves
// the axis to A, starts a slow move to B and is stopped mid-move; a new gateway starts and enables
// the drive. The simulator's own record (commands it executed, Execute edges, words it received)
// must show that nothing was re-sent on start-up or on enable — neither B nor A — the axis stays
// where the drive left it, and only a new command moves it. One test per family.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "server/gateway.h"
#include "tests/e2e/recovery_sims.h"
#include "tests/support/wait_status.h"

namespace drivegw {
namespace {

using std::chrono::seconds;
using test_support::WaitCommandFinal;
using test_support::WaitStatus;

constexpr auto kLong = seconds(30);  // generous: the host runs at load 6-10

using test_support::FamilySim;
using Scenario = FamilySim;

class GatewayRestartTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    data_dir_ = (std::filesystem::temp_directory_path() /
                 (std::string("dgw-restart-") + info->name() + "-" + std::to_string(::getpid())))
                    .string();
    std::filesystem::remove_all(data_dir_);
    std::filesystem::create_directories(data_dir_);
  }
  void TearDown() override { std::filesystem::remove_all(data_dir_); }

  std::unique_ptr<server::Gateway> StartGateway(const DriveConfig& drive) {
    server::GatewayOptions o;
    o.config.listen.grpc = "127.0.0.1:0";
    o.config.listen.http = "127.0.0.1:0";
    o.config.data_dir = data_dir_;
    o.config.demo = false;  // the one drive below, against the simulator this test owns
    o.config.drives = {drive};
    auto gw = server::Gateway::Start(o);
    EXPECT_TRUE(gw.ok()) << gw.status();
    return gw.ok() ? std::move(*gw) : nullptr;
  }

  static Drive& TheDrive(server::Gateway& gw) { return *gw.core().drives().front(); }

  // Waits (polling the simulator, which publishes no events) until `pred` holds or kLong passes.
  static bool WaitSim(const std::function<bool()>& pred) {
    const auto deadline = std::chrono::steady_clock::now() + kLong;
    while (!pred()) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  static bool Online(const DriveStatus& s) { return s.state != DriveState::kOffline; }

  // Lets the new gateway's session run: `n` more replies of the drive on its link (requests and
  // answers went both ways that often) — a count of exchanges, not a time.
  static void Exchanges(const Drive& d, uint64_t n) {
    const uint64_t from = d.link_health().replies;
    EXPECT_TRUE(WaitSim([&] { return d.link_health().replies >= from + n; }))
        << "the drive answered " << d.link_health().replies - from << " of " << n << " requests";
  }

  void Run(Scenario& sc) {
    // --- First gateway: A, then a slow move to B, stopped mid-move.
    double stopped_at = 0;
    {
      auto gw = StartGateway(sc.drive);
      ASSERT_NE(gw, nullptr);
      Drive& d = TheDrive(*gw);
      ASSERT_TRUE(Online(WaitStatus(d, Online, kLong))) << "first gateway never saw the drive";
      if (d.GetStatus().state == DriveState::kFault) {
        ASSERT_TRUE(d.AcknowledgeFault().ok());
      }
      auto en = d.Enable();
      ASSERT_TRUE(en.ok()) << en.status();
      ASSERT_EQ(WaitCommandFinal(d, en->id, kLong).state, CommandState::kDone);
      if (sc.home_first) {
        auto home = d.Home();
        ASSERT_TRUE(home.ok()) << home.status();
        ASSERT_EQ(WaitCommandFinal(d, home->id, kLong).state, CommandState::kDone);
      }
      auto a = d.Move(sc.to_a);
      ASSERT_TRUE(a.ok()) << a.status();
      ASSERT_EQ(WaitCommandFinal(d, a->id, kLong).state, CommandState::kDone);
      ASSERT_NEAR(sc.sim.position_mm(), sc.to_a.position_mm, sc.standstill_tolerance_mm);
      auto b = d.Move(sc.to_b);
      ASSERT_TRUE(b.ok()) << b.status();
      // Mid-move: the axis left A and is still moving toward B.
      ASSERT_TRUE(WaitSim([&] {
        return sc.sim.moving() && std::abs(sc.sim.position_mm() - sc.to_a.position_mm) >
                                      0.1 * std::abs(sc.to_b.position_mm - sc.to_a.position_mm);
      })) << "move to B never got under way";
      stopped_at = sc.sim.position_mm();
      gw.reset();  // Gateway::Stop: servers, drives and sessions go; the simulator stays
    }
    ASSERT_LT(std::abs(stopped_at - sc.to_b.position_mm),
              std::abs(sc.to_b.position_mm - sc.to_a.position_mm))
        << "the stop did not land mid-move";
    // Whatever the drive does on its own when its master goes silent (finish the profile, brake
    // on a watchdog), it is the drive's doing; wait for its standstill and remember it.
    ASSERT_TRUE(WaitSim([&] { return !sc.sim.moving(); })) << "simulated axis never stood";
    const double rest = sc.sim.position_mm();
    std::cout << "restart: A=" << sc.to_a.position_mm << " B=" << sc.to_b.position_mm
              << " stopped at " << stopped_at << " drive came to rest at " << rest << "\n";
    sc.sim.mark();
    const uint64_t commands_before = sc.sim.motion_commands();

    // --- Second gateway: start-up and enable send no motion command, the axis keeps still.
    auto gw = StartGateway(sc.drive);
    ASSERT_NE(gw, nullptr);
    Drive& d = TheDrive(*gw);
    ASSERT_TRUE(Online(WaitStatus(d, Online, kLong))) << "second gateway never saw the drive";
    Exchanges(d, 20);
    EXPECT_EQ(sc.sim.motion_commands(), commands_before) << "motion command sent on start-up";
    EXPECT_NEAR(sc.sim.position_mm(), rest, sc.standstill_tolerance_mm) << "moved on start-up";
    if (d.GetStatus().state == DriveState::kFault) {
      auto ack = d.AcknowledgeFault();
      ASSERT_TRUE(ack.ok()) << ack.status();
      ASSERT_EQ(WaitCommandFinal(d, ack->id, kLong).state, CommandState::kDone);
    }
    auto en = d.Enable();
    ASSERT_TRUE(en.ok()) << en.status();
    ASSERT_EQ(WaitCommandFinal(d, en->id, kLong).state, CommandState::kDone);
    Exchanges(d, 40);
    const DriveStatus after = d.GetStatus();
    EXPECT_EQ(sc.sim.motion_commands(), commands_before) << "motion command sent on enable";
    EXPECT_FALSE(sc.sim.moving());
    EXPECT_NEAR(sc.sim.position_mm(), rest, sc.standstill_tolerance_mm) << "moved on enable";
    EXPECT_NEAR(after.position_mm, rest, sc.standstill_tolerance_mm);
    EXPECT_FALSE(after.motion_active);

    // --- Only a new command moves it.
    auto c = d.Move(sc.to_c);
    ASSERT_TRUE(c.ok()) << c.status();
    EXPECT_EQ(WaitCommandFinal(d, c->id, kLong).state, CommandState::kDone);
    EXPECT_GT(sc.sim.motion_commands(), commands_before);
    EXPECT_NEAR(sc.sim.position_mm(), sc.to_c.position_mm, sc.standstill_tolerance_mm);
  }

  std::string data_dir_;
};

TEST_F(GatewayRestartTest, LinUdp_RestartMidMove_NothingResentAxisStill) {
  auto f = test_support::StartLinUdpSim("r1");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayRestartTest, DeviceNet_RestartMidMove_NothingResentAxisStill) {
  auto f = test_support::StartDeviceNetSim("r2");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayRestartTest, Trinamic_RestartMidMove_NothingResentAxisStill) {
  auto f = test_support::StartTrinamicSim("r3", data_dir_);
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayRestartTest, Stober_RestartMidMove_NothingResentAxisStill) {
  auto f = test_support::StartStoberSim("r4");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

}  // namespace
}  // namespace drivegw
