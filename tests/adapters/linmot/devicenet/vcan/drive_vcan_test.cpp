// The gateway's DeviceNet drive and the simulated DeviceNet drive on a kernel CAN bus (SocketCAN,
// vcan0 in the socketcan-vm stage, issue 3). Skips without DGW_CAN_IFACE: this host's kernel
// has no CAN; the user-space bus runs the same scenario in tests/adapters/linmot/devicenet/drive.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <functional>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/linmot/devicenet/factory.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::devicenet {
namespace {

using namespace std::chrono_literals;
using sim::linmot_devicenet::DnSimOptions;
using sim::linmot_devicenet::LinMotDnServer;

CanBusConfig KernelBus(const char* iface) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kSocketCan;
  bus.interface = iface;
  return bus;
}

class DnDriveVcanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    iface_ = std::getenv("DGW_CAN_IFACE");
    if (iface_ == nullptr) GTEST_SKIP() << "DGW_CAN_IFACE not set: runs in tests/socketcan-vm";
    DnSimOptions so;
    so.can = KernelBus(iface_);
    so.mac_id = 7;
    so.duplicate_check_wait = 50ms;  // §5.7 timing shortened for tests
    auto server = LinMotDnServer::Start(so, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    DriveConfig c;
    c.name = "v1";
    c.family = kFamilyName;
    c.axis.min_mm = 0;
    c.axis.max_mm = 150;
    c.axis.max_velocity_mm_s = 1000;
    c.axis.max_acceleration_mm_s2 = 20000;
    c.can = KernelBus(iface_);
    c.mac_id = 7;
    DnDriveOptions d;
    d.session.duplicate_check_wait = 50ms;
    drive_ = std::make_unique<LinMotDnDrive>(c, SteadyClock::Instance(), d);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred) {
    return test_support::WaitStatus(*drive_, pred, 20s);
  }

  const char* iface_ = nullptr;
  std::unique_ptr<LinMotDnServer> server_;
  std::unique_ptr<LinMotDnDrive> drive_;
};

TEST_F(DnDriveVcanTest, BringUpEnableHomeMove_OnKernelCan) {
  const DriveStatus online =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_NE(online.state, DriveState::kOffline) << "no poll response on " << iface_;

  auto en = drive_->Enable();
  ASSERT_TRUE(en.ok()) << en.status();
  EXPECT_EQ(en->state, CommandState::kDone);

  auto home = drive_->Home();
  ASSERT_TRUE(home.ok()) << home.status();
  const DriveStatus homed =
      WaitUntil([](const DriveStatus& s) { return s.homed && s.state == DriveState::kEnabled; });
  ASSERT_TRUE(homed.homed);

  auto mv = drive_->Move(MoveAbsolute{40, 500, 5000, 5000});
  ASSERT_TRUE(mv.ok()) << mv.status();
  const uint64_t id = mv->id;
  WaitUntil([&](const DriveStatus&) { return IsFinal(drive_->GetCommand(id)->state); });
  EXPECT_EQ(drive_->GetCommand(id)->state, CommandState::kDone) << drive_->GetCommand(id)->message;
  EXPECT_NEAR(drive_->GetStatus().position_mm, 40, 0.05);
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
