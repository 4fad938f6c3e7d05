// The simulated LinMot DeviceNet drive on a kernel CAN bus (SocketCAN): runs in the socketcan-vm
// stage on vcan0 (DGW_CAN_IFACE), skips elsewhere (tests/socketcan-vm/README.md; issue 3).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <thread>

#include "adapters/linmot/devicenet/codec_can.h"
#include "adapters/transport/socketcan_channel.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/sim/linmot_devicenet/test_util.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;
using testing::F;
using testing::Text;

std::string Interface() {
  const char* iface = std::getenv("DGW_CAN_IFACE");
  return iface ? iface : "";
}

class VcanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (Interface().empty()) GTEST_SKIP() << "DGW_CAN_IFACE is not set (socketcan-vm runs this)";
    transport::SocketCanChannel::Options o;
    o.interface = Interface();
    auto master = transport::SocketCanChannel::Open(o);
    ASSERT_TRUE(master.ok()) << master.status();
    master_ = *std::move(master);
  }
  void Start(DnSimOptions options = testing::F1Options()) {
    options.can.kind = CanBusConfig::Kind::kSocketCan;
    options.can.interface = Interface();
    auto s = LinMotDnServer::Start(options, clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
  }
  std::string Expect(uint16_t id, milliseconds timeout = milliseconds(3000)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      auto f = master_->Receive(deadline - std::chrono::steady_clock::now());
      if (!f.ok() || !f->has_value()) continue;
      auto frame = dn::FromCanFrame(**f);
      if (frame.ok() && frame->id == id) return Text(*frame);
    }
    return "";
  }
  std::string Transact(std::string_view frame, uint16_t id,
                       milliseconds timeout = milliseconds(3000)) {
    EXPECT_TRUE(master_->Send(dn::ToCanFrame(F(frame))).ok());
    return Expect(id, timeout);
  }
  void Online() {
    ASSERT_EQ(Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
    clock_.Advance(seconds(1));
    ASSERT_EQ(Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
    clock_.Advance(seconds(1));
    const auto deadline = std::chrono::steady_clock::now() + seconds(5);
    while (server_->Snapshot().stack.network != NetworkState::kOnline &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(milliseconds(2));
    }
    ASSERT_EQ(server_->Snapshot().stack.network, NetworkState::kOnline);
    ASSERT_EQ(Transact("42E#00.4B.03.01.03.00", 0x42B), "42B#00.CB.00");
    ASSERT_EQ(Transact("42C#00.10.05.02.09.64.00", 0x42B), "42B#00.90.64.00");
    ASSERT_EQ(Transact("42C#00.10.05.01.09.00.00", 0x42B), "42B#00.90.00.00");
  }

  ManualClock clock_{TimePoint{} + std::chrono::hours(1)};
  std::unique_ptr<transport::SocketCanChannel> master_;
  std::unique_ptr<LinMotDnServer> server_;
};

// TC-01 and TC-12 on vcan0.
TEST_F(VcanTest, AllocationPollAndStatus_Tc01) {
  Start();
  Online();
  EXPECT_EQ(Transact("42D#00.00.00.00.00.00", 0x3C5), "3C5#01.10.02.00.00.00.00.00");
  EXPECT_EQ(Transact("42D#02.00.02.00.00.00", 0x3C5), "3C5#03.10.02.00.02.00.03.10");
  EXPECT_EQ(server_->bus_name(), Interface());
}

// TC-46 on vcan0: fragments both ways.
TEST_F(VcanTest, Example1Fragmentation_Tc46) {
  Start(testing::F3Options());
  Online();
  ASSERT_TRUE(master_->Send(dn::ToCanFrame(F("42D#00.00.00.18.20.00.00.00"))).ok());
  ASSERT_TRUE(master_->Send(dn::ToCanFrame(F("42D#41.00.00.00.00.00.00.00"))).ok());
  ASSERT_TRUE(master_->Send(dn::ToCanFrame(F("42D#42.00.00.00.00.00.00.00"))).ok());
  ASSERT_TRUE(master_->Send(dn::ToCanFrame(F("42D#83.00"))).ok());
  EXPECT_THAT(Expect(0x3C5), ::testing::StartsWith("3C5#00."));
  EXPECT_THAT(Expect(0x3C5), ::testing::StartsWith("3C5#41."));
  EXPECT_THAT(Expect(0x3C5), ::testing::StartsWith("3C5#42."));
  EXPECT_THAT(Expect(0x3C5), ::testing::StartsWith("3C5#83."));
}

// TC-18 / TC-06 on vcan0: a move on the injected clock, then Reset Controller.
TEST_F(VcanTest, MotionThenResetController) {
  Start();
  Online();
  Transact("42D#00.00.00.00.00.00", 0x3C5);
  Transact("42D#02.00.11.10.00.14", 0x3C5);
  for (int i = 0; i < 20; ++i) {
    clock_.Advance(milliseconds(90));
    Transact("42D#02.00.11.10.00.14", 0x3C5);
  }
  EXPECT_EQ(Transact("42D#02.00.18.10.00.00", 0x3C5), "3C5#03.10.02.00.18.10.00.14");
  ASSERT_TRUE(master_->Send(dn::ToCanFrame(F("42D#02.00.0F.00.00.00"))).ok());
  EXPECT_EQ(Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
  EXPECT_EQ(server_->Snapshot().device.controller_resets, 1u);
}

}  // namespace
}  // namespace drivegw::sim::linmot_devicenet
