// LinMotDnDrive::RunCurve against the simulated LinMot DeviceNet drive on the user-space CAN bus
// (UDP multicast, a fresh port per test), real time: the curve as timed set-point legs (0x51 +
// 0x11) ends DONE at its end point with progress rising to 1 in the status; refused away from the
// start and for a leg the set-point command cannot carry; a Move supersedes it (ABORTED) and
// completes; a fault and a link loss end it ERROR (decisions 013, 987). Waits are bounded
// conditions, never sleeps.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/linmot/devicenet/factory.h"
#include "sim/linmot_devicenet/device.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/support/curve_run_checks.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::devicenet {
namespace {

using namespace std::chrono_literals;
using sim::linmot_devicenet::DnSimOptions;
using sim::linmot_devicenet::LinMotDnDevice;
using sim::linmot_devicenet::LinMotDnServer;
using ::testing::HasSubstr;

constexpr auto kWait = 15s;                 // generous: ctest -j3 on two cores
constexpr char kGroup[] = "239.74.163.94";  // not the drive tests' group: no stray traffic

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

Curve Stroke(double from, double to, double duration_s) {
  return test_support::CosineStroke(from, to, duration_s);
}

class DnCurveTest : public ::testing::Test {
 protected:
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  // `max_velocity` / `max_acceleration`: the axis limits of the drive configuration.
  void Start(double max_velocity = 1000, double max_acceleration = 20000) {
    port_ = UniquePort();
    DnSimOptions o;
    o.duplicate_check_wait = 50ms;  // §5.7 timing shortened for tests
    o.can = Bus(port_);
    auto server = LinMotDnServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    DriveConfig c;
    c.name = "x1";
    c.family = kFamilyName;
    c.axis.min_mm = 0;
    c.axis.max_mm = 150;
    c.axis.max_velocity_mm_s = max_velocity;
    c.axis.max_acceleration_mm_s2 = max_acceleration;
    c.can = Bus(port_);
    c.mac_id = o.mac_id;
    DnDriveOptions d;
    d.session.duplicate_check_wait = 50ms;
    d.restart_wait = 150ms;
    drive_ = std::make_unique<LinMotDnDrive>(c, SteadyClock::Instance(), d);
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus s =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(s.state, DriveState::kOffline) << "the simulated drive never answered a poll";
  }
  void Enable() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }

  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred) {
    return test_support::WaitStatus(*drive_, pred, kWait);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, kWait); }
  double SimActualMm() { return server_->Snapshot().device.motors[0].actual_mm; }
  int32_t SimSetpoint() { return server_->Snapshot().device.motors[0].setpoint; }
  // Every progress value of command `id` the status stream showed until it ended, and whether
  // the stream showed MOVING while it ran.
  std::vector<double> ProgressUntilFinal(uint64_t id, bool* moving = nullptr) {
    test_support::ProgressTrace t = test_support::WatchProgress(*drive_, id, kWait);
    if (moving != nullptr && t.moving) *moving = true;
    return t.progress;
  }
  // Distinct Set Position Setpoint (0x11) values the gateway's polls carried (layout P: control
  // word, then the Addressed In command word and value, little-endian; §7.8).
  std::set<int16_t> SetpointsOnTheWire() {
    std::set<int16_t> out;
    for (const auto& f : server_->Frames()) {
      if (f.transmitted || f.frame.id != 0x42D || f.frame.dlc < 6) continue;
      if ((f.frame.data[2] & 0x7F) != 0x11) continue;
      out.insert(static_cast<int16_t>(f.frame.data[4] | (f.frame.data[5] << 8)));
    }
    return out;
  }

  uint16_t port_ = 0;
  std::unique_ptr<LinMotDnServer> server_;
  std::unique_ptr<LinMotDnDrive> drive_;
};

TEST_F(DnCurveTest, RunsToTheEndPointDone_ProgressRisesToOneInTheStatus) {
  Start();
  Enable();
  server_->ClearFrames();
  auto r = drive_->RunCurve(Stroke(0, 100, 1.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->kind, "RunCurve");
  EXPECT_EQ(r->state, CommandState::kActive);
  bool moving = false;
  const std::vector<double> progress = ProgressUntilFinal(r->id, &moving);
  const CommandInfo done = WaitFinal(r->id);
  ASSERT_EQ(done.state, CommandState::kDone) << done.message;
  EXPECT_THAT(done.message, HasSubstr("end point reached at 100"));
  ASSERT_TRUE(done.progress.has_value());
  EXPECT_DOUBLE_EQ(*done.progress, 1.0);
  test_support::ExpectProgressRisesToOne(progress);
  EXPECT_TRUE(moving);
  // Decision 987: 1 s at a 10 ms poll = 10 legs of 100 ms, each its own set-point on the wire,
  // the last one the end point (100 mm = 5120 increments, §0.5).
  const std::set<int16_t> setpoints = SetpointsOnTheWire();
  EXPECT_EQ(setpoints.size(), 10u);
  EXPECT_EQ(*setpoints.rbegin(), 5120);
  EXPECT_EQ(SimSetpoint(), 5120);
  EXPECT_NEAR(SimActualMm(), 100, 0.1);
  // The filter acceleration is the axis limit, rounded down: 20000 / 238.419 = 83.9 (§0.5).
  std::optional<int32_t> acc;
  server_->WithDevice([&](LinMotDnDevice& d) { acc = d.Parameter(Motor::kA, 0x52); });
  EXPECT_EQ(acc, 83);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) {
    return s.state == DriveState::kEnabled && std::fabs(s.position_mm - 100) < 0.1;
  });
  EXPECT_EQ(s.state, DriveState::kEnabled);
  EXPECT_TRUE(s.in_target);

  // Back along a curve that reverses on the way: it still ends on its end point.
  PositionTimeCurve back;
  back.time_step_s = 0.05;
  back.positions_mm = {100, 105, 110, 105, 90, 60, 30, 10, 5};
  Curve c;
  c.name = "back";
  c.shape = back;
  auto again = drive_->RunCurve(c, CurveRunOptions{});
  ASSERT_TRUE(again.ok()) << again.status();
  const CommandInfo done2 = WaitFinal(again->id);
  EXPECT_EQ(done2.state, CommandState::kDone) << done2.message;
  EXPECT_NEAR(SimActualMm(), 5, 0.1);
}

TEST_F(DnCurveTest, RefusedAwayFromTheStart_MessageNamesBothPositions) {
  Start();
  Enable();
  const auto before = drive_->GetStatus().last_command;
  auto r = drive_->RunCurve(Stroke(20, 100, 0.5), CurveRunOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("axis at 0 mm"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("starts at 20 mm"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("'stroke'"));
  const auto after = drive_->GetStatus().last_command;
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->id, before->id);  // refused: no handle
  EXPECT_EQ(SimSetpoint(), 0);
  // Within the tolerance it runs.
  CurveRunOptions wide;
  wide.start_tolerance_mm = 25;
  auto near = drive_->RunCurve(Stroke(20, 30, 0.3), wide);
  ASSERT_TRUE(near.ok()) << near.status();
  EXPECT_EQ(WaitFinal(near->id).state, CommandState::kDone);
}

// §8.4 / §0.5: 0x51 carries 6..24576 x 190.735 µm/s, 0x53 1..1536 x 238.419 mm/s²; a curve that
// needs more is refused before anything is sent, naming the leg, the field and the range.
TEST_F(DnCurveTest, LegBeyondTheSetpointCommand_RefusedNamingFieldAndLimit) {
  Start(/*max_velocity=*/10000, /*max_acceleration=*/200000);
  Enable();
  const auto before = drive_->GetStatus().last_command;
  PositionTimeCurve jump;
  jump.time_step_s = 0.02;
  jump.positions_mm = {0, 100};  // 5000 mm/s in one leg
  Curve c;
  c.name = "jump";
  c.shape = jump;
  auto r = drive_->RunCurve(c, CurveRunOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("leg 1 of 1"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("velocity_mm_s: 5000"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("4687.5"));
  EXPECT_EQ(drive_->GetStatus().last_command->id, before->id);
  EXPECT_EQ(SimSetpoint(), 0);
}

TEST_F(DnCurveTest, AxisAccelerationBelowOneIncrement_Refused) {
  Start(/*max_velocity=*/1000, /*max_acceleration=*/100);
  Enable();
  auto r = drive_->RunCurve(Stroke(0, 10, 1.0), CurveRunOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(std::string(r.status().message()),
              HasSubstr("axis.max_acceleration_mm_s2: 100 is outside the settable range"));
}

TEST_F(DnCurveTest, MoveDuringTheRunAbortsIt_AndTheMoveCompletes) {
  Start();
  Enable();
  auto r = drive_->RunCurve(Stroke(0, 140, 3.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  WaitUntil([&](const DriveStatus&) {
    const auto info = drive_->GetCommand(r->id);
    return info->progress && *info->progress > 0.1;
  });
  ASSERT_GT(*drive_->GetCommand(r->id)->progress, 0.1);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kMoving);
  // A second curve is refused while the first runs.
  auto second = drive_->RunCurve(Stroke(0, 10, 0.5), CurveRunOptions{});
  EXPECT_EQ(second.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(second.status().message()), HasSubstr("still running"));
  auto m = drive_->Move(MoveAbsolute{20, 500, 5000, 5000});
  ASSERT_TRUE(m.ok()) << m.status();
  const CommandInfo aborted = WaitFinal(r->id);
  EXPECT_EQ(aborted.state, CommandState::kAborted);
  EXPECT_THAT(aborted.message, HasSubstr("superseded by MoveAbsolute"));
  EXPECT_LT(*aborted.progress, 1.0);
  // No later leg of the curve overrides the Move.
  const CommandInfo moved = WaitFinal(m->id);
  EXPECT_EQ(moved.state, CommandState::kDone) << moved.message;
  EXPECT_EQ(SimSetpoint(), 1024);  // 20 mm
  EXPECT_NEAR(SimActualMm(), 20, 0.2);
  // The runner let go: a curve from here runs.
  auto next = drive_->RunCurve(Stroke(20, 0, 0.5), CurveRunOptions{});
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_EQ(WaitFinal(next->id).state, CommandState::kDone);
  EXPECT_EQ(SimSetpoint(), 0);
}

TEST_F(DnCurveTest, FaultDuringTheRunEndsItError) {
  Start();
  Enable();
  auto r = drive_->RunCurve(Stroke(0, 140, 3.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  WaitUntil([&](const DriveStatus&) {
    const auto info = drive_->GetCommand(r->id);
    return info->progress && *info->progress > 0.1;
  });
  server_->WithDevice(
      [](LinMotDnDevice& d) { d.SetMotorErrorCause(Motor::kA, kMotorFollowingError); });
  const CommandInfo failed = WaitFinal(r->id);
  EXPECT_EQ(failed.state, CommandState::kError);
  EXPECT_THAT(failed.message, HasSubstr("Following Error"));
  EXPECT_LT(*failed.progress, 1.0);
}

TEST_F(DnCurveTest, LinkLossDuringTheRunEndsItError) {
  Start();
  Enable();
  auto r = drive_->RunCurve(Stroke(0, 140, 3.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  WaitUntil([&](const DriveStatus&) {
    const auto info = drive_->GetCommand(r->id);
    return info->progress && *info->progress > 0.1;
  });
  server_->SetDropPolls(true);  // the drive stops answering: 4 x EPR, OFFLINE (decision 980)
  const CommandInfo lost = WaitFinal(r->id);
  EXPECT_EQ(lost.state, CommandState::kError);
  // Seen by the runner's check (the link's end) or by the next leg's transaction: either way
  // ERROR naming the lost link.
  EXPECT_THAT(lost.message, HasSubstr("lost"));
  EXPECT_LT(*lost.progress, 1.0);
  server_->SetDropPolls(false);
  const DriveStatus back =
      WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  EXPECT_NE(back.state, DriveState::kOffline);
  EXPECT_NE(back.state, DriveState::kMoving);                         // nothing replayed (983)
  EXPECT_EQ(drive_->GetCommand(r->id)->state, CommandState::kError);  // final states are sticky
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
