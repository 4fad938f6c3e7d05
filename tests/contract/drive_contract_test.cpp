// The drive contract: one TEST_P suite over every family, run through the Drive interface only
// against each family's simulator on real sockets. Case names carry their reference ids
// (linmot-mc.md §14 LMC-nn, linmot-mc.md D-nn, linmot-linudp.md A-nn).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <memory>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/registry.h"
#include "tests/contract/family_fixture.h"
#include "tests/support/wait_status.h"

namespace drivegw::contract {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using SteadyTime = std::chrono::steady_clock::time_point;

constexpr auto kWait = 10s;  // bound for conditions that hold within a second or two

class DriveContract : public ::testing::TestWithParam<FamilyCase> {
 protected:
  void SetUp() override {
    fixture_ = GetParam().make();
    ASSERT_TRUE(fixture_->Start(registry_).ok());
    auto drive = registry_.Create(fixture_->config(), SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
    // Activation may still be OFFLINE (drive.h); the first status answer comes within cycles.
    const DriveStatus s =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(s.state, DriveState::kOffline) << "the simulator never answered";
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (fixture_) fixture_->Stop();
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
    EXPECT_NE(r->state, CommandState::kBusy);  // accepted when returned
    return *r;
  }
  AxisConfig axis() const { return fixture_->config().axis; }
  double Mid() const { return (axis().min_mm + axis().max_mm) / 2; }

  DriveRegistry registry_;
  std::unique_ptr<FamilyFixture> fixture_;
  std::unique_ptr<Drive> drive_;
};

// LMC-01, LMC-03, LMC-04: from power-up (anti-restart lock included) to Operation Enabled.
TEST_P(DriveContract, LMC_01_03_04_EnableFromPowerUp_Enabled) {
  const DriveStatus before = drive_->GetStatus();
  EXPECT_THAT(before.state, ::testing::AnyOf(DriveState::kDisabled, DriveState::kReady));
  Enable();
  const DriveStatus s = drive_->GetStatus();
  ASSERT_TRUE(s.last_command.has_value());
  EXPECT_EQ(s.last_command->kind, "Enable");
  EXPECT_EQ(s.last_command->state, CommandState::kDone);
}

// §2.7 step 7 (T24): switching off returns to a power-off state; Enable works again.
TEST_P(DriveContract, LMC_T24_DisableAfterEnable_PowerOff) {
  Enable();
  auto r = drive_->Disable();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->state, CommandState::kDone);
  EXPECT_THAT(drive_->GetStatus().state,
              ::testing::AnyOf(DriveState::kDisabled, DriveState::kReady));
  Enable();
}

// LMC-06 / D-36: a motion command outside Operation Enabled is refused by the gateway, so the
// drive never sees it and does not fault.
TEST_P(DriveContract, LMC_06_MoveInWrongState_FailedPreconditionNoFault) {
  auto r = drive_->Move(MoveAbsolute{Mid(), 100, 1000, 1000});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(drive_->GetStatus().state, DriveState::kFault);
  EXPECT_EQ(drive_->Home().status().code(), absl::StatusCode::kFailedPrecondition);
}

// LMC-11, LMC-12: accepted (ACTIVE), moving, then DONE with In Target Position at the target.
TEST_P(DriveContract, LMC_11_12_MoveAbsolute_ReachesTargetDone) {
  Enable();
  const double target = Mid();
  const CommandInfo cmd = Move(MoveAbsolute{target, 200, 2000, 2000});
  const DriveStatus moving = WaitUntil([](const DriveStatus& s) { return s.motion_active; });
  EXPECT_EQ(moving.state, DriveState::kMoving);
  const CommandInfo done = WaitFinal(cmd.id);
  EXPECT_EQ(done.state, CommandState::kDone) << done.message;
  const DriveStatus s = drive_->GetStatus();
  EXPECT_NEAR(s.position_mm, target, 0.02);
  EXPECT_TRUE(s.in_target);
  EXPECT_FALSE(s.motion_active);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

// LMC-13: the profile respects the commanded velocity: the move cannot end sooner than
// distance / velocity.
TEST_P(DriveContract, LMC_13_MoveAbsolute_NotFasterThanCommanded) {
  Enable();
  const double start = drive_->GetStatus().position_mm;
  const double target = start + 40 <= axis().max_mm ? start + 40 : start - 40;
  const auto t0 = std::chrono::steady_clock::now();
  const CommandInfo cmd = Move(MoveAbsolute{target, 200, 4000, 4000});
  EXPECT_EQ(WaitFinal(cmd.id).state, CommandState::kDone);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(elapsed, 40.0 / 200 * 0.95);
}

// LMC-14: a new target while moving supersedes the running command (ABORTED), the new one ends
// DONE at its own target.
TEST_P(DriveContract, LMC_14_RetargetWhileMoving_PreviousAbortedNewDone) {
  Enable();
  const CommandInfo first = Move(MoveAbsolute{axis().max_mm - 5, 100, 1000, 1000});
  WaitUntil([](const DriveStatus& s) { return s.motion_active && s.velocity_mm_s > 20; });
  const double second_target = axis().min_mm + 20;
  const CommandInfo second = Move(MoveAbsolute{second_target, 300, 3000, 3000});
  const CommandInfo aborted = *drive_->GetCommand(first.id);
  EXPECT_EQ(aborted.state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(second.id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().position_mm, second_target, 0.02);
}

// LMC-15: a relative move ends at the start position + distance.
TEST_P(DriveContract, LMC_15_MoveRelative_EndsAtStartPlusDistance) {
  Enable();
  EXPECT_EQ(WaitFinal(Move(MoveAbsolute{Mid(), 500, 5000, 5000}).id).state, CommandState::kDone);
  const double start = drive_->GetStatus().demand_position_mm;
  EXPECT_EQ(WaitFinal(Move(MoveRelative{7.5, 300, 3000, 0}).id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().position_mm, start + 7.5, 0.02);
}

// LMC-17: Stop decelerates to standstill short of the original target; the move is ABORTED.
TEST_P(DriveContract, LMC_17_StopWhileMoving_StopDoneMoveAborted) {
  Enable();
  const double start = drive_->GetStatus().position_mm;
  const double far = axis().max_mm - 5;
  const CommandInfo move = Move(MoveAbsolute{far, 150, 1500, 1500});
  WaitUntil([&](const DriveStatus& s) { return s.position_mm > start + 10; });
  const CommandInfo stop = Move(StopMotion{3000});
  EXPECT_EQ(WaitFinal(stop.id).state, CommandState::kDone);
  EXPECT_EQ(drive_->GetCommand(move.id)->state, CommandState::kAborted);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) { return !s.motion_active; });
  EXPECT_LT(s.position_mm, far - 1);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

// LMC-27 (via Disable, §2.7 step 7): switching off during a motion interrupts its handle.
TEST_P(DriveContract, LMC_27_DisableDuringMotion_MoveAborted) {
  Enable();
  const CommandInfo move = Move(MoveAbsolute{axis().max_mm - 5, 100, 1000, 1000});
  WaitUntil([](const DriveStatus& s) { return s.motion_active; });
  ASSERT_TRUE(drive_->Disable().ok());
  const CommandInfo ended = WaitFinal(move.id);
  EXPECT_THAT(ended.state, ::testing::AnyOf(CommandState::kAborted, CommandState::kError));
  EXPECT_NE(drive_->GetStatus().state, DriveState::kMoving);
}

// LMC-10, D-09: the count handshake never loses or repeats a command: more commands than the
// count ring has values, each one accepted and done.
TEST_P(DriveContract, LMC_10_D09_ManyCommands_EachAcceptedOnce) {
  Enable();
  for (int i = 0; i < 18; ++i) {
    const double target = Mid() + (i % 2 == 0 ? 1.0 : -1.0);
    auto r = drive_->Move(MoveAbsolute{target, 500, 10000, 10000});
    ASSERT_TRUE(r.ok()) << i << ": " << r.status();
    ASSERT_EQ(WaitFinal(r->id).state, CommandState::kDone) << i;
    EXPECT_NEAR(drive_->GetStatus().demand_position_mm, target,
                std::max(1e-3, fixture_->PositionResolutionMm()))
        << i;
  }
}

// §2.7 step 3, D-06, D-39: homing returns ACTIVE, ends DONE with Homed and back in state 8.
TEST_P(DriveContract, D39_Home_DoneHomedAndEnabled) {
  Enable();
  auto r = drive_->Home();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_NE(r->state, CommandState::kBusy);
  EXPECT_EQ(WaitFinal(r->id).state, CommandState::kDone);
  const DriveStatus s =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_TRUE(s.homed);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

// LMC-08 (D-04, §2.7 step 5): a recoverable drive error shows as FAULT with code and text; the
// acknowledge clears it and the drive can be enabled again.
TEST_P(DriveContract, LMC_08_FaultThenAcknowledge_ClearedAndEnableable) {
  Enable();
  const CommandInfo move = Move(MoveAbsolute{axis().max_mm - 5, 100, 1000, 1000});
  ASSERT_TRUE(fixture_->InjectFault(false).ok());
  const DriveStatus f =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; });
  ASSERT_EQ(f.state, DriveState::kFault);
  EXPECT_NE(f.fault.code, 0u);
  EXPECT_FALSE(f.fault.text.empty());
  EXPECT_FALSE(f.fault.fatal);
  EXPECT_EQ(WaitFinal(move.id).state, CommandState::kError);
  EXPECT_EQ(drive_->Enable().status().code(), absl::StatusCode::kFailedPrecondition);
  auto ack = drive_->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(ack->state, CommandState::kDone);
  const DriveStatus s = drive_->GetStatus();
  EXPECT_NE(s.state, DriveState::kFault);
  EXPECT_EQ(s.fault.code, 0u);
  Enable();
}

// LMC-09: a fatal error cannot be acknowledged; the refusal says so and the drive stays FAULT.
TEST_P(DriveContract, LMC_09_FatalFault_AcknowledgeRefused) {
  Enable();
  const absl::Status injected = fixture_->InjectFault(true);
  if (absl::IsUnimplemented(injected)) GTEST_SKIP() << injected;
  ASSERT_TRUE(injected.ok()) << injected;
  const DriveStatus f =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kFault; });
  EXPECT_TRUE(f.fault.fatal);
  auto ack = drive_->AcknowledgeFault();
  ASSERT_FALSE(ack.ok());
  EXPECT_EQ(ack.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kFault);
}

// LMC-36: a warning condition is reported by name while it lasts.
TEST_P(DriveContract, LMC_36_Warning_ReportedByName) {
  auto name = fixture_->InjectWarning();
  if (absl::IsUnimplemented(name.status())) GTEST_SKIP() << name.status();
  ASSERT_TRUE(name.ok()) << name.status();
  const DriveStatus s = WaitUntil([&](const DriveStatus& s) {
    return std::find(s.warnings.begin(), s.warnings.end(), *name) != s.warnings.end();
  });
  EXPECT_THAT(s.warnings, ::testing::Contains(*name));
}

// linmot-linudp.md §5.3 (0x10-0x13), A-09: RAM and ROM values round-trip through the parameter
// channel.
TEST_P(DriveContract, LUDP_A09_ParameterRoundTrip_RamAndRom) {
  auto ref = fixture_->WritableParameter();
  if (absl::IsUnimplemented(ref.status())) GTEST_SKIP() << ref.status();
  ASSERT_TRUE(ref.ok());
  const int64_t value = fixture_->WritableParameterValue();
  ParameterRef ram = *ref, rom = *ref;
  ram.rom = false;
  rom.rom = true;
  ASSERT_TRUE(drive_->WriteParameter(ram, value).ok());
  auto read = drive_->ReadParameter(ram);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(*read, value);
  if (!fixture_->HasStoredParameters()) {
    EXPECT_EQ(drive_->WriteParameter(rom, value + 1).code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(*drive_->ReadParameter(ram), value);
    return;
  }
  ASSERT_TRUE(drive_->WriteParameter(rom, value + 1).ok());
  EXPECT_EQ(*drive_->ReadParameter(rom), value + 1);
  EXPECT_EQ(*drive_->ReadParameter(ram), value);
}

// linmot-linudp.md A-14: a parameter the drive does not know comes back as an error, not a value.
TEST_P(DriveContract, LUDP_A14_UnknownParameter_Error) {
  auto ref = fixture_->UnknownParameter();
  if (absl::IsUnimplemented(ref.status())) GTEST_SKIP() << ref.status();
  auto read = drive_->ReadParameter(*ref);
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.status().code(),
              ::testing::AnyOf(absl::StatusCode::kInvalidArgument, absl::StatusCode::kNotFound));
}

// linmot-linudp.md A-10: a silent drive goes OFFLINE (motion refused as Unavailable) and comes
// back with its state when it answers again.
TEST_P(DriveContract, LUDP_A10_LinkLoss_OfflineThenRecovery) {
  Enable();
  auto off = fixture_->SetAnswering(false);
  if (absl::IsUnimplemented(off)) GTEST_SKIP() << off;
  ASSERT_TRUE(off.ok());
  const DriveStatus lost =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  ASSERT_EQ(lost.state, DriveState::kOffline);
  EXPECT_EQ(drive_->Move(MoveAbsolute{Mid(), 100, 1000, 1000}).status().code(),
            absl::StatusCode::kUnavailable);
  // Decision 1431: every family reports the loss as DOWN through the shared model.
  const DriveStatus down = WaitUntil(
      [](const DriveStatus& s) { return s.health && s.health->state == HealthState::kDown; });
  ASSERT_TRUE(down.health.has_value());
  EXPECT_EQ(down.health->state, HealthState::kDown);
  EXPECT_FALSE(down.health->reason.empty());
  ASSERT_TRUE(fixture_->SetAnswering(true).ok());
  const DriveStatus up = WaitUntil(
      [](const DriveStatus& s) { return s.health && s.health->state == HealthState::kUp; });
  ASSERT_TRUE(up.health.has_value());
  EXPECT_EQ(up.health->state, HealthState::kUp);
  if (!fixture_->EnabledAcrossLinkLoss()) {
    const DriveStatus back =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    EXPECT_THAT(back.state, ::testing::AnyOf(DriveState::kDisabled, DriveState::kReady));
    ASSERT_TRUE(drive_->Enable().ok());
    return;
  }
  const DriveStatus back =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_EQ(back.state, DriveState::kEnabled);
}

INSTANTIATE_TEST_SUITE_P(Families, DriveContract,
                         ::testing::Values(FamilyCase{"linmot", &MakeLinMotUdpFixture},
                                           FamilyCase{"linmot_devicenet", &MakeLinMotDnFixture},
                                           FamilyCase{"trinamic", &MakeTrinamicFixture},
                                           FamilyCase{"stober", &MakeStoberFixture}),
                         [](const ::testing::TestParamInfo<FamilyCase>& info) {
                           return info.param.name;
                         });

}  // namespace
}  // namespace drivegw::contract
