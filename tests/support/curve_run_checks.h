// Test support for RunCurve (decision 013): the smooth stroke every family's curve test runs, the
// progress values the status stream showed for a run, and the checks on them — one copy for the
// LinMot DeviceNet, STOBER and Trinamic curve tests.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include "adapters/core/curve.h"
#include "adapters/core/drive.h"
#include "gtest/gtest.h"

namespace drivegw::test_support {

// p = from + (to − from)(1 − cos(πt/T))/2 sampled every 10 ms: starts and ends at rest. With
// `whole_units` every point is rounded (families whose wire unit is one position unit).
inline Curve CosineStroke(double from, double to, double duration_s, bool whole_units = false) {
  PositionTimeCurve pt;
  pt.time_step_s = 0.01;
  const int n = static_cast<int>(std::lround(duration_s / pt.time_step_s));
  for (int i = 0; i <= n; ++i) {
    const double x = static_cast<double>(i) / n;
    const double p = from + (to - from) * (1 - std::cos(std::numbers::pi * x)) / 2;
    pt.positions_mm.push_back(whole_units ? std::round(p) : p);
  }
  Curve c;
  c.name = "stroke";
  c.shape = pt;
  return c;
}

struct ProgressTrace {
  std::vector<double> progress;  // every progress value of the command, in publishing order
  bool moving = false;           // the drive showed MOVING while the command ran
};

// Follows the status stream until command `id` is final and the stream showed that (or a newer
// command took its place), or `timeout` passes.
inline ProgressTrace WatchProgress(const Drive& drive, uint64_t id,
                                   std::chrono::steady_clock::duration timeout) {
  ProgressTrace trace;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  DriveStatus s = drive.GetStatus();
  while (std::chrono::steady_clock::now() < deadline) {
    const bool mine = s.last_command && s.last_command->id == id;
    if (mine && s.last_command->progress) trace.progress.push_back(*s.last_command->progress);
    if (mine && !IsFinal(s.last_command->state) && s.state == DriveState::kMoving) {
      trace.moving = true;
    }
    if (IsFinal(drive.GetCommand(id)->state) && (!mine || IsFinal(s.last_command->state))) break;
    s = drive.WaitForStatus(s.sequence, deadline);
  }
  return trace;
}

// Progress never falls, ends at 1, and some snapshots showed the run under way.
inline void ExpectProgressRisesToOne(const std::vector<double>& progress) {
  ASSERT_GE(progress.size(), 3u);
  for (size_t i = 1; i < progress.size(); ++i) {
    EXPECT_GE(progress[i], progress[i - 1]) << "snapshot " << i;
  }
  EXPECT_DOUBLE_EQ(progress.back(), 1.0);
  EXPECT_TRUE(
      std::any_of(progress.begin(), progress.end(), [](double p) { return p > 0.05 && p < 0.95; }));
}

}  // namespace drivegw::test_support
