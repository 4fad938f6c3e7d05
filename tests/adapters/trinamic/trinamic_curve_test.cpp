// TrinamicDrive::RunCurve against the simulated SIXpack on a real pseudo-terminal, real time: the
// curve as timed position-mode legs ends DONE exactly at its end point with progress rising to 1
// in the status; refused away from the start; a Move supersedes it (ABORTED) and completes; a
// link loss ends it ERROR (decisions 013, 1231-1233). 1 mm = 1 microstep; waits are bounded
// conditions, never sleeps.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/trinamic/drive.h"
#include "adapters/trinamic/factory.h"
#include "sim/trinamic/server.h"
#include "tests/support/curve_run_checks.h"
#include "tests/support/wait_status.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;
using sim::trinamic::Controller;
using sim::trinamic::ServerOptions;
using sim::trinamic::TrinamicServer;
using ::testing::HasSubstr;

std::string TempLink() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("dgw-trcurve-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

Curve Stroke(double from, double to, double duration_s) {
  return test_support::CosineStroke(from, to, duration_s, /*whole_units=*/true);
}

class TrinamicCurveTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.pty_path = TempLink();
    auto s = TrinamicServer::Start(options, SteadyClock::Instance());
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
    DriveConfig c;
    c.name = "feeder-x";
    c.family = kFamilyName;
    // 1 mm = 1 microstep; limits fit the PACK defaults (vmax 511 = 25991 µsteps/s, amax <= 320 =
    // 127 kµsteps/s², §5.1, §5.3).
    c.axis.min_mm = -20000;
    c.axis.max_mm = 20000;
    c.axis.max_velocity_mm_s = 26000;
    c.axis.max_acceleration_mm_s2 = 120000;
    c.timeouts.request = 2000ms;
    c.timeouts.accept = 100ms;
    TrinamicConfig t;
    t.address = 1;
    t.axis = 0;
    t.axes = 6;
    t.microsteps_per_unit = 1;
    t.poll_period = 5ms;
    t.reply_timeout = 60ms;
    t.offline_after_misses = 3;
    t.serial = SerialLineConfig{server_->slave_path(), 19200, false, 6000us};
    c.trinamic = t;
    auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(d.ok()) << d.status();
    drive_ = std::move(*d);
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus st =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(st.state, DriveState::kOffline) << st.native.text;
    auto en = drive_->Enable();
    ASSERT_TRUE(en.ok()) << en.status();
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }
  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::milliseconds timeout = 10000ms) {
    return test_support::WaitStatus(*drive_, pred, timeout);
  }
  CommandInfo WaitFinal(uint64_t id) {
    return test_support::WaitCommandFinal(*drive_, id, 15000ms);
  }
  int32_t SimPosition() {
    int32_t p = 0;
    server_->WithController([&](Controller& c) { p = c.state(0).position; });
    return p;
  }
  // Every progress value of command `id` the status stream showed until it ended.
  std::vector<double> ProgressUntilFinal(uint64_t id) {
    return test_support::WatchProgress(*drive_, id, 15s).progress;
  }

  std::unique_ptr<TrinamicServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(TrinamicCurveTest, RunsToTheEndPointDone_ProgressRisesToOneInTheStatus) {
  auto r = drive_->RunCurve(Stroke(0, 2000, 1.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->kind, "RunCurve");
  EXPECT_EQ(r->state, CommandState::kActive);
  const std::vector<double> progress = ProgressUntilFinal(r->id);
  const CommandInfo done = WaitFinal(r->id);
  ASSERT_EQ(done.state, CommandState::kDone) << done.message;
  EXPECT_THAT(done.message, HasSubstr("end point reached at 2000"));
  ASSERT_TRUE(done.progress.has_value());
  EXPECT_DOUBLE_EQ(*done.progress, 1.0);
  test_support::ExpectProgressRisesToOne(progress);
  // The PACK lands on a ramp's target exactly (§5.4).
  EXPECT_EQ(SimPosition(), 2000);
  const DriveStatus s = WaitUntil([](const DriveStatus& s) {
    return s.state == DriveState::kEnabled && s.position_mm == 2000;
  });
  EXPECT_EQ(s.state, DriveState::kEnabled);
  EXPECT_TRUE(s.in_target);
  // Back along a curve that reverses on the way: it still ends on its end point.
  PositionTimeCurve back;
  back.time_step_s = 0.05;
  back.positions_mm = {2000, 2100, 2200, 2100, 1800, 1200, 600, 200, 0};
  Curve c;
  c.name = "back";
  c.shape = back;
  auto again = drive_->RunCurve(c, CurveRunOptions{});
  ASSERT_TRUE(again.ok()) << again.status();
  const CommandInfo done2 = WaitFinal(again->id);
  EXPECT_EQ(done2.state, CommandState::kDone) << done2.message;
  EXPECT_EQ(SimPosition(), 0);
}

TEST_F(TrinamicCurveTest, RefusedAwayFromTheStart_MessageNamesBothPositions) {
  const auto before = drive_->GetStatus().last_command;
  auto r = drive_->RunCurve(Stroke(500, 2000, 0.5), CurveRunOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("axis at 0 mm"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("starts at 500 mm"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("'stroke'"));
  const auto after = drive_->GetStatus().last_command;
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->id, before->id);  // refused: no handle
  EXPECT_EQ(SimPosition(), 0);
}

TEST_F(TrinamicCurveTest, MoveDuringTheRunAbortsIt_AndTheMoveCompletes) {
  auto r = drive_->RunCurve(Stroke(0, 8000, 3.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  WaitUntil([&](const DriveStatus&) {
    const auto info = drive_->GetCommand(r->id);
    return info->progress && *info->progress > 0.1;
  });
  ASSERT_GT(*drive_->GetCommand(r->id)->progress, 0.1);
  EXPECT_EQ(drive_->GetStatus().state, DriveState::kMoving);
  // A second curve is refused while the first runs.
  EXPECT_EQ(drive_->RunCurve(Stroke(0, 100, 0.5), CurveRunOptions{}).status().code(),
            absl::StatusCode::kFailedPrecondition);
  auto m = drive_->Move(MoveAbsolute{-1000, 5000, 50000, 50000});
  ASSERT_TRUE(m.ok()) << m.status();
  const CommandInfo aborted = WaitFinal(r->id);
  EXPECT_EQ(aborted.state, CommandState::kAborted);
  EXPECT_THAT(aborted.message, HasSubstr("superseded by MoveAbsolute"));
  EXPECT_LT(*aborted.progress, 1.0);
  // No later leg of the curve overrides the Move.
  const CommandInfo moved = WaitFinal(m->id);
  EXPECT_EQ(moved.state, CommandState::kDone) << moved.message;
  EXPECT_EQ(SimPosition(), -1000);
  // The runner let go: a curve from here runs.
  auto next = drive_->RunCurve(Stroke(-1000, 0, 0.5), CurveRunOptions{});
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_EQ(WaitFinal(next->id).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(), 0);
}

TEST_F(TrinamicCurveTest, LinkLossDuringTheRunEndsItError) {
  auto r = drive_->RunCurve(Stroke(0, 6000, 2.0), CurveRunOptions{});
  ASSERT_TRUE(r.ok()) << r.status();
  WaitUntil([&](const DriveStatus&) {
    const auto info = drive_->GetCommand(r->id);
    return info->progress && *info->progress > 0.1;
  });
  server_->SetSilent(true);  // executes words, answers no query
  const CommandInfo lost = WaitFinal(r->id);
  EXPECT_EQ(lost.state, CommandState::kError);
  // Seen first by the poll (the handle's link-loss end) or by the next leg's word (refused by the
  // offline Pack): either way ERROR naming the cause.
  EXPECT_THAT(lost.message, ::testing::AnyOf(HasSubstr("link lost"), HasSubstr("OFFLINE")));
  EXPECT_LT(*lost.progress, 1.0);
  server_->SetSilent(false);
  const DriveStatus back = WaitUntil([](const DriveStatus& s) {
    return s.state == DriveState::kEnabled || s.state == DriveState::kDisabled;
  });
  EXPECT_NE(back.state, DriveState::kOffline);
  EXPECT_EQ(drive_->GetCommand(r->id)->state, CommandState::kError);  // final states are sticky
}

}  // namespace
}  // namespace drivegw::trinamic
