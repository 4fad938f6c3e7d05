// The gateway's STOBER drive (CreateStoberDrive, Drive API) and the simulated STOBER axis
// (sim/stober AxisServer) on a kernel CAN bus: SocketCAN vcan0 in the socketcan-vm stage
// (issue 5 "SocketCAN VM test"). Skips without DGW_CAN_IFACE: this host's kernel has no CAN;
// tests/adapters/stober/drive runs the same drive on the user-space bus. Waits are bounded by
// the drive's WaitForStatus; nothing asserts timing by sleeping.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/stober/factory.h"
#include "sim/stober/server.h"
#include "tests/adapters/stober/test_axis.h"
#include "tests/support/wait_status.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
namespace ss = drivegw::sim::stober;

constexpr uint8_t kNode = 11;

CanBusConfig KernelBus(const std::string& iface) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kSocketCan;
  bus.interface = iface;
  return bus;
}

// busybox `ip` in the VM (PATH=/bin); the VM's /init recreates vcan0 before each test.
int SetLink(const std::string& iface, bool up) {
  const std::string cmd = "ip link set " + iface + (up ? " up" : " down");
  return std::system(cmd.c_str());
}

class StoberVcanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* iface = std::getenv("DGW_CAN_IFACE");
    if (iface == nullptr) GTEST_SKIP() << "DGW_CAN_IFACE not set: runs in tests/socketcan-vm";
    iface_ = iface;
    ss::AxisServerOptions o;
    o.node_id = kNode;
    o.can = KernelBus(iface_);
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    DriveConfig c;
    // Emulated (TCG) VM: generous deadlines, short heartbeat (50 ms) so the loss shows quickly.
    SetTestAxis(c, "sv1", KernelBus(iface_), kNode);
    c.canopen.heartbeat_timeout = 300ms;
    c.canopen.sdo_timeout = 1000ms;
    auto drive = CreateStoberDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (!iface_.empty()) SetLink(iface_, true);
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::steady_clock::duration timeout = 15s) {
    return test_support::WaitStatus(*drive_, pred, timeout);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, 15s); }
  void EnableAndMove(double target) {
    auto en = drive_->Enable();
    ASSERT_TRUE(en.ok()) << en.status();
    EXPECT_EQ(en->state, CommandState::kDone);
    auto mv = drive_->Move(MoveAbsolute{target, 500, 5000, 5000});
    ASSERT_TRUE(mv.ok()) << mv.status();
    const CommandInfo end = WaitFinal(mv->id);
    EXPECT_EQ(end.state, CommandState::kDone) << end.message;
    // TPDO2 (inhibit 10 ms, decision 1175) may trail the Done of TPDO1.
    const DriveStatus s =
        WaitUntil([&](const DriveStatus& s) { return std::abs(s.position_mm - target) < 1e-6; });
    EXPECT_NEAR(s.position_mm, target, 1e-6);
    EXPECT_EQ(s.state, DriveState::kEnabled);
  }

  std::string iface_;
  std::unique_ptr<ss::AxisServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(StoberVcanTest, ActivateEnableMoveAbsoluteAndSdoAbortName_OnKernelCan) {
  const DriveStatus online =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_NE(online.state, DriveState::kOffline)
      << "no heartbeat on " << iface_ << ": " << online.native.text;
  server_->WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
  EnableAndMove(40);

  CanOpenSdoRequest type;
  type.index = 0x1000;  // device type: CiA 402 servo (sim/stober/server.h kDeviceTypeServo)
  auto t = drive_->SendNative(type);
  ASSERT_TRUE(t.ok()) << t.status();
  EXPECT_EQ(t->data, (std::vector<uint8_t>{0x92, 0x01, 0x02, 0x00}));
  CanOpenSdoRequest missing;
  missing.index = 0x5FFF;
  auto m = drive_->SendNative(missing);
  ASSERT_FALSE(m.ok());
  EXPECT_THAT(std::string(m.status().message()),
              HasSubstr("SDO abort 0x06020000 object does not exist"));
}

TEST_F(StoberVcanTest, LinkDownGoesOfflineAndComesBack_OnKernelCan) {
  ASSERT_NE(WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
            DriveState::kOffline);
  server_->WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
  EnableAndMove(10);

  ASSERT_EQ(SetLink(iface_, false), 0) << "ip link set " << iface_ << " down";
  DriveStatus s = WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  ASSERT_EQ(s.state, DriveState::kOffline);
  // The master sees the interface go down (ENETDOWN) or the heartbeat stop, whichever first.
  EXPECT_THAT(s.native.text,
              ::testing::AnyOf(HasSubstr("down"), HasSubstr("heartbeat"), HasSubstr("link")));
  EXPECT_EQ(drive_->Move(MoveAbsolute{0, 100, 1000, 1000}).status().code(),
            absl::StatusCode::kUnavailable);

  ASSERT_EQ(SetLink(iface_, true), 0) << "ip link set " << iface_ << " up";
  s = WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; }, 20s);
  ASSERT_NE(s.state, DriveState::kOffline) << s.native.text;
  // Back on line the axis works again (re-enabled if the reconfiguration left it disabled).
  EnableAndMove(-25);
}

}  // namespace
}  // namespace drivegw::stober
