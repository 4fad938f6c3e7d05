// LinMotUdpDrive curves over real loopback UDP against the simulated LinMot drive: curve service
// download with read-back (linmot-linudp.md §5.3/§5.4), 0xD4 and absent curves, a corrupted
// read-back, and RunCurve (044h) ACTIVE -> progress -> DONE at the end point, start check, abort.
// Decisions 013, 606, 607, 706, 707.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>

#include "adapters/core/clock.h"
#include "adapters/core/curve_run.h"
#include "adapters/linmot/linudp/curve_info_block.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/error_codes.h"
#include "sim/linmot/device.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotDevice;
using sim::linmot::LinMotServer;
using sim::linmot::SimOptions;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;  // bound for conditions that hold within a second or two

LinMotParametricCurve Ramp(int id) {
  LinMotParametricCurve c;
  c.curve_id = id;
  c.x_length_s = 0.5;
  c.points = {0, 100'000, 300'000};  // 0 -> 10 -> 30 mm
  c.offset_mm = 10;
  c.amplitude_scale_pct = 100;
  c.time_scale_pct = 100;
  return c;
}

// 10 mm -> 40 mm in 0.6 s (the simulator starts at 10 mm).
Curve Stroke(double start_mm = 10) {
  return Curve{"stroke", "",
               PositionTimeCurve{
                   0.15, {start_mm, start_mm + 5, start_mm + 15, start_mm + 25, start_mm + 30}}};
}

class LinMotUdpDriveCurvesTest : public ::testing::Test {
 protected:
  virtual SimOptions Options() { return SimOptions{}; }

  void SetUp() override {
    SimOptions o = Options();
    const SimOptions bench = test_support::LinUdpSimOptions();
    o.bind = bench.bind;
    o.master_port = bench.master_port;
    o.hw_test_time = bench.hw_test_time;
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);

    DriveConfig config = test_support::LinUdpDriveConfig(server_->port());
    auto drive = CreateLinMotUdpDrive(config, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
  }

  void EnableOrDie() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
  }
  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred) {
    return test_support::WaitStatus(*drive_, pred, kWait);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, kWait); }
  // The bytes the simulator stored under `id`, decoded with the shared layout.
  std::optional<WireCurve> Stored(uint16_t id) {
    std::optional<WireCurve> out;
    server_->WithDevice([&](LinMotDevice& d) {
      const auto* s = d.stored_curve(id);
      if (s == nullptr) return;
      auto info = DecodeCurveInfoBlock(s->info);
      auto points = DecodeCurveData(s->data);
      if (info.ok() && points.ok()) out = WireCurve{*info, *points};
    });
    return out;
  }
  uint64_t SimRtcCommands() { return server_->Snapshot().device.rtc_commands; }

  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(LinMotUdpDriveCurvesTest, DownloadParametric_StoredInTheSharedLayout_ReadsBackEqual) {
  ASSERT_TRUE(WaitUntil([](const DriveStatus& s) {
                return s.state != DriveState::kOffline;
              }).state != DriveState::kOffline);
  const LinMotParametricCurve curve = Ramp(5);
  absl::Status s = drive_->DownloadCurve(curve);
  ASSERT_TRUE(s.ok()) << s;
  const auto stored = Stored(5);
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(stored->info.x_length, 50'000u);  // offset 32, 10 µs (linmot-mc.md §7 L1000)
  EXPECT_EQ(stored->info.point_count, 3);
  EXPECT_EQ(stored->points, curve.points);
  auto back = drive_->UploadCurve(5);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, curve);
}

TEST_F(LinMotUdpDriveCurvesTest, DownloadPositionTime_WireFormReadsBack) {
  auto model = ToLinMotCurve(Stroke(), 100);
  ASSERT_TRUE(model.ok()) << model.status();
  ASSERT_TRUE(drive_->DownloadCurve(*model).ok());
  auto back = drive_->UploadCurve(100);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->points, (std::vector<int32_t>{100'000, 150'000, 250'000, 350'000, 400'000}));
  EXPECT_DOUBLE_EQ(back->x_length_s, 0.6);
  EXPECT_DOUBLE_EQ(back->offset_mm, 10.0);
}

TEST_F(LinMotUdpDriveCurvesTest, ReadBackMismatch_IsDataLossNamingThePoint) {
  server_->WithDevice([](LinMotDevice& d) { d.CorruptNextStoredCurvePoint(2); });
  absl::Status s = drive_->DownloadCurve(Ramp(6));
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << s;
  EXPECT_THAT(s.message(), HasSubstr("curve 6"));
  EXPECT_THAT(s.message(), HasSubstr("points[2]: sent 300000, read 300001"));
}

TEST_F(LinMotUdpDriveCurvesTest, AbsentCurve_UploadIsNotFound) {
  auto r = drive_->UploadCurve(42);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound) << r.status();
  EXPECT_THAT(r.status().message(), HasSubstr("no curve 42"));
  EXPECT_EQ(drive_->UploadCurve(0).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(LinMotUdpDriveCurvesTest, AlreadyDefined0xD4_IsModifiedInPlace) {
  ASSERT_TRUE(drive_->DownloadCurve(Ramp(7)).ok());
  LinMotParametricCurve other = Ramp(7);
  other.points = {0, 50'000, 60'000, 200'000};
  other.amplitude_scale_pct = 50;
  absl::Status s = drive_->DownloadCurve(other);
  ASSERT_TRUE(s.ok()) << s;
  auto back = drive_->UploadCurve(7);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, other);
}

TEST_F(LinMotUdpDriveCurvesTest, RunCurve_ActiveProgressRisesDoneAtTheEndPoint) {
  EnableOrDie();
  auto run = drive_->RunCurve(Stroke(), CurveRunOptions{});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_EQ(run->kind, "RunCurve");
  EXPECT_EQ(run->state, CommandState::kActive);
  const DriveStatus mid = WaitUntil([&](const DriveStatus& s) {
    return s.last_command && s.last_command->id == run->id && s.last_command->progress &&
           *s.last_command->progress >= 0.3;
  });
  ASSERT_TRUE(mid.last_command && mid.last_command->progress) << "no progress published";
  EXPECT_LT(*mid.last_command->progress, 1.0);
  EXPECT_EQ(mid.state, DriveState::kMoving);
  EXPECT_GT(mid.position_mm, 10.5);
  const CommandInfo done = WaitFinal(run->id);
  EXPECT_EQ(done.state, CommandState::kDone) << done.message;
  EXPECT_EQ(done.progress, 1.0);
  EXPECT_NEAR(drive_->GetStatus().position_mm, 40.0, 0.1);  // start_tolerance_mm
  const DriveStatus end = WaitUntil([](const DriveStatus& s) { return s.in_target; });
  EXPECT_NEAR(end.position_mm, 40.0, 0.011);  // the in-target window
}

TEST_F(LinMotUdpDriveCurvesTest, RunParametric_OwnIdAndScales_SecondRunUsesTheVerifiedCurve) {
  EnableOrDie();
  LinMotParametricCurve p = Ramp(9);
  p.amplitude_scale_pct = 50;  // 10 -> 25 mm
  p.time_scale_pct = 200;      // 0.25 s
  const Curve curve{"half", "", p};
  auto first = drive_->RunCurve(curve, CurveRunOptions{});
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(WaitFinal(first->id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().position_mm, 25.0, 0.1);
  ASSERT_TRUE(Stored(9).has_value());
  // Back to the start, run again: no second download (the session verified this curve).
  auto back = drive_->Move(MoveAbsolute{10, 200, 2000, 2000});
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(WaitFinal(back->id).state, CommandState::kDone);
  const uint64_t rtc_before = SimRtcCommands();
  auto second = drive_->RunCurve(curve, CurveRunOptions{});
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(WaitFinal(second->id).state, CommandState::kDone);
  EXPECT_LT(SimRtcCommands() - rtc_before, 5u);  // a download takes 1 + 18 + 3 + upload
}

TEST_F(LinMotUdpDriveCurvesTest, RunCurve_AwayFromTheStart_RefusedNamingBothPositions) {
  EnableOrDie();
  auto run = drive_->RunCurve(Stroke(50), CurveRunOptions{});
  EXPECT_EQ(run.status().code(), absl::StatusCode::kFailedPrecondition) << run.status();
  EXPECT_THAT(run.status().message(), HasSubstr("stands at 10.0000 mm"));
  EXPECT_THAT(run.status().message(), HasSubstr("starts at 50.0000 mm"));
  EXPECT_FALSE(Stored(100).has_value());  // refused before any download
}

TEST_F(LinMotUdpDriveCurvesTest, MoveDuringACurve_AbortsIt) {
  EnableOrDie();
  Curve slow = Stroke();
  std::get<PositionTimeCurve>(slow.shape).time_step_s = 0.5;  // 2 s
  auto run = drive_->RunCurve(slow, CurveRunOptions{});
  ASSERT_TRUE(run.ok()) << run.status();
  WaitUntil([&](const DriveStatus& s) {
    return s.last_command && s.last_command->progress && *s.last_command->progress > 0.1;
  });
  auto move = drive_->Move(MoveAbsolute{12, 200, 2000, 2000});
  ASSERT_TRUE(move.ok()) << move.status();
  const CommandInfo aborted = WaitFinal(run->id);
  EXPECT_EQ(aborted.state, CommandState::kAborted) << aborted.message;
  EXPECT_EQ(WaitFinal(move->id).state, CommandState::kDone);
  EXPECT_NEAR(drive_->GetStatus().position_mm, 12.0, 0.011);
}

TEST_F(LinMotUdpDriveCurvesTest, AnotherCurveUnderTheRunningId_Refused) {
  EnableOrDie();
  Curve slow = Stroke();
  std::get<PositionTimeCurve>(slow.shape).time_step_s = 0.5;  // 2 s under the scratch ID 100
  auto run = drive_->RunCurve(slow, CurveRunOptions{});
  ASSERT_TRUE(run.ok()) << run.status();
  auto other = drive_->RunCurve(Stroke(50), CurveRunOptions{});
  EXPECT_EQ(other.status().code(), absl::StatusCode::kFailedPrecondition) << other.status();
  EXPECT_THAT(other.status().message(), HasSubstr("curve 100 is running"));
  EXPECT_EQ(drive_->GetCommand(run->id)->state, CommandState::kActive);
}

TEST_F(LinMotUdpDriveCurvesTest, EndPointNotReached_ErrorNamingBothPositions) {
  EnableOrDie();
  // 10 -> 12 mm at 1 mm/s; the slider is blocked half way (lag < 1 mm: no lag error).
  const Curve creep{"creep", "", PositionTimeCurve{1.0, {10, 11, 12}}};
  auto run = drive_->RunCurve(creep, CurveRunOptions{});
  ASSERT_TRUE(run.ok()) << run.status();
  WaitUntil([](const DriveStatus& s) { return s.position_mm >= 11.3; });
  server_->SetMotorBlocked(true);
  const CommandInfo failed = test_support::WaitCommandFinal(*drive_, run->id, 20s);
  EXPECT_EQ(failed.state, CommandState::kError) << failed.message;
  EXPECT_THAT(failed.message, HasSubstr("curve ended at 11."));
  EXPECT_THAT(failed.message, HasSubstr("from its end point 12.0000 mm"));
}

TEST_F(LinMotUdpDriveCurvesTest, DriveFaultDuringACurve_ErrorWithTheCodeText) {
  EnableOrDie();
  Curve slow = Stroke();
  std::get<PositionTimeCurve>(slow.shape).time_step_s = 0.5;  // 2 s
  auto run = drive_->RunCurve(slow, CurveRunOptions{});
  ASSERT_TRUE(run.ok()) << run.status();
  WaitUntil([&](const DriveStatus& s) {
    return s.last_command && s.last_command->progress && *s.last_command->progress > 0.1;
  });
  ASSERT_TRUE(server_->RaiseError(mc::kPosLagAlwaysTooBig).ok());
  const CommandInfo failed = WaitFinal(run->id);
  EXPECT_EQ(failed.state, CommandState::kError);
  EXPECT_THAT(failed.message, HasSubstr("drive fault"));
  EXPECT_THAT(failed.message, HasSubstr("0x000B"));
}

// linudp 5.1.3 / A-09: every RTC command first answers "busy" for two telegrams.
class LinMotUdpDriveCurvesBusyTest : public LinMotUdpDriveCurvesTest {
 protected:
  SimOptions Options() override {
    SimOptions o;
    o.rtc_busy_telegrams = 2;
    return o;
  }
};

TEST_F(LinMotUdpDriveCurvesBusyTest, BusyReplies_AreWaitedOut) {
  const LinMotParametricCurve curve = Ramp(11);
  absl::Status s = drive_->DownloadCurve(curve);
  ASSERT_TRUE(s.ok()) << s;
  auto back = drive_->UploadCurve(11);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, curve);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
