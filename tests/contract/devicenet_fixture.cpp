// Contract fixture of the LinMot DeviceNet family (the simulated drive of sim/linmot_devicenet on
// the user-space CAN bus, the drive from CreateLinMotDnDrive), plus the reference's §13 cases a
// master can observe, named by their ids (linmot-devicenet.md §13).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <thread>

#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/commands.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/linmot/devicenet/factory.h"
#include "adapters/transport/can_channel.h"
#include "sim/linmot_devicenet/device.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/contract/family_fixture.h"
#include "tests/support/wait_status.h"

namespace drivegw::contract {
namespace {

using namespace std::chrono_literals;
namespace dn = linmot::devicenet;
using sim::linmot_devicenet::DnSimOptions;
using sim::linmot_devicenet::LinMotDnDevice;
using sim::linmot_devicenet::LinMotDnServer;

constexpr char kGroup[] = "239.74.163.95";  // not python-can's default: no stray traffic
constexpr auto kWait = 10s;

// A port no other test (here or in a concurrent ctest process) uses at the same time.
uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + 7 + next++) % 40000);
}

CanBusConfig Bus(uint16_t port) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = port;
  return bus;
}

DriveConfig Config(uint16_t port, uint8_t mac) {
  DriveConfig c;
  c.name = "c1";
  c.family = dn::kFamilyName;
  c.axis.min_mm = 0;
  c.axis.max_mm = 150;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 20000;
  c.can = Bus(port);
  c.mac_id = mac;
  return c;
}

class LinMotDnFixture final : public FamilyFixture {
 public:
  absl::Status Start(DriveRegistry& registry) override {
    const uint16_t port = UniquePort();
    DnSimOptions o;
    o.name = "contract-linmot-dn";
    o.can = Bus(port);
    o.duplicate_check_wait = 50ms;
    auto server = LinMotDnServer::Start(o, SteadyClock::Instance());
    if (!server.ok()) return server.status();
    server_ = std::move(*server);
    registry.Register(dn::kFamilyName, dn::CreateLinMotDnDrive);
    config_ = Config(port, o.mac_id);
    return absl::OkStatus();
  }
  DriveConfig config() const override { return config_; }
  void Stop() override {
    if (server_) server_->Stop();
  }

  absl::Status InjectFault(bool fatal) override {
    // §8.6: 0x8100 "Application needs DN servo controller" no reset cures (decision 986); 0x8118
    // "Range error" is latched until Reset Coded Error.
    return server_->RaiseCodedError(fatal ? dn::kCodedNeedsDnController : dn::kCodedRangeError);
  }
  absl::StatusOr<std::string> InjectWarning() override {
    server_->WithDevice(
        [](LinMotDnDevice& d) { d.SetMotorWarningCause(dn::Motor::kA, dn::kMotorTooHotCalc); });
    return std::string(dn::WordBitName(dn::WordKind::kMotorWarnState, 0));
  }
  absl::Status SetAnswering(bool answering) override {
    server_->SetDropPolls(!answering);
    return absl::OkStatus();
  }
  absl::StatusOr<ParameterRef> WritableParameter() const override {
    return ParameterRef{0x24, false};  // §8.9 (Rise) Curve Number, 0..63
  }
  int64_t WritableParameterValue() const override { return 5; }
  absl::StatusOr<ParameterRef> UnknownParameter() const override {
    return ParameterRef{0x01, false};  // §8.7: not assigned
  }
  double PositionResolutionMm() const override { return 1 / dn::kPositionIncrementsPerMm; }
  bool HasStoredParameters() const override { return false; }    // §8.8, D-29
  bool EnabledAcrossLinkLoss() const override { return false; }  // D-15, decision 983

 private:
  std::unique_ptr<LinMotDnServer> server_;
  DriveConfig config_;
};

// ---- §13 cases a master can observe ------------------------------------------------------

class DeviceNetContract : public ::testing::Test {
 protected:
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }
  static DnSimOptions Sim() {
    DnSimOptions o;
    o.duplicate_check_wait = 50ms;
    return o;
  }
  // Starts the simulator and a drive with test timings (decision 981 options); waits for the
  // first poll response unless `expect_online` is false.
  void Start(DnSimOptions o = Sim(), dn::DnDriveOptions d = {}, bool expect_online = true,
             uint8_t mac = 5) {
    port_ = UniquePort();
    o.can = Bus(port_);
    auto server = LinMotDnServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    d.session.duplicate_check_wait = 50ms;
    d.restart_wait = 150ms;
    config_ = Config(port_, mac);
    drive_ = std::make_unique<dn::LinMotDnDrive>(config_, SteadyClock::Instance(), d);
    ASSERT_TRUE(drive_->Activate().ok());
    if (!expect_online) return;
    const DriveStatus s =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(s.state, DriveState::kOffline) << "the simulated drive never answered";
  }
  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::steady_clock::duration timeout = kWait) {
    return test_support::WaitStatus(*drive_, pred, timeout);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, kWait); }
  void Enable() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
  }
  void MoveDone(double mm) {
    auto r = drive_->Move(MoveAbsolute{mm, 500, 5000, 5000});
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(WaitFinal(r->id).state, CommandState::kDone);
  }
  int64_t Read(uint32_t id) {
    auto v = drive_->ReadParameter(ParameterRef{id, false});
    EXPECT_TRUE(v.ok()) << v.status();
    return v.ok() ? *v : -1;
  }
  NativeReply Native(uint16_t word, int32_t value) {
    auto r = drive_->SendNative(LinMotDnRequest{word, value});
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : NativeReply{};
  }
  // Frames the simulator received on `id`, oldest first.
  std::vector<dn::Frame> Received(uint16_t id) {
    std::vector<dn::Frame> out;
    for (const auto& f : server_->Frames()) {
      if (!f.transmitted && f.frame.id == id) out.push_back(f.frame);
    }
    return out;
  }

  uint16_t port_ = 0;
  DriveConfig config_;
  std::unique_ptr<LinMotDnServer> server_;
  std::unique_ptr<dn::LinMotDnDrive> drive_;
};

// TC-01: Allocate explicit + polled (42E#..4B.03.01.03.00 -> CB.00), poll EPR 100 ms granted,
// 6-byte polls answered by one 8-byte frame on 0x3C5.
TEST_F(DeviceNetContract, TC_01_AllocationAndPollSetup) {
  Start();
  const auto snap = server_->Snapshot();
  EXPECT_EQ(snap.stack.owner, std::optional<uint8_t>(0));
  EXPECT_GE(snap.stack.poll_connection.expected_packet_rate_ms, 100);
  const auto polls = Received(0x42D);
  ASSERT_FALSE(polls.empty());
  EXPECT_EQ(polls.front().dlc, 6);
  for (const auto& f : server_->Frames()) {
    if (f.transmitted && f.frame.id == 0x3C5) {
      EXPECT_EQ(f.frame.dlc, 8);
    }
  }
  const auto allocate = Received(0x42E);
  ASSERT_FALSE(allocate.empty());
  EXPECT_EQ(allocate.back().data[1], 0x4B);
  EXPECT_EQ(allocate.back().data[4], 0x03);  // explicit | polled
}

// TC-02: one master at a time (line 142): a second master is refused while the gateway keeps
// polling; after the gateway released the set (§11.9) the second master gets it.
TEST_F(DeviceNetContract, TC_02_SecondMasterRefusedUntilRelease) {
  Start();
  auto master1 = transport::OpenCanChannel(Bus(port_));
  ASSERT_TRUE(master1.ok());
  ASSERT_TRUE((*master1)->SetFilters(std::vector<transport::CanFilter>{{0x42B, 0x7FF}}).ok());
  const std::vector<uint8_t> allocate = {0x01, 0x4B, 0x03, 0x01, 0x01, 0x01};
  ASSERT_TRUE((*master1)->Send(transport::MakeCanFrame(0x42E, allocate)).ok());
  std::optional<transport::CanFrame> answer;
  const auto deadline = std::chrono::steady_clock::now() + kWait;
  while (!answer && std::chrono::steady_clock::now() < deadline) {
    auto f = (*master1)->Receive(100ms);
    if (f.ok() && f->has_value() && ((*f)->data[0] & 0x3F) == 1) answer = **f;
  }
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->data[1], 0x94);  // error response, D-14 0C/01
  EXPECT_EQ(answer->data[2], 0x0C);
  EXPECT_EQ(answer->data[3], 0x01);
  EXPECT_NE(drive_->GetStatus().state, DriveState::kOffline);
  // The gateway's session sees the foreign allocation on its own socket, independently of the
  // answer the test received: wait for it to be counted instead of racing it.
  const auto counted_by = std::chrono::steady_clock::now() + kWait;
  while (drive_->exchange_counters()->foreign_master < 1u &&
         std::chrono::steady_clock::now() < counted_by) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_GE(drive_->exchange_counters()->foreign_master, 1u);
  drive_->Deactivate();  // Release
  answer.reset();
  bool granted = false;
  const auto until = std::chrono::steady_clock::now() + kWait;
  while (!granted && std::chrono::steady_clock::now() < until) {
    if (!server_->Snapshot().stack.owner.has_value()) {
      ASSERT_TRUE((*master1)->Send(transport::MakeCanFrame(0x42E, allocate)).ok());
    }
    auto f = (*master1)->Receive(100ms);
    if (f.ok() && f->has_value() && ((*f)->data[0] & 0x3F) == 1 && (*f)->data[1] == 0xCB) {
      granted = true;
    }
  }
  EXPECT_TRUE(granted);
}

// TC-03 / TC-46: sizes follow the module selection; seed example 1 (F3, 22/24 bytes) is
// fragmented both ways: 00/41/42/83 out, four fragments back, reassembled.
TEST_F(DeviceNetContract, TC_03_TC_46_Example1SizesAndFragmentation) {
  DnSimOptions o = Sim();
  o.motor_count = 4;
  o.poll_modules = dn::Example1Layout().modules;
  dn::DnDriveOptions d;
  d.layout = dn::Example1Layout();
  Start(o, d);
  Enable();
  MoveDone(40);
  const auto snap = server_->Snapshot();
  EXPECT_EQ(snap.stack.poll_connection.consumed_size, 22);
  EXPECT_EQ(snap.stack.poll_connection.produced_size, 24);
  EXPECT_EQ(snap.stack.counters.polls_wrong_size, 0u);
  EXPECT_EQ(snap.stack.counters.fragment_errors, 0u);
  const auto polls = Received(0x42D);
  ASSERT_GE(polls.size(), 4u);
  size_t first = 0;
  while (first < polls.size() && polls[first].data[0] != 0x00) ++first;
  ASSERT_LE(first + 4, polls.size());
  EXPECT_EQ(polls[first + 1].data[0], 0x41);
  EXPECT_EQ(polls[first + 2].data[0], 0x42);
  EXPECT_EQ(polls[first + 3].data[0], 0x83);
  EXPECT_EQ(polls[first + 3].dlc, 2);
  EXPECT_EQ(drive_->exchange_counters()->fragment_errors, 0u);
}

// TC-06: Reset Controller is not answered; the drive restarts (duplicate MAC ID requests) and
// the gateway sets the connection up again; the command is never sent twice (D-28).
TEST_F(DeviceNetContract, TC_06_ResetControllerNotAnsweredReconnect) {
  Start();
  Enable();
  Native(0x000F, 0);
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  ASSERT_NE(WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
            DriveState::kOffline);
  EXPECT_EQ(server_->Snapshot().device.controller_resets, 1u);
  int resets = 0;
  for (const auto& f : Received(0x42D)) resets += (f.data[2] == 0x0F) ? 1 : 0;
  EXPECT_EQ(resets, 1);
}

// TC-07: DeviceNet disabled: nothing answers the Allocate, the drive stays OFFLINE and says why.
TEST_F(DeviceNetContract, TC_07_DeviceNetDisabled_Offline) {
  DnSimOptions o = Sim();
  o.dn_enable = false;
  Start(o, {}, /*expect_online=*/false);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return !s.native.text.empty(); }, 3s);
  EXPECT_EQ(s.state, DriveState::kOffline);
  EXPECT_THAT(s.native.text, ::testing::HasSubstr("no answer to Allocate"));
  EXPECT_EQ(drive_->Enable().status().code(), absl::StatusCode::kUnavailable);
}

// TC-08: MAC ID 42 from the hexadecimal rotary switches 2,A: identifiers 0x556/0x555/0x3EA.
TEST_F(DeviceNetContract, TC_08_MacIdFromHexSwitches) {
  DnSimOptions o = Sim();
  o.mac_source = sim::linmot_devicenet::MacIdSource::kSwitches;
  o.mac_switches = 0x2A;
  Start(o, {}, true, 42);
  EXPECT_FALSE(Received(0x556).empty());
  EXPECT_FALSE(Received(0x555).empty());
  bool answered = false;
  for (const auto& f : server_->Frames()) answered |= f.transmitted && f.frame.id == 0x3EA;
  EXPECT_TRUE(answered);
}

// TC-09: MAC ID 63 from the parameter: 0x5FE / 0x5FD / 0x3FF.
TEST_F(DeviceNetContract, TC_09_MacIdFromParameter63) {
  DnSimOptions o = Sim();
  o.mac_id = 63;
  o.mac_switches = 0x05;
  Start(o, {}, true, 63);
  EXPECT_FALSE(Received(0x5FD).empty());
  EXPECT_TRUE(Received(0x42D).empty());
}

// TC-10: the drive's duplicate MAC ID check is answered: it stays offline (0x8101 latched);
// the gateway sees its restart and never gets an answer to Allocate.
TEST_F(DeviceNetContract, TC_10_DuplicateMacId_DriveStaysOffline) {
  Start();
  server_->InjectDuplicateMac();
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kOffline);
  EXPECT_GE(drive_->exchange_counters()->drive_restarts, 1u);
  EXPECT_EQ(server_->Snapshot().device.coded_error, dn::kCodedMacIdInUse);
  // Still offline after several set-up attempts.
  EXPECT_EQ(
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; }, 1s).state,
      DriveState::kOffline);
}

// TC-11: bus-off in the drive: silent, then after its recovery a new set-up; Get Coded Error
// answers 0x8148 (the gateway reports it as the fault).
TEST_F(DeviceNetContract, TC_11_DriveBusOff_CodedError8148AfterRecovery) {
  Start();
  server_->GoBusOff();
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  server_->RecoverBusOff();
  const DriveStatus f = WaitUntil([](const DriveStatus& s) { return s.fault.code == 0x8148; });
  EXPECT_EQ(f.fault.code, 0x8148u);
  EXPECT_EQ(Read(0x0A), 0x8148);
}

// TC-12, TC-13, TC-14: status low / high words and the control word read back consistently.
TEST_F(DeviceNetContract, TC_12_13_14_StatusAndControlWords) {
  Start();
  Enable();
  MoveDone(75);
  const int64_t low = Read(0x02);
  EXPECT_EQ(low & 0x1003, 0x1003);  // INIT Done, RUN, In Position A (TC-12: 0x1003)
  EXPECT_EQ(drive_->GetStatus().native.status_word & 0xFFFF, static_cast<uint32_t>(low));
  const int64_t high = Read(0x03);
  EXPECT_EQ(high & 0x0002, 0x0002);  // motor A inside its position range
  EXPECT_EQ(Read(0x04), 0x0002);     // TC-14: CW = RUN request
}

// TC-16: RUN and STOP requests (Enable / Disable).
TEST_F(DeviceNetContract, TC_16_RunAndStopRequests) {
  Start();
  Enable();
  EXPECT_EQ(Read(0x02) & 0x0002, 0x0002);
  ASSERT_TRUE(drive_->Disable().ok());
  EXPECT_EQ(Read(0x02) & 0x0002, 0);
  EXPECT_EQ(Read(0x04), 0x0004);  // STOP request
}

// TC-17: In Position follows the window around the target; a disturbance clears it.
TEST_F(DeviceNetContract, TC_17_InPositionWindow) {
  Start();
  Enable();
  MoveDone(100);
  EXPECT_TRUE(drive_->GetStatus().in_target);
  server_->WithDevice([](LinMotDnDevice& d) { d.SetDisturbance(dn::Motor::kA, 80.0 / 51.2); });
  EXPECT_FALSE(WaitUntil([](const DriveStatus& s) { return !s.in_target; }).in_target);
  server_->WithDevice([](LinMotDnDevice& d) { d.SetDisturbance(dn::Motor::kA, 0); });
  EXPECT_TRUE(WaitUntil([](const DriveStatus& s) { return s.in_target; }).in_target);
}

// TC-18, TC-19: set-point 5120 (100 mm) after a move; actual position -256 at -5 mm.
TEST_F(DeviceNetContract, TC_18_19_SetpointAndActualPosition) {
  Start();
  drive_->Deactivate();
  config_.axis.min_mm = -10;
  drive_ = std::make_unique<dn::LinMotDnDrive>(config_, SteadyClock::Instance(), [] {
    dn::DnDriveOptions d;
    d.session.duplicate_check_wait = 50ms;
    d.restart_wait = 150ms;
    return d;
  }());
  ASSERT_TRUE(drive_->Activate().ok());
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  Enable();
  MoveDone(100);
  EXPECT_EQ(Read(0x10), 5120);
  MoveDone(-5);
  EXPECT_EQ(Read(0x18), -256);
  EXPECT_NEAR(drive_->GetStatus().position_mm, -5.0, 1e-9);
}

// TC-21: Increment Position Setpoint executes once per toggle (MoveRelative).
TEST_F(DeviceNetContract, TC_21_IncrementOncePerToggle) {
  Start();
  Enable();
  MoveDone(100);
  const bool toggle = (Read(0x03) & 0x0008) != 0;
  auto r = drive_->Move(MoveRelative{5.0, 300, 3000, 0});  // +256 increments
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(WaitFinal(r->id).state, CommandState::kDone);
  EXPECT_EQ(Read(0x10), 5376);
  EXPECT_NE((Read(0x03) & 0x0008) != 0, toggle);
}

// TC-22 / TC-24: Start Curve and Start Curve Incremental (T-commands) run once per call; Curve
// Done A toggles at the end.
TEST_F(DeviceNetContract, TC_22_24_StartCurveOncePerToggle) {
  Start();
  Enable();
  MoveDone(50);
  const bool done_before = (Read(0x02) & 0x0100) != 0;
  const NativeReply r = Native(0x1020, 3);  // curve 3
  EXPECT_EQ(r.status, 0u);
  EXPECT_EQ(r.word2 & 0x007F, 0x20);
  const DriveStatus s = WaitUntil([&](const DriveStatus& s) {
    return ((s.native.status_word & 0x0100) != 0) != done_before && !s.motion_active;
  });
  EXPECT_NE((s.native.status_word & 0x0100) != 0, done_before);
  EXPECT_EQ(server_->Snapshot().device.motors[0].curves_completed, 1u);
  const int64_t before = Read(0x18);
  const NativeReply inc = Native(0x1022, 4);  // TC-24: +512 from the demand position
  EXPECT_EQ(inc.status, 0u);
  WaitUntil([&](const DriveStatus&) {
    return server_->Snapshot().device.motors[0].curves_completed == 2;
  });
  EXPECT_EQ(server_->Snapshot().device.motors[0].curves_completed, 2u);
  EXPECT_NEAR(static_cast<double>(Read(0x18)), static_cast<double>(before + 512), 1.0);
}

// TC-26 / TC-27: Move Home Position and Set Actual Position move nothing; toggle rule.
TEST_F(DeviceNetContract, TC_26_27_HomeAndActualPositionWithoutMotion) {
  Start();
  Enable();
  MoveDone(50);
  const bool toggle = (Read(0x03) & 0x0008) != 0;
  Native(0x1015, 0);
  EXPECT_NE((Read(0x03) & 0x0008) != 0, toggle);
  Native(0x1019, 2560);  // TC-27: actual := 2560 (50 mm), no motion
  EXPECT_EQ(Read(0x03) & 0x0008, toggle ? 0x0008 : 0);
  EXPECT_EQ(Read(0x18), 2560);
  EXPECT_FALSE(drive_->GetStatus().motion_active);
}

// TC-28: motion outside serial mode: ERROR Pending, System Error bit 7, coded error 0x8112.
TEST_F(DeviceNetContract, TC_28_NotSerialMode_8112) {
  Start();
  Enable();
  server_->WithDevice([](LinMotDnDevice& d) {
    d.SetRunMode(dn::Motor::kA, sim::linmot_devicenet::RunMode::kMasterEncoder);
  });
  auto r = drive_->Move(MoveAbsolute{60, 100, 1000, 1000});
  EXPECT_EQ(dn::GetCodedError(r.status()), std::optional<uint16_t>(0x8112));
  EXPECT_EQ(Read(0x08) & 0x0080, 0x0080);
  EXPECT_EQ(Read(0x0A), 0x8112);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kFault);
}

// TC-29, TC-31, TC-32, TC-33, TC-42: commands the drive refuses report their coded error.
TEST_F(DeviceNetContract, TC_29_31_32_33_42_CodedErrorsOfRefusedCommands) {
  DnSimOptions o = Sim();
  o.motor_count = 2;
  o.motors[1].master = false;  // motor B is a slave axis
  Start(o);
  Enable();
  struct Case {
    const char* id;
    uint16_t word;
    int32_t value;
    uint16_t coded;
  };
  for (const Case& c : {Case{"TC-29", 0x10A0, 10, 0x8130}, Case{"TC-31", 0x0018, 0, 0x8110},
                        Case{"TC-32", 0x2011, 5120, 0x8111}, Case{"TC-33", 0x104B, 1, 0x8118},
                        Case{"TC-42", 0x0060, 0, 0x8120}}) {
    const NativeReply r = Native(c.word, c.value);
    EXPECT_EQ(r.status, c.coded) << c.id;
    auto ack = drive_->AcknowledgeFault();
    EXPECT_TRUE(ack.ok()) << c.id << ": " << ack.status();
  }
  EXPECT_EQ(Read(0x4A), 10);  // TC-33: In Position + unchanged
}

// TC-34, TC-35, TC-36: warn / error states, system versus motor words, first error latched.
TEST_F(DeviceNetContract, TC_34_35_36_WarnAndErrorStates) {
  Start();
  Enable();
  server_->WithDevice(
      [](LinMotDnDevice& d) { d.SetMotorWarningCause(dn::Motor::kA, dn::kMotorTooHotCalc); });
  WaitUntil([](const DriveStatus& s) {
    return std::find(s.warnings.begin(), s.warnings.end(), "Motor Too Hot Calc") !=
           s.warnings.end();
  });
  EXPECT_EQ(Read(0x06), 0x1000);  // TC-34: system word, Warn Motor A
  EXPECT_THAT(drive_->GetStatus().warnings, ::testing::Contains("Motor Too Hot Calc"));
  server_->WithDevice(
      [](LinMotDnDevice& d) { d.SetMotorErrorCause(dn::Motor::kA, dn::kMotorFollowingError); });
  const DriveStatus f = WaitUntil([](const DriveStatus& s) { return s.fault.code == 0x10004; });
  EXPECT_EQ(f.fault.code, 0x10004u);           // decision 986: motor error word 0x0004
  EXPECT_EQ(Read(0x08), 0x1000);               // TC-35: system word, Error Motor A
  EXPECT_EQ(Native(0x1008, 0).word3, 0x0004);  // TC-35: motor word, Following Error
  server_->WithDevice([](LinMotDnDevice& d) {
    d.SetMotorErrorCause(dn::Motor::kA, dn::kMotorFollowingError | dn::kMotorTooHotSensor);
  });
  EXPECT_EQ(Native(0x1008, 0).word3, 0x0004);  // TC-36: only the first error is latched
  EXPECT_EQ(drive_->GetStatus().fault.code, 0x10004u);
}

// TC-37, TC-38: after Reset Error State / Reset Coded Error, RUN only after a RUN re-edge: the
// acknowledge leaves the drive READY and Enable brings it back.
TEST_F(DeviceNetContract, TC_37_38_ResetThenRunReEdge) {
  Start();
  Enable();
  ASSERT_TRUE(server_->RaiseCodedError(dn::kCodedUnknownCommand).ok());
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; });
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kReady);
  EXPECT_EQ(Read(0x0A), 0);
  Enable();
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kEnabled);
}

// TC-39, TC-41, TC-43: controller IO, extended IO and Direct Out variable selection.
TEST_F(DeviceNetContract, TC_39_41_43_IoWordsAndDirectOutSelection) {
  DnSimOptions o = Sim();
  o.digital_io_module = true;
  Start(o);
  server_->WithDevice([](LinMotDnDevice& d) {
    d.SetControllerInputs(0x0101);  // run request input, Dig In 5
    d.SetExtendedInputs(0x3C);
  });
  EXPECT_EQ(Read(0x0C) & 0x03FF, 0x0101);  // TC-39
  const NativeReply ext = Native(0x0065, 0xA500);
  EXPECT_EQ(ext.word3, 0xA53C);  // TC-41: outputs echoed, actual inputs
  EXPECT_EQ(Read(0x70), 0);      // TC-43: Direct Out 1 = Actual Pos (D-30)
  ASSERT_TRUE(drive_->WriteParameter(ParameterRef{0x71, false}, 4).ok());
  EXPECT_EQ(Read(0x70), 4);
}

}  // namespace

std::unique_ptr<FamilyFixture> MakeLinMotDnFixture() { return std::make_unique<LinMotDnFixture>(); }

}  // namespace drivegw::contract
