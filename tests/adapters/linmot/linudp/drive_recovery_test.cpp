// Safe recovery, LinUDP (issue 11 "Safe recovery", decision 1451): after link loss, a drive reset
// and a fault acknowledge, re-enabling sends no stale target. The MC interface executes a motion
// command only when the command count in the MC header changes (linmot-mc.md "Motion Command
// Interface": count/toggle, state var echo); a drive that rebooted has forgotten its count, so
// a header still carrying the last move with a non-zero count would be executed again once the
// drive is in Operation Enabled. The simulator counts every MC command it interpreted
// (executed or rejected) — that record, and the drive's demand position, must not change from the
// loss to the re-enable.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <thread>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/error_codes.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotServer;
using sim::linmot::SimOptions;

constexpr auto kWait = 20s;  // generous: the host runs at load 6-10

class LinUdpRecoveryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SimOptions o = test_support::LinUdpSimOptions();
    o.boot_time = 300ms;
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    DriveConfig c = test_support::LinUdpDriveConfig(server_->port());
    auto drive = CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
    ASSERT_NE(Wait([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
              DriveState::kOffline);
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
  }

  DriveStatus Wait(const std::function<bool(const DriveStatus&)>& pred) {
    return test_support::WaitStatus(*drive_, pred, kWait);
  }
  sim::linmot::DeviceSnapshot Sim() { return server_->Snapshot().device; }
  uint64_t Interpreted() {
    const auto d = Sim();
    return d.mc_commands_executed + d.mc_commands_rejected;
  }
  static bool WaitFor(const std::function<bool()>& pred) {
    return test_support::WaitFor(pred, kWait);
  }
  void Enable() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }
  // Starts a slow move to 120 mm and waits until the slider is under way.
  void StartSlowMove() {
    auto r = drive_->Move(MoveAbsolute{120, 40, 400, 400});
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_TRUE(WaitFor([&] { return Sim().motion_active && Sim().actual_position_mm > 15; }));
  }
  // From the recovery on: acknowledge when needed, enable, let 50 telegrams go both ways; the
  // drive interpreted no MC command and its demand position is where the drive left it.
  void ReEnableAndExpectNothingResent(uint64_t interpreted, double demand_mm) {
    if (drive_->GetStatus().state == DriveState::kFault) {
      auto ack = drive_->AcknowledgeFault();
      ASSERT_TRUE(ack.ok()) << ack.status();
    }
    EXPECT_EQ(Interpreted(), interpreted) << "MC command interpreted before the re-enable";
    Enable();
    const uint64_t from = drive_->link_health().replies;
    ASSERT_TRUE(WaitFor([&] { return drive_->link_health().replies >= from + 50; }));
    const auto sim = Sim();
    EXPECT_EQ(sim.mc_commands_executed + sim.mc_commands_rejected, interpreted)
        << "stale MC command executed on re-enable";
    EXPECT_FALSE(sim.motion_active);
    EXPECT_NEAR(sim.demand_position_mm, demand_mm, 1e-4);  // 0.1 um: the wire unit
    // Only a new command moves it.
    auto mv = drive_->Move(MoveAbsolute{60, 500, 5000, 5000});
    ASSERT_TRUE(mv.ok()) << mv.status();
    EXPECT_EQ(test_support::WaitCommandFinal(*drive_, mv->id, kWait).state, CommandState::kDone);
    EXPECT_EQ(Interpreted(), interpreted + 1);
  }

  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(LinUdpRecoveryTest, LinkLossMidMove_ReEnableSendsNoStaleTarget) {
  Enable();
  StartSlowMove();
  server_->SetAnswering(false);
  ASSERT_EQ(Wait([](const DriveStatus& s) { return s.state == DriveState::kOffline; }).state,
            DriveState::kOffline);
  // The drive ends the move on its own (the simulator has no telegram watchdog).
  ASSERT_TRUE(WaitFor([&] { return !Sim().motion_active; }));
  const uint64_t interpreted = Interpreted();
  const double demand = Sim().demand_position_mm;
  server_->SetAnswering(true);
  ASSERT_NE(Wait([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
            DriveState::kOffline);
  ReEnableAndExpectNothingResent(interpreted, demand);
}

// RTC 0x30 restarts the drive: the count it remembers starts again, so the last move still
// in the gateway's MC block would differ from it.
TEST_F(LinUdpRecoveryTest, DriveResetAfterMove_ReEnableSendsNoStaleTarget) {
  Enable();
  auto mv = drive_->Move(MoveAbsolute{100, 500, 5000, 5000});
  ASSERT_TRUE(mv.ok()) << mv.status();
  ASSERT_EQ(test_support::WaitCommandFinal(*drive_, mv->id, kWait).state, CommandState::kDone);
  auto r = drive_->SendNative(LinMotRtcRequest{0x30, 0, 0, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(Sim().boots, 1u);
  ASSERT_NE(Wait([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
            DriveState::kOffline);
  // Power-up after the reboot: wherever the slider is, that is where it must stay.
  ASSERT_TRUE(WaitFor([&] { return !Sim().booting; }));
  ReEnableAndExpectNothingResent(Interpreted(), Sim().demand_position_mm);
}

TEST_F(LinUdpRecoveryTest, FaultMidMoveThenAcknowledge_ReEnableSendsNoStaleTarget) {
  Enable();
  StartSlowMove();
  ASSERT_TRUE(server_->RaiseError(mc::kPwrVoltageTooLow).ok());  // quick stop (D-34)
  ASSERT_EQ(Wait([](const DriveStatus& s) { return s.state == DriveState::kFault; }).state,
            DriveState::kFault);
  ASSERT_TRUE(WaitFor([&] { return !Sim().motion_active; }));
  const double demand = Sim().demand_position_mm;
  EXPECT_LT(demand, 119);  // stopped short of the target
  ReEnableAndExpectNothingResent(Interpreted(), demand);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
