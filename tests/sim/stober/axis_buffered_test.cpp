// Buffered (subsequent) motion blocks and End velocity (stober-motion.md §2.5 L228-245, §2.7
// L292, §3.2 Target L364-373; G-08, G-09; decisions 1161-1163), AXIS target, fixture F-LIN,
// 1 ms cycles. Command Mode I409: 0 aborting, 1 "start at the end of the running block".
#include <algorithm>
#include <cmath>

#include "axis_fixture.h"
#include "gtest/gtest.h"

namespace drivegw::sim::stober {
namespace {

using testing::TestAxis;

// Largest |Δa|/Δt between consecutive 1 ms cycles (§2.4 L300: never an acceleration step).
struct JerkWatch {
  explicit JerkWatch(TestAxis& axis) : axis(axis), previous(axis.core().set_acceleration()) {}
  void Sample() {
    const double a = axis.core().set_acceleration();
    max_jerk = std::max(max_jerk, std::abs(a - previous) / 0.001);
    previous = a;
  }
  TestAxis& axis;
  double previous;
  double max_jerk = 0;
};

// What the status shows cycle by cycle from the current cycle until Done (or max cycles).
struct Trace {
  bool done_early = false;       // I92 = 1 before `done_from`
  bool error = false;            // I91 = 1 at any time
  bool stopped_between = false;  // E07 = 0 while between the two targets
  double velocity_at_first = 0;  // |E07| in the cycle that crossed the first target
  double max_position = -1e9;
  int cycles = -1;
};

// Runs until I92 = 1; `first` is the first block's target (crossed upwards), `second` the end.
Trace RunChain(TestAxis& axis, double first, double second, JerkWatch* watch = nullptr) {
  Trace tr;
  double previous = axis.R("I96");
  tr.cycles = axis.RunUntil([&] {
    if (watch != nullptr) watch->Sample();
    const double x = axis.R("I96");
    const double v = axis.R("E07");
    if (previous < first && x >= first) tr.velocity_at_first = std::abs(v);
    if (x > first + 1e-6 && x < second - 1e-6 && v == 0) tr.stopped_between = true;
    tr.max_position = std::max(tr.max_position, x);
    tr.error = tr.error || axis.B("I91");
    previous = x;
    const bool done = axis.B("I92");
    if (done && std::abs(x - second) > 1e-6) tr.done_early = true;
    return done && std::abs(x - second) <= 1e-6;
  });
  return tr;
}

// BUF-01 — §2.5 L236-244, §2.7 L292: a MoveAbsolute buffered (I409 = 1) behind a running
// MoveAbsolute starts at the end of the running block (at rest on its target: End velocity 0,
// L368), ends at its own target, and Done is reported only at the end of the subsequent block.
// I83 (G-08) shows 2 while the successor waits; the active motion ID I82 switches at takeover.
TEST(StoberAxisBuffered, BUF01_BufferedMoveAbsoluteStartsAtTheEndDoneOnlyAtTheEnd) {
  TestAxis axis;
  axis.W("I400", 1);
  axis.MoveAbsolute(300);
  axis.Advance(50);
  ASSERT_EQ(axis.R("I83"), 1);
  axis.W("I409", 1);
  axis.W("I400", 2);
  axis.W("I404", 800);
  axis.MoveAbsolute(600);
  // The edge is a command start: I92 = I91 = 0 in it (§2.7), the first block keeps moving.
  EXPECT_EQ(axis.R("I92"), 0);
  EXPECT_EQ(axis.R("I83"), 2);
  EXPECT_EQ(axis.R("I82"), 1);
  EXPECT_EQ(axis.R("I89"), 3);
  // The next command's values written meanwhile do not change the buffered block (§2.2 L183).
  axis.W("I403", 5000);
  axis.W("I400", 3);
  // Until the takeover: at rest on 300 for the takeover cycle at most, then towards 600.
  bool was_2_at_300 = false;
  ASSERT_GT(axis.RunUntil([&] {
    if (axis.R("I83") == 2) was_2_at_300 = axis.R("I96") == 300 || was_2_at_300;
    EXPECT_EQ(axis.R("I92"), 0) << "Done before the end of the subsequent block";
    return axis.R("I83") != 2;
  }),
            0);
  EXPECT_FALSE(was_2_at_300) << "the successor starts at the end of the block, not later";
  EXPECT_NEAR(axis.R("I96"), 300, 1);  // handed over at the first target
  EXPECT_EQ(axis.R("I82"), 2);
  EXPECT_EQ(axis.R("I83"), 1);
  const Trace tr = RunChain(axis, 300, 600);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_FALSE(tr.done_early);
  EXPECT_FALSE(tr.error);
  EXPECT_EQ(axis.R("I80"), 600);
  EXPECT_EQ(axis.R("I89"), 2);
  EXPECT_EQ(axis.R("I83"), 0);
}

// BUF-02 — §2.4 L283-332: Command Mode 0 (the default, decision 1162) still aborts: the second
// MoveAbsolute takes over at once from motion and the axis never stops at the first target.
TEST(StoberAxisBuffered, BUF02_AbortingModeStillAborts) {
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(50);
  axis.W("I409", 0);
  axis.MoveAbsolute(600);
  EXPECT_EQ(axis.R("I83"), 1);
  const Trace tr = RunChain(axis, 300, 600);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_GT(tr.velocity_at_first, 100);  // crossed 300 at speed: it was retargeted at once
  EXPECT_EQ(axis.R("I80"), 600);
}

// BUF-03 — §3.2 Target L364-373 (L368): End velocity ≠ 0 passes the set position at that
// velocity; with a buffered successor the motion continues into it without stopping and without
// an acceleration step (L300), and Done comes only at the end of the successor (L390).
TEST(StoberAxisBuffered, BUF03_EndVelocityPassesIntoTheBufferedBlock) {
  TestAxis axis;
  axis.W("I429", 200);
  axis.MoveAbsolute(300);
  axis.Advance(20);
  axis.W("I429", 0);
  axis.W("I409", 1);
  axis.MoveAbsolute(600);
  JerkWatch watch(axis);
  const Trace tr = RunChain(axis, 300, 600, &watch);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_NEAR(tr.velocity_at_first, 200, 10);  // passed at the End velocity (1 ms sampling)
  EXPECT_FALSE(tr.stopped_between);
  EXPECT_FALSE(tr.done_early);
  EXPECT_LE(watch.max_jerk, 50000 * (1 + 1e-6));  // I407 of both blocks
  EXPECT_EQ(axis.R("I80"), 600);
}

// BUF-04 — G-09, decision 1161: End velocity ≠ 0 without a subsequent block: the target is
// passed at the End velocity, then the block brakes with its deceleration and jerk and returns
// to the target; Done there as for End velocity 0.
TEST(StoberAxisBuffered, BUF04_EndVelocityWithoutSuccessorReturnsToTheTarget) {
  TestAxis axis;
  axis.W("I429", 300);
  axis.MoveAbsolute(300);
  const Trace tr = RunChain(axis, 300, 300);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_NEAR(tr.velocity_at_first, 300, 15);
  EXPECT_GT(tr.max_position, 300 + 1);  // overshoot: 300²/(2·5000) = 9 u plus the jerk ramp
  EXPECT_EQ(axis.R("I80"), 300);
  EXPECT_EQ(axis.R("I89"), 2);
}

// BUF-05 — decision 1162: with nothing running, a buffered start starts at once.
TEST(StoberAxisBuffered, BUF05_BufferedStartAtStandstillStartsAtOnce) {
  TestAxis axis;
  axis.W("I409", 1);
  axis.MoveAbsolute(100);
  EXPECT_EQ(axis.R("I83"), 1);
  EXPECT_GT(axis.R("E07"), 0);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 100);
}

// BUF-06 — decision 1162: an aborting start cancels the running and the buffered block.
TEST(StoberAxisBuffered, BUF06_AbortingStartDropsTheBufferedBlock) {
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(50);
  axis.W("I409", 1);
  axis.MoveAbsolute(600);
  ASSERT_EQ(axis.R("I83"), 2);
  axis.W("I409", 0);
  axis.MoveAbsolute(100);
  EXPECT_EQ(axis.R("I83"), 1);
  double max_position = 0;
  ASSERT_GT(axis.RunUntil([&] {
    max_position = std::max(max_position, axis.R("I80"));
    return axis.B("I92");
  }),
            0);
  EXPECT_EQ(axis.R("I80"), 100);
  EXPECT_LT(max_position, 300);
}

// BUF-07 — decision 1162 (one-deep buffer): a second buffered start replaces the first.
TEST(StoberAxisBuffered, BUF07_SecondBufferedStartReplacesTheFirst) {
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(50);
  axis.W("I409", 1);
  axis.MoveAbsolute(600);
  axis.MoveAbsolute(700);
  EXPECT_EQ(axis.R("I83"), 2);
  const Trace tr = RunChain(axis, 300, 700);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_FALSE(tr.done_early);
  EXPECT_EQ(axis.R("I80"), 700);
}

// BUF-08 — §3.4.6 L741: a buffered MoveAdditive adds to the last valid set position, the first
// block's target; a buffered MoveRelative to the actual position at its start (L413), which is
// the end of the first block.
TEST(StoberAxisBuffered, BUF08_BufferedAdditiveAndRelativeStartFromTheFirstTarget) {
  {
    TestAxis axis;
    axis.MoveAbsolute(300);
    axis.Advance(30);
    axis.W("I409", 1);
    axis.W("I403", 100);
    axis.Start(Command::kMoveAdditive);
    ASSERT_GT(RunChain(axis, 300, 400).cycles, 0);
    EXPECT_EQ(axis.R("I80"), 400);
  }
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(30);
  axis.W("I409", 1);
  axis.W("I403", 50);
  axis.Start(Command::kMoveRelative);
  ASSERT_GT(RunChain(axis, 300, 350).cycles, 0);
  EXPECT_EQ(axis.R("I80"), 350);
}

// BUF-09 — §2.8 L386-388, decision 1162: a buffered block is checked when it starts; denied
// there (target outside I50..I51) it reports I91 = 1 / I89 = 7 with its cause — not before.
TEST(StoberAxisBuffered, BUF09_BufferedBlockDeniedAtItsStart) {
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(30);
  axis.W("I409", 1);
  axis.MoveAbsolute(20000);  // beyond I50 = 10000
  axis.Advance();
  EXPECT_EQ(axis.R("I91"), 0);
  EXPECT_EQ(axis.R("I83"), 2);
  ASSERT_GT(axis.RunUntil([&] { return axis.B("I91"); }), 0);
  EXPECT_EQ(axis.R("I90"), static_cast<int>(Cause::kSoftwareLimit));
  EXPECT_EQ(axis.R("I89"), 7);
  EXPECT_EQ(axis.R("I80"), 300);  // the first block had ended at rest on its target
  EXPECT_EQ(axis.R("I83"), 0);
}

// BUF-10 — §2.5 L240 (buffering per command 1-5, 8, 11): a buffered MC_Halt behind a
// MoveVelocity waits for the set velocity, then brakes; Done at standstill only.
TEST(StoberAxisBuffered, BUF10_BufferedHaltAfterMoveVelocityWaitsForTheVelocity) {
  TestAxis axis;
  axis.W("I404", 400);
  axis.Start(Command::kMoveVelocity);
  axis.Advance(10);
  axis.W("I409", 1);
  axis.Start(Command::kHalt);
  ASSERT_EQ(axis.R("I83"), 2);
  // Not braking before the MoveVelocity ramp has reached 400.
  double peak = 0;
  ASSERT_GT(axis.RunUntil([&] {
    peak = std::max(peak, axis.R("E07"));
    EXPECT_EQ(axis.R("I92"), 0);
    return axis.R("I83") != 2;
  }),
            0);
  EXPECT_NEAR(peak, 400, 0.5);  // handed over inside the cycle the ramp ended in
  axis.ExecuteLow();
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("E07"), 0);
  EXPECT_EQ(axis.R("I89"), 2);
}

// BUF-11 — G-18, decisions 1146/1162: enable-off drops the buffered block with the running one.
TEST(StoberAxisBuffered, BUF11_EnableOffDropsTheBufferedBlock) {
  TestAxis axis;
  axis.MoveAbsolute(300);
  axis.Advance(30);
  axis.W("I409", 1);
  axis.MoveAbsolute(600);
  ASSERT_EQ(axis.R("I83"), 2);
  axis.W("A515", 0x06);  // shutdown: Operation enabled → Ready to switch on
  axis.Advance(5);
  EXPECT_EQ(axis.R("I83"), 0);
  EXPECT_EQ(axis.R("I89"), 0);
  axis.Advance(2000);
  EXPECT_LT(axis.R("I80"), 300);
}

// BUF-12 — §3.3/§3.4 inputs (End velocity for 2 and 3, L460, L650): a MoveRelative passes its
// target at I429 into a buffered MoveAdditive, whose base is the MoveRelative's set position
// (L741).
TEST(StoberAxisBuffered, BUF12_RelativePassesIntoBufferedAdditive) {
  TestAxis axis;
  axis.W("I403", 200);
  axis.W("I429", 100);
  axis.Start(Command::kMoveRelative);
  axis.Advance(20);
  axis.W("I429", 0);
  axis.W("I409", 1);
  axis.W("I403", 100);
  axis.Start(Command::kMoveAdditive);
  const Trace tr = RunChain(axis, 200, 300);
  ASSERT_GT(tr.cycles, 0);
  EXPECT_NEAR(tr.velocity_at_first, 100, 10);
  EXPECT_FALSE(tr.stopped_between);
  EXPECT_EQ(axis.R("I80"), 300);
}

// BUF-13 — decisions 1161/1162: a subsequent block buffered after the pass (while the block
// without successor brakes and returns) starts at the end of that return, from rest on the
// target.
TEST(StoberAxisBuffered, BUF13_SuccessorBufferedDuringTheReturnStartsAfterIt) {
  TestAxis axis;
  axis.W("I429", 300);
  axis.MoveAbsolute(300);
  ASSERT_GT(axis.RunUntil([&] { return axis.R("I96") > 300; }), 0);  // passed, now braking
  axis.W("I429", 0);
  axis.W("I409", 1);
  axis.MoveAbsolute(500);
  ASSERT_EQ(axis.R("I83"), 2);
  // It returns to 300 first (the block's end), then heads for 500.
  double min_after_pass = 1e9;
  ASSERT_GT(axis.RunUntil([&] {
    min_after_pass = std::min(min_after_pass, axis.R("I96"));
    return axis.R("I83") != 2;
  }),
            0);
  EXPECT_NEAR(min_after_pass, 300, 1e-6);
  ASSERT_GT(axis.RunUntilDone(), 0);
  EXPECT_EQ(axis.R("I80"), 500);
}

}  // namespace
}  // namespace drivegw::sim::stober
