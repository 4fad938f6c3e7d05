// The drive-side watchdog of issue 11 (decision 1483). The simulated STOBER axis as a CANopen
// node on its own (SlaveNode + AxisDevice, time given by the test): after the first heartbeat of
// the producer in 1016h:01, a silence longer than the consumer time is an EMCY 8130h and the
// 6007h reaction (quick stop with the quick-stop deceleration, then Switch on disabled), in the
// motion log; heartbeats that keep coming change nothing. And StoberDrive::Configure against the
// simulated axis on the UDP bus: the master produces its own heartbeat, and the node holds
// 1016h:01 = (master node << 16) | heartbeat_timeout and 6007h = 3 afterwards.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include "adapters/canopen/emcy.h"
#include "adapters/canopen/master_pool.h"
#include "adapters/canopen/nmt.h"
#include "adapters/stober/drive.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "sim/canopen/node.h"
#include "sim/stober/axis_device.h"
#include "sim/stober/server.h"
#include "tests/adapters/stober/test_axis.h"
#include "tests/support/wait_status.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
namespace co = drivegw::canopen;
namespace ss = drivegw::sim::stober;
namespace sc = drivegw::sim::canopen;

constexpr uint8_t kNode = 5;
constexpr uint8_t kMaster = 126;
constexpr uint16_t kConsumerMs = 300;
constexpr double kQuickStopDeceleration = 2000;  // u/s²
constexpr double kQuickStopJerk = 200000;        // u/s³
constexpr double kVelocity = 100;                // u/s

std::vector<uint8_t> Le(uint32_t v, int bytes) {
  std::vector<uint8_t> out;
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
  return out;
}

class SimWatchdogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ss::AxisDeviceOptions o;
    o.core.start_operation_enabled = true;
    o.core.quick_stop_deceleration = kQuickStopDeceleration;
    o.core.quick_stop_jerk = kQuickStopJerk;
    device_ = std::make_unique<ss::AxisDevice>(o);
    sc::SlaveNodeOptions n;
    n.node_id = kNode;
    auto node = sc::SlaveNode::Create(n, device_.get());
    ASSERT_TRUE(node.ok()) << node.status();
    node_ = *std::move(node);
    node_->Boot(now_);
    // What the gateway's Configure writes, through the bus side of the dictionary.
    sc::ObjectDictionary& od = node_->dictionary();
    ASSERT_TRUE(od.Write(0x1016, 1, Le(uint32_t{kMaster} << 16 | kConsumerMs, 4)).ok());
    ASSERT_TRUE(od.Write(kAbortConnectionOption, 0, Le(kAbortQuickStop, 2)).ok());
    node_->OnFrame(*co::EncodeNmt({co::NmtCommand::kStart, kNode}), now_);
    ASSERT_EQ(node_->state(), co::NmtState::kOperational);
    node_->TakeFrames();
  }

  void StartMove(double target) {
    ss::MotionCore& c = device_->core();
    c.SetReferenced(true);
    for (const auto& [id, v] : {std::pair<const char*, double>{"A515", 0x0F},
                                {"I403", target},
                                {"I404", kVelocity},
                                {"I405", 1000},
                                {"I406", 1000},
                                {"I401", 1}}) {
      ASSERT_TRUE(c.Write(P(id), v).ok()) << id;
    }
    ASSERT_TRUE(c.Write(P("I402"), 1).ok());
  }
  void Heartbeat() {
    node_->OnFrame(*co::EncodeErrorControl({kMaster, co::NmtState::kOperational, false}), now_);
    last_heartbeat_ = now_;
  }
  void Advance(Duration d) {
    now_ += d;
    node_->Advance(now_);
    for (const transport::CanFrame& f : node_->TakeFrames()) frames_.push_back(f);
  }
  double Position() { return device_->core().actual_position_unwrapped(); }
  // The 6007h reaction in the motion log (number 0, cause = the EMCY code).
  const ss::Event* Reaction() {
    for (const ss::Event& e : device_->core().events()) {
      if (e.number == 0 && e.cause == co::emcy_code::kLifeGuardHeartbeat) return &e;
    }
    return nullptr;
  }
  bool SentEmcy(uint16_t code) {
    for (const transport::CanFrame& f : frames_) {
      auto e = co::DecodeEmcy(f);
      if (e.ok() && e->error_code == code) return true;
    }
    return false;
  }

  TimePoint now_{};
  TimePoint last_heartbeat_{};
  std::unique_ptr<ss::AxisDevice> device_;
  std::unique_ptr<sc::SlaveNode> node_;
  std::vector<transport::CanFrame> frames_;
};

TEST_F(SimWatchdogTest, HeartbeatsStop_QuickStopWithinConsumerTimeThenSwitchOnDisabled) {
  StartMove(1000);  // 10 s of travel at 100 u/s
  for (int ms = 0; ms < 1000; ms += 10) {
    if (ms % 50 == 0) Heartbeat();
    Advance(10ms);
  }
  ASSERT_EQ(Reaction(), nullptr) << "reacted while heartbeats came";
  const double before = Position();
  Advance(50ms);
  ASSERT_GT(Position(), before + 1) << "the move did not run";
  // The gateway dies: no heartbeat any more. Detection after the consumer time (CiA 301: more
  // than 300 ms since the last heartbeat), within one 10 ms step.
  Duration detected{};
  while (Reaction() == nullptr && now_ - last_heartbeat_ < 2s) Advance(10ms);
  ASSERT_NE(Reaction(), nullptr) << "no 6007h reaction 2 s after the last heartbeat";
  detected = now_ - last_heartbeat_;
  EXPECT_GT(detected, Duration(std::chrono::milliseconds(kConsumerMs)));
  EXPECT_LE(detected, Duration(std::chrono::milliseconds(kConsumerMs + 10)));
  EXPECT_THAT(Reaction()->text, HasSubstr("heartbeat of node 126 lost"));
  EXPECT_THAT(Reaction()->text, HasSubstr("6007h = 3 quick stop"));
  EXPECT_TRUE(SentEmcy(co::emcy_code::kLifeGuardHeartbeat)) << "CiA 301: EMCY 8130h";
  const double at_detection = Position();
  // Quick-stop ramp: about v / a + a / j = 60 ms; then the position holds and the drive is Switch
  // on disabled (6007h = 3 → transition 11; quick stop option 2 → 12, decision 1143).
  Advance(100ms);
  const double stopped = Position();
  Advance(500ms);
  EXPECT_DOUBLE_EQ(Position(), stopped) << "still moving after the quick stop";
  // Jerk-limited ramp: v²/2a plus v·a/2j for the jerk phases (2.5 + 0.5 u).
  const double braking = kVelocity * kVelocity / (2 * kQuickStopDeceleration) +
                         kVelocity * kQuickStopDeceleration / (2 * kQuickStopJerk);
  EXPECT_LE(stopped - at_detection, braking + kVelocity * 0.002);
  EXPECT_LT(stopped, 1000);
  EXPECT_EQ(device_->core().power_state(), ss::PowerState::kSwitchOnDisabled);
  // 1029h:01 = 0 (the default): the node also left OPERATIONAL (CiA 301, decision 1130).
  EXPECT_EQ(node_->state(), co::NmtState::kPreOperational);
}

TEST_F(SimWatchdogTest, HeartbeatsKeepComing_TheMoveRunsToItsTarget) {
  StartMove(150);  // 1.5 s plus ramps
  for (int ms = 0; ms < 3000; ms += 10) {
    if (ms % 100 == 0) Heartbeat();  // 100 ms < 300 ms consumer time
    Advance(10ms);
  }
  EXPECT_EQ(Reaction(), nullptr);
  EXPECT_FALSE(SentEmcy(co::emcy_code::kLifeGuardHeartbeat));
  EXPECT_NEAR(Position(), 150, 1e-6);
  EXPECT_EQ(device_->core().power_state(), ss::PowerState::kOperationEnabled);
  EXPECT_EQ(node_->state(), co::NmtState::kOperational);
}

TEST_F(SimWatchdogTest, NoSupervisionBeforeTheFirstHeartbeat) {
  // CiA 301 §7.2.8.3.2.3: monitoring starts with the first heartbeat of the producer.
  StartMove(150);
  for (int ms = 0; ms < 1000; ms += 10) Advance(10ms);
  EXPECT_EQ(Reaction(), nullptr);
  EXPECT_EQ(device_->core().power_state(), ss::PowerState::kOperationEnabled);
}

TEST_F(SimWatchdogTest, OptionCodeZeroKeepsMoving_OutOfRangeRefused) {
  sc::ObjectDictionary& od = node_->dictionary();
  EXPECT_FALSE(od.Write(kAbortConnectionOption, 0, Le(4, 2)).ok());
  ASSERT_TRUE(od.Write(kAbortConnectionOption, 0, Le(kAbortNoAction, 2)).ok());
  StartMove(1000);
  Heartbeat();
  for (int ms = 0; ms < 600; ms += 10) Advance(10ms);
  // Lost (EMCY) but 6007h = 0: no action, the axis keeps its move (why 3 is configured).
  EXPECT_TRUE(SentEmcy(co::emcy_code::kLifeGuardHeartbeat));
  const double p = Position();
  Advance(100ms);
  EXPECT_GT(Position(), p + 5);
  EXPECT_EQ(device_->core().power_state(), ss::PowerState::kOperationEnabled);
}

// ---------------------------------------------------------------- Configure

constexpr char kGroup[] = "239.74.163.98";

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

class ConfigureWatchdogTest : public ::testing::Test {
 protected:
  void Start(uint8_t master_node_id) {
    bus_.kind = CanBusConfig::Kind::kUdpMulticast;
    bus_.group = kGroup;
    bus_.port = RandomPort();
    ss::AxisServerOptions o;
    o.node_id = kNode;
    o.can = bus_;
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    SetTestAxis(config_, "wd", bus_, kNode);
    config_.canopen.heartbeat_timeout = 200ms;
    config_.canopen.sdo_timeout = 300ms;
    config_.canopen.master_node_id = master_node_id;
    auto drive = CreateStoberDrive(config_, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_.reset(static_cast<StoberDrive*>(drive->release()));
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus s = test_support::WaitStatus(
        *drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, 5s);
    ASSERT_NE(s.state, DriveState::kOffline) << s.native.text;
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  CanBusConfig bus_;
  DriveConfig config_;
  std::unique_ptr<ss::AxisServer> server_;
  std::unique_ptr<StoberDrive> drive_;
};

TEST_F(ConfigureWatchdogTest, WritesConsumerAndQuickStopOption_MasterProducesHeartbeat) {
  Start(127);  // the default
  EXPECT_EQ(server_->ReadObject(0x1016, 1).value_or(-1), int64_t{127} << 16 | 200);
  EXPECT_EQ(server_->ReadObject(kAbortConnectionOption, 0).value_or(-1), kAbortQuickStop);
  auto master = co::CanopenMasterPool::Instance().Acquire(bus_);
  ASSERT_TRUE(master.ok());
  const uint64_t sent = (*master)->counters().own_heartbeats_sent;
  std::this_thread::sleep_for(300ms);  // 6 periods of 50 ms
  EXPECT_GE((*master)->counters().own_heartbeats_sent, sent + 2);
  // The node saw them: its consumer is armed and has not timed out while the gateway lives.
  bool reacted = false;
  server_->WithAxis([&](ss::MotionCore& c) {
    for (const ss::Event& e : c.events()) reacted |= e.number == 0;
  });
  EXPECT_FALSE(reacted);
  // The master's own heartbeat is no node of the bus.
  EXPECT_FALSE((*master)->node_state(127).has_value());
}

TEST_F(ConfigureWatchdogTest, MasterNodeIdZero_ClearsTheConsumerAndLeaves6007h) {
  Start(0);
  EXPECT_EQ(server_->ReadObject(0x1016, 1).value_or(-1), 0);
  EXPECT_EQ(server_->ReadObject(kAbortConnectionOption, 0).value_or(-1), kAbortFault);
}

TEST(ConfigureWatchdogConfigTest, MasterNodeIdEqualToTheDrivesIsRefusedNamingBoth) {
  DriveConfig c;
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = 30000;
  SetTestAxis(c, "wd", bus, 9);
  c.canopen.master_node_id = 9;
  auto drive = CreateStoberDrive(c, SteadyClock::Instance());
  ASSERT_FALSE(drive.ok());
  EXPECT_THAT(drive.status().message(), HasSubstr("canopen.master_node_id"));
  EXPECT_THAT(drive.status().message(), HasSubstr("node_id 9"));
}

}  // namespace
}  // namespace drivegw::stober
