// LinMotUdpDrive tests over real loopback UDP against the simulated LinMot drive (sim/linmot):
// control word sequences, motion handles, faults, link loss, RTC parameters, native requests.
#include "adapters/linmot/linudp/drive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/linmot/mc/warn_word.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotServer;
using sim::linmot::SimOptions;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;  // bound for conditions that hold within a second

// ---- pure helpers ------------------------------------------------------------------------

TEST(MapLinMotState, MainStates_MapToUnifiedStates) {
  auto map = [](uint16_t sv, uint16_t sw = 0) {
    return MapLinMotState(true, mc::StateVar::FromRaw(sv), mc::StatusWord{sw});
  };
  EXPECT_EQ(map(0x0000), DriveState::kDisabled);
  EXPECT_EQ(map(0x0100), DriveState::kDisabled);
  EXPECT_EQ(map(0x0200), DriveState::kReady);
  EXPECT_EQ(map(0x030B), DriveState::kFault);
  EXPECT_EQ(map(0x0486), DriveState::kFault);
  EXPECT_EQ(map(0x0500), DriveState::kReady);
  EXPECT_EQ(map(0x0600), DriveState::kReady);
  EXPECT_EQ(map(0x0700), DriveState::kReady);
  EXPECT_EQ(map(0x0841), DriveState::kEnabled);  // in target, count 1
  EXPECT_EQ(map(0x0821), DriveState::kMoving);   // Motion Active
  EXPECT_EQ(map(0x0900), DriveState::kHoming);
  EXPECT_EQ(map(0x0C00, 1u << 13), DriveState::kMoving);
  EXPECT_EQ(map(0x0C00), DriveState::kReady);
  EXPECT_EQ(map(0x0E00), DriveState::kFault);
  EXPECT_EQ(map(0x1001), DriveState::kMoving);
  EXPECT_EQ(map(0x1500), DriveState::kReady);
  EXPECT_EQ(MapLinMotState(false, mc::StateVar::FromRaw(0x0800), {}), DriveState::kOffline);
}

TEST(PlannedVaiDuration, TrapezoidAndTriangle_MatchD21WorkedNumbers) {
  // linmot-mc.md §6.1 case A: 200 mm, 1 m/s, 10 m/s², 5 m/s² -> 0.35 s.
  EXPECT_NEAR(ToSeconds(PlannedVaiDuration(200, 0, 1000, 10000, 5000)), 0.35, 1e-9);
  // Case B: 10 mm, 1 m/s, 10 m/s² both -> 63.25 ms.
  EXPECT_NEAR(ToSeconds(PlannedVaiDuration(10, 0, 1000, 10000, 10000)), 0.06325, 1e-5);
  EXPECT_EQ(PlannedVaiDuration(0, 0, 1000, 1000, 1000), Duration::zero());
}

// ---- against the simulated drive ---------------------------------------------------------

class LinMotUdpDriveTest : public ::testing::Test {
 protected:
  void SetUp() override { Start(SimOptions{}); }

  // `o`: the test's own simulator settings; the bench's loopback ports and short power-up
  // replace its bind, master_port and hw_test_time.
  void Start(SimOptions o) {
    const SimOptions bench = test_support::LinUdpSimOptions();
    o.bind = bench.bind;
    o.master_port = bench.master_port;
    o.hw_test_time = bench.hw_test_time;
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    config_ = test_support::LinUdpDriveConfig(server_->port());
    auto drive = CreateLinMotUdpDrive(config_, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
  }

  void TearDown() override {
    if (drive_) drive_->Deactivate();
  }

  // Waits (WaitForStatus, deadline) until `pred` holds for a published status.
  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::steady_clock::duration timeout = kWait) {
    return test_support::WaitStatus(*drive_, pred, timeout);
  }
  CommandInfo WaitFinal(uint64_t id, std::chrono::steady_clock::duration timeout = kWait) {
    return test_support::WaitCommandFinal(*drive_, id, timeout);
  }
  void EnableOrDie() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }
  CommandInfo MoveOrDie(const MotionCommand& cmd) {
    auto r = drive_->Move(cmd);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : CommandInfo{};
  }
  sim::linmot::DeviceSnapshot Sim() { return server_->Snapshot().device; }

  DriveConfig config_;
  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(LinMotUdpDriveTest, Activate_ReportsPowerUpStateWithoutTouchingTheDrive) {
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  // Power-up: state 0 or 1 (the sim's control word starts at 0), never switched on by connecting.
  EXPECT_EQ(s.state, DriveState::kDisabled);
  EXPECT_LE(s.native.main_state, 1u);
  EXPECT_NEAR(s.position_mm, 10.0, 1e-3);  // SimOptions.initial_position_mm
  EXPECT_THAT(s.warnings, ::testing::Contains("Motor Not Homed"));
  EXPECT_FALSE(s.homed);
  EXPECT_EQ(drive_->endpoint(), absl::StrCat("udp://127.0.0.1:", server_->port()));
}

// Issue 8 fleet card: the link health counts the cyclic exchange and keeps the last round trip.
TEST_F(LinMotUdpDriveTest, LinkHealth_CountsRequestsRepliesAndRoundTrip) {
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  const LinkHealth h = drive_->link_health();
  EXPECT_GT(h.requests, 0u);
  EXPECT_GT(h.replies, 0u);
  EXPECT_LE(h.replies, h.requests);
  ASSERT_TRUE(h.last_round_trip_ms.has_value());
  EXPECT_GE(*h.last_round_trip_ms, 0.0);
  EXPECT_LE(*h.last_round_trip_ms, 30.0);  // reply_timeout: a later reply is a timeout
}

TEST_F(LinMotUdpDriveTest, Enable_FromPowerUp_DoneInOperationEnabled) {
  EnableOrDie();
  const DriveStatus s = drive_->GetStatus();
  EXPECT_EQ(s.state, DriveState::kEnabled);
  EXPECT_EQ(s.native.main_state, 8u);
  EXPECT_EQ(s.native.text, "Operation Enabled");
  EXPECT_EQ(Sim().control_word, 0x003F);
  EXPECT_EQ(s.last_command->kind, "Enable");
  EXPECT_EQ(s.last_command->state, CommandState::kDone);
  // Idempotent.
  EnableOrDie();
}

TEST_F(LinMotUdpDriveTest, Disable_FromEnabled_Ready) {
  EnableOrDie();
  auto r = drive_->Disable();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->state, CommandState::kDone);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return s.native.main_state == 2; });
  EXPECT_EQ(s.state, DriveState::kReady);
  EXPECT_EQ(Sim().control_word, 0x003E);
}

TEST_F(LinMotUdpDriveTest, MoveAbsolute_RampsAndEndsDoneInTarget) {
  EnableOrDie();
  const CommandInfo cmd = MoveOrDie(MoveAbsolute{60, 200, 2000, 1000});
  EXPECT_EQ(cmd.state, CommandState::kActive);
  EXPECT_EQ(cmd.kind, "MoveAbsolute");
  const DriveStatus moving = WaitUntil(
      [](const DriveStatus& s) { return s.state == DriveState::kMoving && s.velocity_mm_s > 50; });
  EXPECT_EQ(moving.state, DriveState::kMoving);
  EXPECT_GT(moving.position_mm, 10.0);
  EXPECT_LT(moving.position_mm, 60.0);
  EXPECT_LE(moving.velocity_mm_s, 200 * 1.1);
  const CommandInfo done = WaitFinal(cmd.id);
  EXPECT_EQ(done.state, CommandState::kDone) << done.message;
  const DriveStatus s = drive_->GetStatus();
  EXPECT_NEAR(s.position_mm, 60.0, 0.011);
  EXPECT_NEAR(s.demand_position_mm, 60.0, 1e-6);
  EXPECT_TRUE(s.in_target);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

TEST_F(LinMotUdpDriveTest, MoveRelative_FromDemandPosition) {
  EnableOrDie();
  EXPECT_EQ(WaitFinal(MoveOrDie(MoveAbsolute{30, 500, 5000, 0}).id).state, CommandState::kDone);
  const CommandInfo rel = MoveOrDie(MoveRelative{-12.5, 500, 5000, 5000});
  EXPECT_EQ(WaitFinal(rel.id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().demand_position_mm, 17.5, 1e-6);
}

TEST_F(LinMotUdpDriveTest, MoveVelocity_RunsToTheStrokeEndInItsDirection) {
  EnableOrDie();
  const CommandInfo cmd = MoveOrDie(MoveVelocity{-400, 4000, 0});
  EXPECT_EQ(WaitFinal(cmd.id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().demand_position_mm, 0.0, 1e-6);  // axis.min_mm
}

TEST_F(LinMotUdpDriveTest, Retarget_AbortsThePreviousHandle_NewOneDone) {
  EnableOrDie();
  const CommandInfo first = MoveOrDie(MoveAbsolute{140, 100, 1000, 1000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 15; });
  const CommandInfo second = MoveOrDie(MoveAbsolute{20, 300, 2000, 2000});
  const CommandInfo aborted = *drive_->GetCommand(first.id);
  EXPECT_EQ(aborted.state, CommandState::kAborted);
  EXPECT_THAT(aborted.message, HasSubstr("superseded"));
  EXPECT_EQ(WaitFinal(second.id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().demand_position_mm, 20.0, 1e-6);
  EXPECT_EQ(drive_->GetCommand(first.id)->state, CommandState::kAborted);
}

TEST_F(LinMotUdpDriveTest, Stop_DeceleratesAndEndsDone_MoveAborted) {
  EnableOrDie();
  const CommandInfo move = MoveOrDie(MoveAbsolute{140, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 30; });
  const CommandInfo stop = MoveOrDie(StopMotion{4000});
  EXPECT_EQ(stop.kind, "Stop");
  EXPECT_EQ(drive_->GetCommand(move.id)->state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(stop.id).state, CommandState::kDone);
  const DriveStatus s = drive_->GetStatus();
  EXPECT_FALSE(s.motion_active);
  EXPECT_GT(s.demand_position_mm, 30);
  EXPECT_LT(s.demand_position_mm, 140);
}

TEST_F(LinMotUdpDriveTest, Move_NotEnabled_FailedPreconditionAndDriveUntouched) {
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  auto r = drive_->Move(MoveAbsolute{50, 100, 1000, 1000});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(r.status().message(), HasSubstr("needs main state 8"));
  EXPECT_THAT(r.status().message(), HasSubstr("main state"));
  // linmot-mc.md D-36: nothing was sent, so the drive never raised 0086h.
  const auto sim = Sim();
  EXPECT_EQ(sim.mc_commands_rejected, 0u);
  EXPECT_EQ(sim.error_code, 0u);
  EXPECT_FALSE(drive_->GetStatus().last_command.has_value());
}

TEST_F(LinMotUdpDriveTest, Move_BadArguments_RejectedNamingTheField) {
  EnableOrDie();
  auto zero = drive_->Move(MoveAbsolute{50, 0, 1000, 1000});
  EXPECT_EQ(zero.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(zero.status().message(), HasSubstr("move_absolute.velocity_mm_s"));
  auto far = drive_->Move(MoveAbsolute{151, 100, 1000, 1000});
  EXPECT_EQ(far.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(far.status().message(), HasSubstr("move_absolute.position_mm"));
  auto fast = drive_->Move(MoveRelative{10, 5000, 1000, 1000});
  EXPECT_EQ(fast.status().code(), absl::StatusCode::kOutOfRange);
  auto beyond = drive_->Move(MoveRelative{-20, 100, 1000, 1000});  // 10 - 20 < min 0
  EXPECT_EQ(beyond.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(beyond.status().message(), HasSubstr("move_relative.distance_mm"));
  EXPECT_EQ(drive_->Move(MoveVelocity{0, 100, 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Sim().mc_commands_executed, 0u);
}

TEST_F(LinMotUdpDriveTest, FaultRaisedBySim_FaultWithCodeAndText_MoveHandleError) {
  EnableOrDie();
  const CommandInfo move = MoveOrDie(MoveAbsolute{140, 100, 1000, 1000});
  ASSERT_TRUE(server_->RaiseError(mc::kPwrVoltageTooLow).ok());
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return s.native.main_state == 4; });
  EXPECT_EQ(s.state, DriveState::kFault);
  EXPECT_EQ(s.fault.code, mc::kPwrVoltageTooLow);
  EXPECT_THAT(s.fault.text, HasSubstr("X1 Pwr Voltage Too Low"));
  EXPECT_FALSE(s.fault.fatal);
  const CommandInfo ended = WaitFinal(move.id);
  EXPECT_EQ(ended.state, CommandState::kError);
  EXPECT_THAT(ended.message, HasSubstr("X1 Pwr Voltage Too Low"));
  // Enable refuses while the fault is pending.
  auto en = drive_->Enable();
  EXPECT_EQ(en.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(en.status().message(), HasSubstr("AcknowledgeFault"));
  EXPECT_EQ(mc::GetErrorCode(en.status()), mc::kPwrVoltageTooLow);
}

TEST_F(LinMotUdpDriveTest, AcknowledgeFault_ClearsAndReleasesAntiRestart_ThenEnable) {
  EnableOrDie();
  ASSERT_TRUE(server_->RaiseError(mc::kPwrVoltageTooLow).ok());
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; });
  auto ack = drive_->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(ack->state, CommandState::kDone);
  const DriveStatus s = drive_->GetStatus();
  EXPECT_EQ(s.native.main_state, 2u);  // D-04: 0 -> anti-restart released -> 2
  EXPECT_EQ(s.state, DriveState::kReady);
  EXPECT_EQ(s.fault.code, 0u);
  EnableOrDie();
  // Nothing pending: DONE at once.
  auto again = drive_->AcknowledgeFault();
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(drive_->GetStatus().native.main_state, 8u);
}

TEST_F(LinMotUdpDriveTest, AcknowledgeFault_Fatal_FailedPreconditionWithCode) {
  EnableOrDie();
  ASSERT_TRUE(server_->RaiseError(mc::kPwrOverCurrent).ok());
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; });
  EXPECT_TRUE(s.fault.fatal);
  auto ack = drive_->AcknowledgeFault();
  ASSERT_FALSE(ack.ok());
  EXPECT_EQ(ack.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(ack.status().message(), HasSubstr("fatal"));
  EXPECT_EQ(mc::GetErrorCode(ack.status()), mc::kPwrOverCurrent);
  EXPECT_EQ(drive_->GetStatus().native.main_state, 4u);
}

TEST_F(LinMotUdpDriveTest, LinkLoss_OfflineThenRecovery) {
  EnableOrDie();
  server_->SetAnswering(false);
  DriveStatus s = WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  EXPECT_EQ(s.state, DriveState::kOffline);
  auto move = drive_->Move(MoveAbsolute{50, 100, 1000, 1000});
  EXPECT_EQ(move.status().code(), absl::StatusCode::kUnavailable);
  server_->SetAnswering(true);
  s = WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_EQ(s.state, DriveState::kEnabled);
  auto* d = dynamic_cast<LinMotUdpDrive*>(drive_.get());
  ASSERT_NE(d, nullptr);
  EXPECT_GE(d->exchange_counters()->timeouts, 3u);
  EXPECT_GT(d->exchange_counters()->replies, 0u);
}

TEST_F(LinMotUdpDriveTest, MoveNotAccepted_ErrorAndNeverExecutedLater) {
  EnableOrDie();
  const double before = Sim().demand_position_mm;
  server_->SetAnswering(false);  // the drive reads nothing: the command cannot be accepted
  auto r = drive_->Move(MoveAbsolute{100, 500, 5000, 5000});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.status().code(), ::testing::AnyOf(absl::StatusCode::kDeadlineExceeded,
                                                  absl::StatusCode::kUnavailable));
  ASSERT_TRUE(drive_->GetStatus().last_command.has_value());
  EXPECT_EQ(drive_->GetStatus().last_command->state, CommandState::kError);
  server_->SetAnswering(true);
  WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  // An RTC round trip proves telegrams (still carrying the MC block) reached the drive again.
  {
    auto rp = drive_->ReadParameter({sim::linmot::upid::kPredefVelocity, false});
    ASSERT_TRUE(rp.ok()) << rp.status();
  }
  const auto sim = Sim();
  EXPECT_FALSE(sim.motion_active);
  EXPECT_NEAR(sim.demand_position_mm, before, 1e-9);  // the block was disarmed to a NOP
  // The count ring goes on: the next command is accepted normally.
  EXPECT_EQ(WaitFinal(MoveOrDie(MoveAbsolute{30, 500, 5000, 5000}).id).state, CommandState::kDone);
}

TEST_F(LinMotUdpDriveTest, Home_ActiveThenDoneHomed) {
  EnableOrDie();
  auto home = drive_->Home();
  ASSERT_TRUE(home.ok()) << home.status();
  EXPECT_NE(home->state, CommandState::kError);
  const CommandInfo done = WaitFinal(home->id);
  EXPECT_EQ(done.state, CommandState::kDone) << done.message;
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return s.native.main_state == 8; });
  EXPECT_TRUE(s.homed);
  EXPECT_EQ(s.state, DriveState::kEnabled);
  EXPECT_THAT(s.warnings, ::testing::Not(::testing::Contains("Motor Not Homed")));
  EXPECT_EQ(Sim().control_word & 0x0800, 0);  // bit 11 released (D-06)
}

TEST_F(LinMotUdpDriveTest, Home_NotEnabled_FailedPrecondition) {
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  EXPECT_EQ(drive_->Home().status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(LinMotUdpDriveTest, Parameters_RamRomRoundTrip) {
  const ParameterRef ram{sim::linmot::upid::kPredefVelocity, false};
  const ParameterRef rom{sim::linmot::upid::kPredefVelocity, true};
  auto before = drive_->ReadParameter(ram);
  ASSERT_TRUE(before.ok()) << before.status();
  ASSERT_TRUE(drive_->WriteParameter(ram, 123456).ok());
  EXPECT_EQ(*drive_->ReadParameter(ram), 123456);
  EXPECT_EQ(*drive_->ReadParameter(rom), *before);  // D-31: RAM writes leave ROM alone
  ASSERT_TRUE(drive_->WriteParameter(rom, 654321).ok());
  EXPECT_EQ(*drive_->ReadParameter(rom), 654321);
  EXPECT_EQ(*drive_->ReadParameter(ram), 123456);
  // Signed values survive the two 16-bit words.
  ASSERT_TRUE(drive_->WriteParameter({sim::linmot::upid::kCmdTabVar1, false}, -5).ok());
  EXPECT_EQ(*drive_->ReadParameter({sim::linmot::upid::kCmdTabVar1, false}), -5);
}

TEST_F(LinMotUdpDriveTest, Parameters_DriveErrors_MappedWithRtcStatus) {
  auto unknown = drive_->ReadParameter({0x7777, false});
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(unknown.status().message(), HasSubstr("0xC0"));
  EXPECT_THAT(unknown.status().message(), HasSubstr("UPID 0x7777"));
  auto read_only = drive_->WriteParameter({sim::linmot::upid::kActualPosition, false}, 1);
  EXPECT_EQ(read_only.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(read_only.message(), HasSubstr("0xC3"));
  EXPECT_EQ(drive_->ReadParameter({0x10000, false}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(drive_->WriteParameter({0x1450, false}, int64_t{1} << 33).code(),
            absl::StatusCode::kOutOfRange);
}

TEST_F(LinMotUdpDriveTest, NativeRtc_PassesStatusAndWordsThrough) {
  auto r = drive_->SendNative(LinMotRtcRequest{0x11, sim::linmot::upid::kPredefVelocity, 0, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->status, 0u);
  EXPECT_EQ(r->word2, sim::linmot::upid::kPredefVelocity);
  const int32_t value = static_cast<int32_t>(r->word3 | (uint32_t{r->word4} << 16));
  EXPECT_EQ(value, *drive_->ReadParameter({sim::linmot::upid::kPredefVelocity, false}));
  auto bad = drive_->SendNative(LinMotRtcRequest{0x99, 0, 0, 0});
  ASSERT_TRUE(bad.ok()) << bad.status();
  EXPECT_EQ(bad->status, 0xC0u);  // the raw code goes upward
}

TEST_F(LinMotUdpDriveTest, NativeMc_CountHandshakeAndCompletion) {
  EnableOrDie();
  auto params = mc::ParameterBytes(mc::VaiGoToPos(300000, 300000, 300000, 300000));
  ASSERT_TRUE(params.ok());
  auto r = drive_->SendNative(LinMotMcRequest{0x01, 0x0, *params});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_GT(r->command_id, 0u);
  EXPECT_EQ(r->word2 >> 8, 8u);  // state var at acceptance: main state 8
  EXPECT_EQ(WaitFinal(r->command_id).state, CommandState::kDone);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return !s.motion_active; });
  EXPECT_NEAR(s.demand_position_mm, 30.0, 1e-6);
  // Unknown ID and short parameters never reach the drive.
  auto unknown = drive_->SendNative(LinMotMcRequest{0x13, 0x0, {}});
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kInvalidArgument);
  auto shorter = drive_->SendNative(LinMotMcRequest{0x01, 0x0, {1, 2}});
  EXPECT_EQ(shorter.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Sim().mc_commands_rejected, 0u);
}

TEST_F(LinMotUdpDriveTest, CountRing_ManyCommands_EveryOneAccepted) {
  EnableOrDie();
  // D-09: more commands than the 15 counts of the ring, each accepted by its echo.
  for (int i = 0; i < 20; ++i) {
    auto r = drive_->Move(MoveAbsolute{10.0 + (i % 2), 1000, 20000, 20000});
    ASSERT_TRUE(r.ok()) << i << ": " << r.status();
    EXPECT_EQ(WaitFinal(r->id).state, CommandState::kDone) << i;
  }
}

TEST_F(LinMotUdpDriveTest, Deactivate_AbortsOpenMotionAndGoesOffline) {
  EnableOrDie();
  const CommandInfo move = MoveOrDie(MoveAbsolute{140, 50, 1000, 1000});
  drive_->Deactivate();
  EXPECT_EQ(drive_->GetCommand(move.id)->state, CommandState::kAborted);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kOffline);
  EXPECT_EQ(drive_->lifecycle(), Lifecycle::kInactive);
  EXPECT_EQ(drive_->Move(StopMotion{}).status().code(), absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE(drive_->Activate().ok());  // re-activation works
  WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  EXPECT_EQ(drive_->GetStatus().native.main_state, 8u);  // the drive kept its state
}

class LinMotUdpDriveBusyRtcTest : public LinMotUdpDriveTest {
 protected:
  void SetUp() override {
    SimOptions o;
    o.rtc_busy_telegrams = 3;  // A-09 test option: 0x02 for three telegrams first
    Start(o);
  }
};

TEST_F(LinMotUdpDriveBusyRtcTest, BusyStatus_ResentUntilDone) {
  ASSERT_TRUE(drive_->WriteParameter({sim::linmot::upid::kPredefVelocity, false}, 4242).ok());
  EXPECT_EQ(*drive_->ReadParameter({sim::linmot::upid::kPredefVelocity, false}), 4242);
}

class LinMotUdpDriveRestartTest : public LinMotUdpDriveTest {
 protected:
  void SetUp() override {
    SimOptions o;
    o.boot_time = 300ms;
    Start(o);
  }
};

TEST_F(LinMotUdpDriveRestartTest, NativeRestart_A11_ReturnsAfterRebootAndDriveUsable) {
  EnableOrDie();
  auto r = drive_->SendNative(LinMotRtcRequest{0x30, 0, 0, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->status, 0u);
  const auto sim = Sim();
  EXPECT_EQ(sim.boots, 1u);
  EXPECT_EQ(sim.rtc_count, 0u);
  // Rebooted: power-up state again, the anti-restart lock included (the gateway still sends
  // 0x003F), and the next RTC command works with count 1.
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  EXPECT_LE(s.native.main_state, 2u);
  EXPECT_TRUE(drive_->ReadParameter({sim::linmot::upid::kPredefVelocity, false}).ok());
  EnableOrDie();
  EXPECT_EQ(WaitFinal(MoveOrDie(MoveAbsolute{20, 500, 5000, 0}).id).state, CommandState::kDone);
}

TEST(CreateLinMotUdpDrive, MissingOrBadConfig_InvalidArgumentNamingField) {
  DriveConfig c;
  c.name = "x9";
  c.family = "linmot";
  auto missing = CreateLinMotUdpDrive(c, SteadyClock::Instance());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(missing.status().message(), HasSubstr("drive 'x9'.linudp"));
  c.linudp = LinUdpConfig{};
  c.linudp->host = "";
  EXPECT_THAT(CreateLinMotUdpDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr(".linudp.host: must not be empty"));
  // A host name is accepted here and resolved when the drive is activated (Endpoint::Resolve).
  c.linudp->host = "drive.local";
  EXPECT_TRUE(CreateLinMotUdpDrive(c, SteadyClock::Instance()).ok());
  c.linudp = LinUdpConfig{};
  c.linudp->cycle = 0ms;
  EXPECT_THAT(CreateLinMotUdpDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr(".linudp.cycle"));
  // Decision 1311: the I/O thread's scheduling is checked before anything is opened.
  c.linudp = LinUdpConfig{};
  c.linudp->io_priority = 100;
  EXPECT_THAT(CreateLinMotUdpDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x9'.linudp.io_priority: 100 is outside 0..99"));
  c.linudp = LinUdpConfig{};
  c.linudp->io_cpus = {0, 0};
  EXPECT_THAT(CreateLinMotUdpDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("drive 'x9'.linudp.io_cpus[1]: CPU 0 is given twice"));
  c.linudp = LinUdpConfig{};
  auto ok = CreateLinMotUdpDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ((*ok)->lifecycle(), Lifecycle::kUnconfigured);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
