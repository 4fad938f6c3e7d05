// The gateway's Trinamic drive (CreateTrinamicDrive, Drive API) and the simulated SIXpack on CAN
// (sim/trinamic TrinamicCanServer) on a kernel CAN bus: SocketCAN vcan0 in the socketcan-vm stage.
// Skips without DGW_CAN_IFACE: this host's kernel has no CAN; tests/adapters/trinamic/drive runs
// the same drive on the user-space bus. Waits are bounded by the drive's WaitForStatus.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/trinamic/factory.h"
#include "sim/trinamic/can_server.h"
#include "tests/support/wait_status.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;
using sim::trinamic::Controller;
using sim::trinamic::TrinamicCanServer;

CanBusConfig KernelBus(const std::string& iface) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kSocketCan;
  bus.interface = iface;
  return bus;
}

class TrinamicVcanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* iface = std::getenv("DGW_CAN_IFACE");
    if (iface == nullptr) GTEST_SKIP() << "DGW_CAN_IFACE not set: runs in tests/socketcan-vm";
    sim::trinamic::CanServerOptions o;
    o.can = KernelBus(iface);
    auto s = TrinamicCanServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(s.ok()) << s.status();
    sim_ = *std::move(s);

    // 1 mm = 1 microstep; limits fit the PACK defaults (trinamic-sixpack.md §5.1, §5.3).
    DriveConfig c;
    c.name = "tv1";
    c.family = kFamilyName;
    c.axis.min_mm = -20000;
    c.axis.max_mm = 20000;
    c.axis.max_velocity_mm_s = 26000;
    c.axis.max_acceleration_mm_s2 = 120000;
    c.timeouts.request = 3000ms;
    c.timeouts.accept = 300ms;  // emulated (TCG) VM
    TrinamicConfig t;
    t.address = 1;
    t.axis = 2;
    t.axes = 6;
    t.microsteps_per_unit = 1;
    t.poll_period = 10ms;
    t.reply_timeout = 200ms;
    t.offline_after_misses = 3;
    t.can = KernelBus(iface);
    c.trinamic = t;
    auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(d.ok()) << d.status();
    drive_ = *std::move(d);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (sim_) sim_->Stop();
  }
  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred) {
    return test_support::WaitStatus(*drive_, pred, 15s);
  }

  std::unique_ptr<TrinamicCanServer> sim_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(TrinamicVcanTest, MoveAndUnitInformation_OnKernelCan) {
  const DriveStatus online =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_EQ(online.state, DriveState::kDisabled) << online.native.text;
  auto en = drive_->Enable();
  ASSERT_TRUE(en.ok()) << en.status();

  auto mv = drive_->Move(MoveAbsolute{-777, 10000, 60000, 0});
  ASSERT_TRUE(mv.ok()) << mv.status();
  WaitUntil([&](const DriveStatus&) { return IsFinal(drive_->GetCommand(mv->id)->state); });
  EXPECT_EQ(drive_->GetCommand(mv->id)->state, CommandState::kDone)
      << drive_->GetCommand(mv->id)->message;
  int32_t pos = 0;
  sim_->WithController([&](Controller& c) { pos = c.state(2).position; });
  EXPECT_EQ(pos, -777);

  // $43 unit information (trinamic-sixpack.md "$43 Unit information", L845-855): reply byte 0
  // is 43h, byte 1 the firmware revision (the simulator reports V1.4.8 = 148).
  auto r = drive_->SendNative(TrinamicRequest{0x43, {0x55, 0, 0, 0, 0, 0, 0}});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->data.size(), 8u);
  EXPECT_EQ(r->data[0], 0x43);
  EXPECT_EQ(r->data[1], 148);
}

}  // namespace
}  // namespace drivegw::trinamic
