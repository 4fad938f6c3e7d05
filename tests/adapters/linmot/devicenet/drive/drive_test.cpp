// LinMotDnDrive tests on the user-space CAN bus (UDP multicast, a fresh port per test) against the
// simulated LinMot DeviceNet drive (sim/linmot_devicenet): bring-up, control word sequences,
// motion handles, faults, link loss without replay, parameters, native commands.
#include "adapters/linmot/devicenet/drive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/factory.h"
#include "adapters/transport/udp_multicast_channel.h"
#include "sim/linmot_devicenet/device.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::devicenet {
namespace {

using namespace std::chrono_literals;
using sim::linmot_devicenet::DnSimOptions;
using sim::linmot_devicenet::LinMotDnDevice;
using sim::linmot_devicenet::LinMotDnServer;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;                 // bound for conditions that hold within a second
constexpr char kGroup[] = "239.74.163.93";  // not python-can's default: no stray traffic

// A port no other test (here or in a concurrent ctest process) uses at the same time.
uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + 11 + next++) % 40000);
}

CanBusConfig Bus(uint16_t port) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = port;
  return bus;
}

// ---- pure helpers ------------------------------------------------------------------------

TEST(MapDnState, StatusWords_MapToUnifiedStates) {
  auto map = [](uint16_t low, bool moving = false, bool online = true) {
    return MapDnState(online, StatusLowWord{low}, Motor::kA, moving);
  };
  EXPECT_EQ(map(0x0010), DriveState::kDisabled);       // DISABLE State
  EXPECT_EQ(map(0x0008), DriveState::kHoming);         // INIT State
  EXPECT_EQ(map(0x0001), DriveState::kReady);          // STOPPED: INIT Done only
  EXPECT_EQ(map(0x1003), DriveState::kEnabled);        // RUN, In Position A
  EXPECT_EQ(map(0x1003, true), DriveState::kEnabled);  // In Position wins
  EXPECT_EQ(map(0x0003, true), DriveState::kMoving);   // RUN, moving, not in position
  EXPECT_EQ(map(0x0003), DriveState::kEnabled);        // standing outside the window
  EXPECT_EQ(map(0x2003, true), DriveState::kMoving);   // In Position B is not ours
  EXPECT_EQ(map(0x0045), DriveState::kFault);          // ERROR State + ERROR Pending
  EXPECT_EQ(map(0x0043), DriveState::kFault);          // ERROR Pending while RUN still shows
  EXPECT_EQ(map(0x0021), DriveState::kDisabled);       // Emergency Stop
  EXPECT_EQ(map(0x1083), DriveState::kEnabled);        // a warning does not change the state
  EXPECT_EQ(map(0x1003, false, false), DriveState::kOffline);
}

TEST(Conversions, Position_IncrementsOf19_53Um_CheckedNotClamped) {
  EXPECT_EQ(*PositionToDn("p", 100.0), 5120);  // §13.4 TC-18: 100.000 mm = 5120
  EXPECT_EQ(*PositionToDn("p", -5.0), -256);   // TC-19
  EXPECT_EQ(*PositionToDn("p", 630.0), 32256);
  auto beyond = PositionToDn("move_absolute.position_mm", 630.1);
  EXPECT_EQ(beyond.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(beyond.status().message(), HasSubstr("move_absolute.position_mm"));
  EXPECT_DOUBLE_EQ(PositionFromDn(5120), 100.0);
}

TEST(Conversions, FilterLimits_RoundDownAndNameTheRange) {
  EXPECT_EQ(*SpeedToDn("v", 1000.0), 5242);  // 999.9 mm/s: never faster than asked
  EXPECT_EQ(*AccelerationToDn("a", 10000.0), 41);
  EXPECT_EQ(*AccelerationToDn("a", 238.419), 1);
  auto slow = AccelerationToDn("move_absolute.acceleration_mm_s2", 100.0);
  EXPECT_EQ(slow.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(slow.status().message(),
              HasSubstr("move_absolute.acceleration_mm_s2: 100 is outside the settable range"));
  EXPECT_EQ(SpeedToDn("v", 5000.0).status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(SpeedToDn("v", NAN).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(Factory, MissingOrBadConfig_NamesTheKey) {
  DriveConfig c;
  c.name = "x1";
  c.family = kFamilyName;
  c.axis.min_mm = 0;
  c.axis.max_mm = 100;
  auto r = CreateLinMotDnDrive(c, SteadyClock::Instance());
  EXPECT_THAT(r.status().message(), HasSubstr("drive 'x1'.can: missing"));
  c.can = Bus(43113);
  r = CreateLinMotDnDrive(c, SteadyClock::Instance());
  EXPECT_THAT(r.status().message(), HasSubstr("drive 'x1'.mac_id: missing"));
  c.mac_id = 64;
  EXPECT_THAT(CreateLinMotDnDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x1'.mac_id: 64 exceeds 63"));
  c.mac_id = 0;
  EXPECT_THAT(CreateLinMotDnDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x1'.mac_id: 0 is the gateway's own MAC ID"));
  c.mac_id = 5;
  c.can->kind = CanBusConfig::Kind::kSocketCan;
  c.can->interface = "can/0";
  EXPECT_THAT(CreateLinMotDnDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x1'.can.socketcan.interface"));
  c.can = Bus(43113);
  c.axis.max_mm = 700;
  EXPECT_THAT(CreateLinMotDnDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x1'.axis"));
  c.axis.max_mm = 100;
  auto ok = CreateLinMotDnDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ((*ok)->lifecycle(), Lifecycle::kUnconfigured);
  EXPECT_EQ((*ok)->endpoint(), "devicenet://udp:239.74.163.93:43113/5");
}

// ---- against the simulated drive ---------------------------------------------------------

class DnDriveTest : public ::testing::Test {
 protected:
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  static DnSimOptions SimDefaults() {
    DnSimOptions o;
    o.duplicate_check_wait = 50ms;  // §5.7 timing shortened for tests
    return o;
  }
  DnDriveOptions DriveDefaults() const {
    DnDriveOptions d;
    d.session.duplicate_check_wait = 50ms;
    d.restart_wait = 150ms;
    return d;
  }

  void Start(DnSimOptions o = SimDefaults(), std::optional<DnDriveOptions> d = std::nullopt) {
    port_ = UniquePort();
    o.can = Bus(port_);
    auto server = LinMotDnServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    config_.name = "x1";
    config_.family = kFamilyName;
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 150;
    config_.axis.max_velocity_mm_s = 1000;
    config_.axis.max_acceleration_mm_s2 = 20000;
    config_.can = Bus(port_);
    config_.mac_id = o.mac_id;
    drive_ = std::make_unique<LinMotDnDrive>(config_, SteadyClock::Instance(),
                                             d.value_or(DriveDefaults()));
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus s =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(s.state, DriveState::kOffline) << "the simulated drive never answered a poll";
  }

  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::steady_clock::duration timeout = kWait) {
    return test_support::WaitStatus(*drive_, pred, timeout);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, kWait); }
  void Enable() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
    ASSERT_EQ(drive_->GetStatus().state, DriveState::kEnabled);
  }
  CommandInfo Move(const MotionCommand& cmd) {
    auto r = drive_->Move(cmd);
    EXPECT_TRUE(r.ok()) << KindName(cmd) << ": " << r.status();
    if (!r.ok()) return CommandInfo{};
    EXPECT_NE(r->state, CommandState::kBusy);
    return *r;
  }
  sim::linmot_devicenet::DnSimSnapshot Sim() { return server_->Snapshot(); }
  // Waits (on the drive's status stream) until the simulator shows `pred`.
  bool WaitSim(const std::function<bool(const sim::linmot_devicenet::DnSimSnapshot&)>& pred) {
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    DriveStatus s = drive_->GetStatus();
    while (std::chrono::steady_clock::now() < deadline) {
      if (pred(Sim())) return true;
      s = drive_->WaitForStatus(s.sequence,
                                std::min(deadline, std::chrono::steady_clock::now() + 100ms));
    }
    return pred(Sim());
  }

  uint16_t port_ = 0;
  DriveConfig config_;
  std::unique_ptr<LinMotDnServer> server_;
  std::unique_ptr<LinMotDnDrive> drive_;
};

// §11.2: duplicate MAC ID check, Allocate explicit + polled, EPRs, first poll with CW 0.
TEST_F(DnDriveTest, BringUp_AllocatedPolledAndDisabled) {
  Start();
  const DriveStatus s = drive_->GetStatus();
  EXPECT_EQ(s.state, DriveState::kDisabled);  // the simulator powers up in DISABLE (D-10)
  EXPECT_FALSE(s.homed);
  const auto sim = Sim();
  ASSERT_TRUE(sim.stack.owner.has_value());
  EXPECT_EQ(*sim.stack.owner, 0);  // the gateway's MAC ID (decision 981)
  EXPECT_EQ(sim.stack.allocation_choice & 0x03, 0x03);
  EXPECT_EQ(sim.stack.poll_connection.expected_packet_rate_ms, 100);
  EXPECT_EQ(sim.stack.explicit_connection.expected_packet_rate_ms, 2500);
  EXPECT_EQ(sim.device.control_word, 0);  // §11.2 step 8: nothing requested on connect
  auto counters = drive_->exchange_counters();
  ASSERT_TRUE(counters.has_value());
  EXPECT_EQ(counters->connects, 1u);
  EXPECT_GE(counters->poll_responses, 1u);
  EXPECT_EQ(counters->size_mismatches, 0u);
  // The allocation frame on the wire, §11.2 step 2 (XID masked): 42E#?0.4B.03.01.03.00.
  bool allocate_seen = false;
  for (const auto& f : server_->Frames()) {
    if (!f.transmitted && f.frame.id == 0x42E && f.frame.dlc == 6 && f.frame.data[1] == 0x4B) {
      allocate_seen = (f.frame.data[0] & 0xBF) == 0x00 && f.frame.data[2] == 0x03 &&
                      f.frame.data[3] == 0x01 && f.frame.data[4] == 0x03 && f.frame.data[5] == 0x00;
    }
  }
  EXPECT_TRUE(allocate_seen);
}

// D-10 / §11.6: Enable from power-up runs INIT (INIT Done), then a RUN edge.
TEST_F(DnDriveTest, Enable_FromDisable_InitThenRun) {
  Start();
  Enable();
  const DriveStatus s = drive_->GetStatus();
  EXPECT_TRUE(s.homed);
  EXPECT_TRUE(s.in_target);
  EXPECT_EQ(s.native.main_state, 3u);  // RUN
  EXPECT_EQ(Sim().device.control_word, ControlWord::kRunRequest);
  // Enable when already enabled: DONE at once.
  Enable();
}

// §11.10: absolute move via 0x51/0x53 + 0x11: ACTIVE when echoed, MOVING, DONE In Position.
TEST_F(DnDriveTest, MoveAbsolute_RampsAndEndsDone) {
  Start();
  Enable();
  const double target = 75.0;
  const auto t0 = std::chrono::steady_clock::now();
  const CommandInfo cmd = Move(MoveAbsolute{target, 200, 2000, 2000});
  EXPECT_EQ(cmd.state, CommandState::kActive);
  const DriveStatus moving = WaitUntil([](const DriveStatus& s) { return s.motion_active; });
  EXPECT_EQ(moving.state, DriveState::kMoving);
  const CommandInfo done = WaitFinal(cmd.id);
  EXPECT_EQ(done.state, CommandState::kDone) << done.message;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(elapsed, target / 200 * 0.95);  // never faster than commanded (filter floor)
  const DriveStatus s =
      WaitUntil([&](const DriveStatus& s) { return std::fabs(s.position_mm - target) < 0.05; });
  EXPECT_NEAR(s.position_mm, target, 0.05);
  EXPECT_NEAR(s.demand_position_mm, target, 1e-9);
  EXPECT_EQ(s.state, DriveState::kEnabled);
  // The filter limits went to the drive, rounded down (decision 984).
  std::optional<int32_t> speed, acc;
  server_->WithDevice([&](LinMotDnDevice& d) {
    speed = d.Parameter(Motor::kA, 0x50);
    acc = d.Parameter(Motor::kA, 0x52);
  });
  EXPECT_EQ(speed, 1048);  // 200 / 0.190735 = 1048.6
  EXPECT_EQ(acc, 8);       // 2000 / 238.419 = 8.39
}

// 0x13 with the toggle handshake; the increment applies to the set-point (decision 984).
TEST_F(DnDriveTest, MoveRelative_EndsAtSetpointPlusDistance) {
  Start();
  Enable();
  ASSERT_EQ(WaitFinal(Move(MoveAbsolute{50, 500, 5000, 5000}).id).state, CommandState::kDone);
  const bool toggle_before = Sim().device.motors[0].command_toggle;
  const CommandInfo rel = Move(MoveRelative{7.5, 300, 3000, 0});
  EXPECT_EQ(WaitFinal(rel.id).state, CommandState::kDone);
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return std::fabs(s.position_mm - 57.5) < 0.05; });
  EXPECT_NEAR(s.demand_position_mm, 57.5, 1e-9);
  EXPECT_NE(Sim().device.motors[0].command_toggle, toggle_before);  // one execution (TC-21)
  // Beyond the axis: refused before anything is sent.
  auto far = drive_->Move(MoveRelative{100, 300, 3000, 0});
  EXPECT_EQ(far.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(far.status().message(), HasSubstr("move_relative.distance_mm"));
}

TEST_F(DnDriveTest, StopWhileMoving_StopDoneMoveAborted) {
  Start();
  Enable();
  const CommandInfo move = Move(MoveAbsolute{145, 150, 1500, 1500});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 10; });
  const CommandInfo stop = Move(StopMotion{3000});
  EXPECT_EQ(drive_->GetCommand(move.id)->state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(stop.id).state, CommandState::kDone);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return !s.motion_active; });
  EXPECT_LT(s.position_mm, 140);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

TEST_F(DnDriveTest, MoveOutsideRun_RefusedByTheGateway) {
  Start();
  auto r = drive_->Move(MoveAbsolute{50, 100, 1000, 1000});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(r.status().message(), HasSubstr("needs RUN"));
  EXPECT_EQ(drive_->Home().status().code(), absl::StatusCode::kFailedPrecondition);
  auto fast = drive_->Move(MoveAbsolute{50, 5000, 1000, 1000});
  EXPECT_EQ(fast.status().code(), absl::StatusCode::kFailedPrecondition);  // state first
}

// §11.7: a motor error is FAULT with the motor error word; Reset Error State + RUN edge.
TEST_F(DnDriveTest, MotorFault_ThenAcknowledge_Enableable) {
  Start();
  Enable();
  const CommandInfo move = Move(MoveAbsolute{140, 100, 1000, 1000});
  server_->WithDevice(
      [](LinMotDnDevice& d) { d.SetMotorErrorCause(Motor::kA, kMotorFollowingError); });
  const DriveStatus f = WaitUntil([](const DriveStatus& s) {
    return s.state == DriveState::kFault && (s.fault.code & 0xFFFF0000u) == 0x00010000u;
  });
  ASSERT_EQ(f.state, DriveState::kFault);
  EXPECT_EQ(f.fault.code, 0x00010004u);  // decision 986: motor error word 0x0004
  EXPECT_THAT(f.fault.text, HasSubstr("Motor A: Following Error"));
  EXPECT_FALSE(f.fault.fatal);
  EXPECT_EQ(WaitFinal(move.id).state, CommandState::kError);
  EXPECT_EQ(drive_->Enable().status().code(), absl::StatusCode::kFailedPrecondition);
  // The cause persists: the acknowledge fails and says so.
  auto stuck = drive_->AcknowledgeFault();
  EXPECT_FALSE(stuck.ok());
  server_->WithDevice([](LinMotDnDevice& d) { d.SetMotorErrorCause(Motor::kA, 0); });
  auto ack = drive_->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(ack->state, CommandState::kDone);
  const DriveStatus s = drive_->GetStatus();
  EXPECT_NE(s.state, DriveState::kFault);
  EXPECT_EQ(s.fault.code, 0u);
  Enable();  // TC-37: RUN after CW 0x0000 -> 0x0002
}

// §8.6: a coded error shows its code and text; TC-38 reset.
TEST_F(DnDriveTest, CodedError_FaultWithCode_AcknowledgeClears) {
  Start();
  Enable();
  ASSERT_TRUE(server_->RaiseCodedError(kCodedRangeError).ok());
  const DriveStatus f = WaitUntil([](const DriveStatus& s) { return s.fault.code == 0x8118; });
  EXPECT_EQ(f.state, DriveState::kFault);
  EXPECT_THAT(f.fault.text, HasSubstr("Range error"));
  auto enable = drive_->Enable();
  EXPECT_EQ(GetCodedError(enable.status()), std::optional<uint16_t>(0x8118));
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  EXPECT_EQ(Sim().device.coded_error, 0);
  Enable();
}

// Decision 986: coded errors that no reset cures are fatal; the acknowledge is refused.
TEST_F(DnDriveTest, FatalCodedError_AcknowledgeRefused) {
  Start();
  Enable();
  ASSERT_TRUE(server_->RaiseCodedError(kCodedNeedsDnController).ok());
  const DriveStatus f = WaitUntil([](const DriveStatus& s) { return s.fault.fatal; });
  EXPECT_TRUE(f.fault.fatal);
  auto ack = drive_->AcknowledgeFault();
  EXPECT_EQ(ack.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kFault);
}

// TC-28 observed through the API: the drive refuses 0x11 outside serial mode with 0x8112.
TEST_F(DnDriveTest, MoveRefusedByDrive_CodedErrorPayload) {
  Start();
  Enable();
  server_->WithDevice([](LinMotDnDevice& d) {
    d.SetRunMode(Motor::kA, sim::linmot_devicenet::RunMode::kMasterEncoder);
  });
  auto r = drive_->Move(MoveAbsolute{60, 100, 1000, 1000});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(GetCodedError(r.status()), std::optional<uint16_t>(kCodedDriveNotSerial));
  EXPECT_THAT(r.status().message(), HasSubstr("Drive not in serial mode"));
  const DriveStatus s = drive_->GetStatus();
  ASSERT_TRUE(s.last_command.has_value());
  EXPECT_EQ(s.last_command->state, CommandState::kError);
}

// §11.7: warnings are read by name while WARNING Pending; AcknowledgeFault resets the latch.
TEST_F(DnDriveTest, Warning_ReportedByName_ResetByAcknowledge) {
  Start();
  Enable();
  server_->WithDevice([](LinMotDnDevice& d) { d.SetMotorWarningCause(Motor::kA, 1u << 0); });
  const DriveStatus w = WaitUntil([](const DriveStatus& s) {
    return std::find(s.warnings.begin(), s.warnings.end(), "Motor Too Hot Calc") !=
           s.warnings.end();
  });
  EXPECT_THAT(w.warnings, ::testing::Contains("Motor Too Hot Calc"));
  EXPECT_EQ(w.state, DriveState::kEnabled);
  server_->WithDevice([](LinMotDnDevice& d) { d.SetMotorWarningCause(Motor::kA, 0); });
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  EXPECT_TRUE(drive_->GetStatus().warnings.empty());
}

TEST_F(DnDriveTest, Home_ActiveThenDoneHomedAndEnabled) {
  Start();
  Enable();
  ASSERT_EQ(WaitFinal(Move(MoveAbsolute{30, 500, 5000, 5000}).id).state, CommandState::kDone);
  auto r = drive_->Home();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_NE(r->state, CommandState::kBusy);
  EXPECT_EQ(WaitFinal(r->id).state, CommandState::kDone) << drive_->GetCommand(r->id)->message;
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_TRUE(s.homed);
  EXPECT_NEAR(s.position_mm, 0, 0.05);  // the simulator's INIT position
}

TEST_F(DnDriveTest, Disable_LeavesRun_MoveAborted) {
  Start();
  Enable();
  const CommandInfo move = Move(MoveAbsolute{140, 100, 1000, 1000});
  WaitUntil([](const DriveStatus& s) { return s.motion_active; });
  auto r = drive_->Disable();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kReady);
  EXPECT_EQ(WaitFinal(move.id).state, CommandState::kAborted);
  EXPECT_EQ(Sim().device.control_word, ControlWord::kStopRequest);
  // Leaving RUN brakes the slider with the filter deceleration; enable again at standstill.
  WaitUntil([](const DriveStatus& s) { return std::fabs(s.velocity_mm_s) < 0.5; });
  Enable();
}

// §5.6 / §11.8: polls unanswered -> 4 x EPR -> OFFLINE (event), re-allocation when the drive
// answers again; decision 983: RUN is not re-requested and the old command never returns.
TEST_F(DnDriveTest, Watchdog_OfflineThenRecovery_NoStaleReplay) {
  Start();
  Enable();
  const CommandInfo move = Move(MoveAbsolute{140, 50, 500, 500});
  server_->SetDropPolls(true);
  const DriveStatus lost =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  ASSERT_EQ(lost.state, DriveState::kOffline);
  EXPECT_EQ(drive_->GetCommand(move.id)->state, CommandState::kError);
  EXPECT_THAT(drive_->GetCommand(move.id)->message, HasSubstr("4 x EPR"));
  EXPECT_EQ(drive_->Move(MoveAbsolute{60, 100, 1000, 1000}).status().code(),
            absl::StatusCode::kUnavailable);
  EXPECT_GE(drive_->exchange_counters()->watchdog_expiries, 1u);
  server_->ClearFrames();
  server_->SetDropPolls(false);
  const DriveStatus back =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_NE(back.state, DriveState::kOffline);
  EXPECT_NE(back.state, DriveState::kEnabled);  // no RUN replay
  EXPECT_GE(drive_->exchange_counters()->connects, 2u);
  // Every poll of the new connection: control word 0, never the old 0x11 set-point.
  int polls = 0;
  for (const auto& f : server_->Frames()) {
    if (f.transmitted || f.frame.id != 0x42D) continue;
    ++polls;
    EXPECT_EQ(f.frame.data[0] | (f.frame.data[1] << 8), 0) << FrameToString(f.frame);
    EXPECT_NE(f.frame.data[2] & 0x7F, 0x11) << FrameToString(f.frame);
  }
  EXPECT_GT(polls, 0);
  // The drive released RUN on its own connection loss (D-15) and may still be braking.
  auto enable = drive_->Enable();
  ASSERT_TRUE(enable.ok()) << enable.status();
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_EQ(WaitFinal(Move(MoveAbsolute{60, 200, 2000, 2000}).id).state, CommandState::kDone);
}

// §5.10 / §11.8: the drive goes bus-off (silent); after its recovery (new duplicate MAC ID
// check) the gateway re-allocates and sees the latched 0x8148.
TEST_F(DnDriveTest, DriveBusOff_OfflineThenReconnect) {
  Start();
  Enable();
  server_->GoBusOff();
  ASSERT_EQ(WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; }).state,
            DriveState::kOffline);
  server_->RecoverBusOff();
  const DriveStatus back =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_NE(back.state, DriveState::kOffline);
  const DriveStatus f = WaitUntil([](const DriveStatus& s) { return s.fault.code == 0x8148; });
  EXPECT_EQ(f.fault.code, 0x8148u);  // TC-11: CAN BOFF error, readable after the restart
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  Enable();
}

// Fragmented I/O both ways (§5.8): seed example 1 layout, 22 / 24 bytes, motor A of four.
TEST_F(DnDriveTest, Example1Layout_FragmentedPollsWork) {
  DnSimOptions o = SimDefaults();
  o.motor_count = 4;
  o.poll_modules = Example1Layout().modules;
  DnDriveOptions d = DriveDefaults();
  d.layout = Example1Layout();
  Start(o, d);
  Enable();
  EXPECT_EQ(WaitFinal(Move(MoveAbsolute{20, 400, 4000, 4000}).id).state, CommandState::kDone);
  const PeerCounters c = *drive_->exchange_counters();
  EXPECT_GT(c.poll_responses, 10u);
  EXPECT_EQ(c.fragment_errors, 0u);
  // 4 fragments out, 4 back per poll (§5.8 table): frames sent ≈ 4 x polls + explicit set-up.
  EXPECT_GE(c.frames_sent, 4 * c.polls_sent);
  // Every response loses a middle fragment: dropped (§5.8), so the watchdog takes the link.
  server_->SetCorruptFragments(true);
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  EXPECT_GT(drive_->exchange_counters()->fragment_errors, 3u);
  server_->SetCorruptFragments(false);
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  Enable();
  EXPECT_EQ(WaitFinal(Move(MoveAbsolute{30, 400, 4000, 4000}).id).state, CommandState::kDone);
}

// D-24 / line 326: responses of the wrong length are counted and dropped, never decoded.
TEST_F(DnDriveTest, WrongResponseLength_CountedAndOffline) {
  Start();
  server_->SetResponseLengthDelta(-2);
  WaitUntil([&](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  EXPECT_GT(drive_->exchange_counters()->size_mismatches, 0u);
  server_->SetResponseLengthDelta(0);
  EXPECT_NE(WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; }).state,
            DriveState::kOffline);
}

// §8.9: Get/Set pairs; errors name the parameter and the limit.
TEST_F(DnDriveTest, Parameters_ReadWriteRangeAndErrors) {
  Start();
  ASSERT_TRUE(drive_->WriteParameter(ParameterRef{0x4A, false}, 12).ok());
  EXPECT_EQ(*drive_->ReadParameter(ParameterRef{0x4A, false}), 12);
  EXPECT_EQ(*drive_->ReadParameter(ParameterRef{0x4B, false}), 12);  // the Set half names it too
  ASSERT_TRUE(drive_->WriteParameter(ParameterRef{0x29, false}, -512).ok());  // signed word
  EXPECT_EQ(*drive_->ReadParameter(ParameterRef{0x28, false}), -512);
  auto range = drive_->WriteParameter(ParameterRef{0x4B, false}, 1);
  EXPECT_EQ(range.code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(range.message(), HasSubstr("in_position_plus: 1 below minimum 2"));
  auto rom = drive_->ReadParameter(ParameterRef{0x4A, true});
  EXPECT_EQ(rom.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(rom.status().message(), HasSubstr("rom"));
  EXPECT_EQ(drive_->ReadParameter(ParameterRef{0x01, false}).status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(drive_->WriteParameter(ParameterRef{0x11, false}, 0).code(),
            absl::StatusCode::kInvalidArgument);
  // Status words read as parameters too.
  auto low = drive_->ReadParameter(ParameterRef{0x02, false});
  ASSERT_TRUE(low.ok()) << low.status();
  EXPECT_EQ(*low & 0x10, 0x10);  // DISABLE State
  // The drive refuses a command it cannot serve: coded error 0x8120 (no encoder module).
  auto cam = drive_->WriteParameter(ParameterRef{0x63, false}, 100);
  EXPECT_EQ(cam.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(GetCodedError(cam), std::optional<uint16_t>(kCodedEncoderNotExists));
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  // A Get the drive cannot serve answers 0 and raises the coded error: an error, not a value.
  auto encoder = drive_->ReadParameter(ParameterRef{0x60, false});
  EXPECT_EQ(GetCodedError(encoder.status()), std::optional<uint16_t>(kCodedEncoderNotExists));
}

// Native pass-through: raw command word + value; T handled by the gateway.
TEST_F(DnDriveTest, Native_RawCommandWordAndValue) {
  Start();
  Enable();
  auto get = drive_->SendNative(LinMotDnRequest{0x1018, 0});  // TC-19 Get Actual Position A
  ASSERT_TRUE(get.ok()) << get.status();
  EXPECT_EQ(get->word2, 0x1018);
  EXPECT_EQ(get->status, 0u);
  EXPECT_EQ(get->word4 & 0x0002, 0x0002);                     // RUN State
  auto set = drive_->SendNative(LinMotDnRequest{0x1025, 3});  // Set Rise Curve Number
  ASSERT_TRUE(set.ok()) << set.status();
  EXPECT_EQ(set->word3, 3);
  const bool toggle = Sim().device.motors[0].command_toggle;
  auto home = drive_->SendNative(LinMotDnRequest{0x1015, 0});  // Move Home Position (T)
  ASSERT_TRUE(home.ok()) << home.status();
  EXPECT_NE(Sim().device.motors[0].command_toggle, toggle);
  auto refused = drive_->SendNative(LinMotDnRequest{0x104B, 1});  // In Position + below 2
  ASSERT_TRUE(refused.ok()) << refused.status();
  EXPECT_EQ(refused->status, kCodedRangeError);  // the drive's answer, not ours
  ASSERT_TRUE(drive_->AcknowledgeFault().ok());
  EXPECT_EQ(drive_->SendNative(LinMotDnRequest{0x0001, 0}).status().code(),
            absl::StatusCode::kInvalidArgument);  // §8.7 unknown ID
  EXPECT_EQ(drive_->SendNative(LinMotDnRequest{0x0068, 0}).status().code(),
            absl::StatusCode::kInvalidArgument);  // D-19
  EXPECT_EQ(drive_->SendNative(LinMotDnRequest{0x3011, 0}).status().code(),
            absl::StatusCode::kInvalidArgument);  // D-6: two motors
  EXPECT_EQ(drive_->SendNative(LinMotDnRequest{0x0005, 2}).status().code(),
            absl::StatusCode::kInvalidArgument);  // D-8: Control In owns the word
  EXPECT_EQ(drive_->SendNative(LinMotMcRequest{}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// TC-06 through the API: Reset Controller is carried by one poll only (D-28); the drive
// restarts, the gateway re-allocates after its duplicate MAC ID check.
TEST_F(DnDriveTest, NativeResetController_DriveRestartsAndReconnects) {
  Start();
  Enable();
  auto reset = drive_->SendNative(LinMotDnRequest{0x000F, 0});
  ASSERT_TRUE(reset.ok()) << reset.status();
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  const DriveStatus back =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_NE(back.state, DriveState::kOffline);
  EXPECT_EQ(Sim().device.controller_resets, 1u);  // exactly one reset
  EXPECT_GE(drive_->exchange_counters()->drive_restarts, 1u);
}

// ---- Safe recovery (issue 11, decision 1451) ---------------------------------------------------
// §8.4 / D-4: T-commands run only on a changed Start Command Toggle; the IDs below set a
// position set point or start motion. After a fault acknowledge or a power cycle, re-enabling
// must not make the drive execute any of them (the drive's own per-ID record, executed_by_id).

class DnRecoveryTest : public DnDriveTest {
 protected:
  uint64_t SetPointCommands() {
    const auto by_id = Sim().device.executed_by_id;
    uint64_t n = 0;
    for (uint8_t id : {0x11, 0x12, 0x13, 0x14, 0x15, 0x19, 0x20, 0x21, 0x22, 0x23, 0x68}) {
      n += by_id[id];
    }
    return n;
  }
  bool Moving() { return Sim().device.motors[0].motion_active; }
  double Position() { return Sim().device.motors[0].actual_mm; }
  void ReEnableAndExpectNothingResent(uint64_t commands, double position) {
    if (drive_->GetStatus().state == DriveState::kFault) {
      ASSERT_TRUE(drive_->AcknowledgeFault().ok());
    }
    Enable();
    const uint64_t from = drive_->link_health().replies;
    EXPECT_TRUE(WaitSim([&](const auto&) { return drive_->link_health().replies >= from + 40; }));
    EXPECT_EQ(SetPointCommands(), commands) << "set point executed after the re-enable";
    EXPECT_FALSE(Moving());
    EXPECT_NEAR(Position(), position, 0.1);  // In Pos window
    EXPECT_EQ(WaitFinal(Move(MoveAbsolute{60, 200, 2000, 2000}).id).state, CommandState::kDone);
    EXPECT_GT(SetPointCommands(), commands);
  }
};

TEST_F(DnRecoveryTest, CodedErrorMidMoveThenAcknowledge_ReEnableSendsNoStaleSetPoint) {
  Start();
  Enable();
  Move(MoveAbsolute{140, 50, 500, 500});
  ASSERT_TRUE(WaitSim([&](const auto& s) {
    return s.device.motors[0].motion_active && s.device.motors[0].actual_mm > 5;
  }));
  ASSERT_TRUE(server_->RaiseCodedError(kCodedRangeError).ok());
  ASSERT_EQ(WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; }).state,
            DriveState::kFault);
  ASSERT_TRUE(WaitSim([&](const auto&) { return !Moving(); }));
  ReEnableAndExpectNothingResent(SetPointCommands(), Position());
}

// Motors that come up initialised (INIT Done at power-up, §13.1 F1). Without that, Enable runs
// INIT first (D-10: RUN needs INIT Done) — a homing run that moves the axis by design, not a
// stale set point (docs/reliability.md "Safe recovery").
TEST_F(DnRecoveryTest, PowerCycleAfterMove_ReEnableSendsNoStaleSetPoint) {
  DnSimOptions o = SimDefaults();
  o.initialised = true;
  Start(o);
  Enable();
  ASSERT_EQ(WaitFinal(Move(MoveAbsolute{40, 200, 2000, 2000}).id).state, CommandState::kDone);
  const uint64_t connects = drive_->exchange_counters()->connects;
  server_->PowerCycle();
  const uint64_t commands = SetPointCommands();  // the new power-up's count, before any poll
  ASSERT_NE(WaitUntil([&](const DriveStatus& s) {
              return s.state != DriveState::kOffline &&
                     drive_->exchange_counters()->connects > connects;
            }).state,
            DriveState::kOffline);
  ReEnableAndExpectNothingResent(commands, Position());
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
