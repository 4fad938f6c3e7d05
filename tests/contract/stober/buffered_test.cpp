// Buffered motion blocks and End velocity through the gateway (stober-motion.md §2.5 L228-245,
// §2.7 L292, §3.2 Target L364-373; decisions 1161-1163, 1209, 1210): StoberDrive against the
// simulated axis on the UDP multicast CAN bus, the wire checked by the sniffer (wire.h).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "tests/contract/stober/wire.h"

namespace drivegw::stober::wire {
namespace {

using ::testing::AnyOf;
using ::testing::HasSubstr;

// MoveAbsolute at moderate dynamics: 0 → 100 mm takes about 0.6 s.
StoberMcRequest MoveAbs(double position, uint8_t mode = 0, double end_velocity = 0) {
  StoberMcRequest r;
  r.command = 1;
  r.position_mm = position;
  r.velocity_mm_s = 200;
  r.acceleration_mm_s2 = 2000;
  r.deceleration_mm_s2 = 2000;
  r.jerk_mm_s3 = 20000;
  r.command_mode = mode;
  r.end_velocity_mm_s = end_velocity;
  return r;
}

class BufferedTest : public WireTest {
 protected:
  void SetUp() override {
    before_drive_ = [](ss::AxisServer& s) {
      s.WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
    };
    Start();
  }
  // TPDO2 samples {position, velocity} from sniffer index `from` on.
  std::vector<std::vector<double>> Actuals(size_t from) {
    std::vector<std::vector<double>> out;
    for (const Seen& s : sniffer_->With(kTpdo2, from)) out.push_back(DecodeTpdo2(s.frame));
    return out;
  }
};

// §2.5 L236-244 (Done only at the end of the subsequent block), decisions 1162/1210: a
// MoveAbsolute with I409 = 1 behind a running MoveAbsolute is BUSY while queued (I83 = 2), the
// first handle ends DONE at the take-over (near its target, where it stopped: End velocity 0),
// the second DONE at its own target; on the wire I92 = 1 comes only after the take-over.
TEST_F(BufferedTest, BufferedMoveAbsoluteEndsAtSecondTargetDoneOnlyAtTheEnd) {
  const uint64_t first = Native(MoveAbs(100));
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const size_t mark = sniffer_->size();
  const uint64_t second = Native(MoveAbs(150, 1));
  // I409 = 1 went out by SDO before the edge (decision 1209).
  EXPECT_EQ(Sim("I409"), 1);
  EXPECT_EQ(drive_->GetCommand(second)->state, CommandState::kBusy);
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kActive);
  EXPECT_EQ(Sim("I83"), 2);
  // First DONE at the take-over, near 100 (the status that ended it is published first).
  WaitUntil([&](const DriveStatus&) { return IsFinal(drive_->GetCommand(first)->state); });
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kDone)
      << drive_->GetCommand(first)->message;
  EXPECT_NEAR(drive_->GetStatus().position_mm, 100, 3);
  EXPECT_EQ(drive_->GetCommand(second)->state, CommandState::kActive);
  const CommandInfo end = WaitFinal(second);
  EXPECT_EQ(end.state, CommandState::kDone) << end.message;
  EXPECT_EQ(Sim("I80"), 150);
  AtRest(150);
  // The wire: after the buffered edge I83 = 2, then the take-over (I83 back to 1), and only then
  // the first I92 = 1.
  // The sniffer's socket may lag the drive's (wire.h): wait for the I92 = 1 to be recorded.
  const std::vector<Seen> all = sniffer_->Until(
      [&](const std::vector<Seen>& f) {
        return Sniffer::Any(f, mark, kTpdo1,
                            [](const transport::CanFrame& x) { return DecodeTpdo1(x).done(); });
      },
      "I92 = 1 of the subsequent block");
  bool queued = false;
  bool taken_over = false;
  bool done = false;
  for (size_t i = mark; i < all.size() && !done; ++i) {
    if (all[i].frame.id != kTpdo1) continue;
    const Tpdo1 t = DecodeTpdo1(all[i].frame);
    const int i83 = static_cast<int>((t.flags & status_bit::kCommandStateMask) >>
                                     status_bit::kCommandStateShift);
    queued |= i83 == 2;
    taken_over |= queued && i83 != 2;
    if (t.done()) {
      done = true;
      EXPECT_TRUE(taken_over) << "I92 = 1 before the subsequent block took over"
                              << Trace(all, mark);
    }
  }
  EXPECT_TRUE(queued) << "I83 = 2 never on the bus" << Trace(all, mark);
  EXPECT_TRUE(done);
}

// §3.2 Target L368: End velocity ≠ 0 passes the set position at that velocity; with the
// subsequent block buffered the axis does not stop at the first target (decision 1161).
TEST_F(BufferedTest, EndVelocityPassesTheFirstTargetWithoutStopping) {
  const uint64_t first = Native(MoveAbs(100, 0, 80));
  EXPECT_EQ(Sim("I429"), 80);  // written by SDO before the edge (decision 1209)
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const size_t mark = sniffer_->size();
  const uint64_t second = Native(MoveAbs(150, 1));
  EXPECT_EQ(Sim("I429"), 0);
  const CommandInfo end = WaitFinal(second);
  EXPECT_EQ(end.state, CommandState::kDone) << end.message;
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kDone);
  AtRest(150);
  // Every actual-value sample between 90 and 140 mm moved at ≥ 40 mm/s: never stopped at 100.
  EXPECT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    return Sniffer::Any(f, mark, kTpdo2, [](const transport::CanFrame& x) {
      return DecodeTpdo2(x).at(0) >= 150 - 1e-6;
    });
  })) << "the end position never on the bus";
  int near_pass = 0;
  for (const std::vector<double>& a : Actuals(mark)) {
    ASSERT_EQ(a.size(), 2u);
    if (a[0] > 90 && a[0] < 140) {
      EXPECT_GT(a[1], 40) << "at " << a[0] << " mm";
      if (a[0] > 97 && a[0] < 103) ++near_pass;
    }
  }
  EXPECT_GT(near_pass, 0) << "no TPDO2 sample near the pass";
}

// Decision 1161 (G-09): End velocity ≠ 0 without a subsequent block: the target is passed, the
// axis brakes and returns to it; the handle is DONE there.
TEST_F(BufferedTest, EndVelocityWithoutSuccessorReturnsToTheTarget) {
  const size_t mark = sniffer_->size();
  const CommandInfo end = WaitFinal(Native(MoveAbs(100, 0, 150)));
  EXPECT_EQ(end.state, CommandState::kDone) << end.message;
  AtRest(100);
  sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    return Sniffer::Any(f, mark, kTpdo2,
                        [](const transport::CanFrame& x) { return DecodeTpdo2(x).at(0) > 101; });
  });
  double max_position = 0;
  for (const std::vector<double>& a : Actuals(mark)) max_position = std::max(max_position, a[0]);
  EXPECT_GT(max_position, 101);  // 150²/(2·2000) ≈ 5.6 mm of braking beyond the target
}

// §2.4 L283-332, decision 1162: Command Mode 0 still aborts — the first handle ABORTED at once,
// the axis retargeted from motion (it never stops at the first target).
TEST_F(BufferedTest, AbortingModeStillAborts) {
  const uint64_t first = Native(MoveAbs(100, 1));  // buffered with nothing running: starts at once
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const size_t mark = sniffer_->size();
  const uint64_t second = Native(MoveAbs(150, 0));
  EXPECT_EQ(Sim("I409"), 0);
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kAborted);
  const CommandInfo end = WaitFinal(second);
  EXPECT_EQ(end.state, CommandState::kDone) << end.message;
  AtRest(150);
  sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    return Sniffer::Any(f, mark, kTpdo2, [](const transport::CanFrame& x) {
      return DecodeTpdo2(x).at(0) >= 150 - 1e-6;
    });
  });
  for (const std::vector<double>& a : Actuals(mark)) {
    if (a[0] > 95 && a[0] < 105) {
      EXPECT_GT(a[1], 100) << "slowed down at the first target";
    }
  }
}

// Decision 1210: an aborting command while a block is buffered supersedes both handles.
TEST_F(BufferedTest, AbortingStartSupersedesRunningAndBufferedHandles) {
  const uint64_t first = Native(MoveAbs(100));
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const uint64_t second = Native(MoveAbs(150, 1));
  ASSERT_EQ(drive_->GetCommand(second)->state, CommandState::kBusy);
  const CommandInfo third = Move(MoveAbsolute{-50, 500, 5000, 5000});
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kAborted);
  EXPECT_EQ(drive_->GetCommand(second)->state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(third.id).state, CommandState::kDone);
  AtRest(-50);
  EXPECT_EQ(Sim("I409"), 0);  // the unified Move is aborting (decision 1209)
}

// Decisions 1162, 1210: a buffered block denied at its take-over (target beyond I50, §2.8
// L386-388): the take-over cycle shows I83 ≠ 2 with I91 still 0 (§2.7: 0 for ≥ one cycle at a
// start), so the first handle is DONE — its block ended at its target — and the second ERROR.
TEST_F(BufferedTest, BufferedBlockDeniedAtTakeOverFirstDoneSecondError) {
  const uint64_t first = Native(MoveAbs(100));
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const uint64_t second = Native(MoveAbs(20000, 1));  // I50 = 10000 (F-LIN)
  ASSERT_EQ(drive_->GetCommand(second)->state, CommandState::kBusy);
  const CommandInfo end = WaitFinal(second);
  EXPECT_EQ(end.state, CommandState::kError);
  EXPECT_THAT(end.message, HasSubstr("software limits"));
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kDone);
  EXPECT_EQ(Sim("I80"), 100);  // the first block had ended at rest on its target
}

// L1059, sim decision 1160, decision 1210: behind an active MC_Stop the node denies every start,
// buffered or not: the Stop handle is ABORTED (its Done is never reported), the new one ERROR.
TEST_F(BufferedTest, BufferedStartBehindAnActiveStopIsDenied) {
  Native(MoveAbs(150));
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 40; });
  const CommandInfo stop = Move(StopMotion{400});  // 200 mm/s at 400 mm/s²: 0.5 s of braking
  const uint64_t next = Native(MoveAbs(150, 1));
  EXPECT_EQ(drive_->GetCommand(stop.id)->state, CommandState::kAborted);
  const CommandInfo end = WaitFinal(next);
  EXPECT_EQ(end.state, CommandState::kError);
  EXPECT_THAT(end.message, HasSubstr("MC_Stop"));
}

// Decision 1210: Disable ends the running and the buffered handle ABORTED.
TEST_F(BufferedTest, DisableWhileBufferedAbortsBothHandles) {
  const uint64_t first = Native(MoveAbs(100));
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  const uint64_t second = Native(MoveAbs(150, 1));
  ASSERT_EQ(drive_->GetCommand(second)->state, CommandState::kBusy);
  auto off = drive_->Disable();
  ASSERT_TRUE(off.ok()) << off.status();
  EXPECT_EQ(drive_->GetCommand(first)->state, CommandState::kAborted);
  EXPECT_EQ(drive_->GetCommand(second)->state, CommandState::kAborted);
  EXPECT_EQ(Sim("I83"), 0);
}

// Decisions 1161, 1162, 1209: refused locally naming the field and the limit, before any frame.
TEST_F(BufferedTest, InvalidCommandModeOrEndVelocityRefusedBeforeAnyFrame) {
  const size_t mark = SyncedMark();
  StoberMcRequest mode = MoveAbs(10, 2);
  auto r = drive_->SendNative(mode);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("command_mode: 2 outside I409 0..1"));
  StoberMcRequest home;
  home.command = 6;
  home.command_mode = 1;
  r = drive_->SendNative(home);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("applies to commands 1-5, 8, 11"));
  r = drive_->SendNative(MoveAbs(10, 0, -5));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("end_velocity_mm_s: -5 must be >= 0"));
  r = drive_->SendNative(MoveAbs(10, 0, 5e6));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(r.status().message(), HasSubstr("I429"));
  StoberMcRequest velocity;
  velocity.command = 4;
  velocity.end_velocity_mm_s = 10;
  r = drive_->SendNative(velocity);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("end_velocity_mm_s: applies to"));
  const size_t after = SyncedMark();
  for (size_t i = mark; i + 1 < after; ++i) {
    EXPECT_FALSE(ToNode(sniffer_->frames()[i].frame)) << "a refused command touched the drive";
  }
}

}  // namespace
}  // namespace drivegw::stober::wire
