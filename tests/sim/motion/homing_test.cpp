// Tests for sim/motion/homing: D-39 move-to-home, switch search, initial position, aborts.
#include "sim/motion/homing.h"

#include <cmath>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::motion {
namespace {

using ::testing::ElementsAre;

constexpr Limits kHomingLimits{100, 1000, 1000};
constexpr double kTick = 0.001;

// Runs until the homing settles (done/aborted) or `max_s`, recording each phase change.
std::vector<HomingPhase> RunHoming(Homing& homing, Axis& axis, double max_s = 20) {
  std::vector<HomingPhase> phases{homing.phase()};
  for (double t = 0; t < max_s; t += kTick) {
    homing.Advance(axis, kTick);
    if (homing.phase() != phases.back()) phases.push_back(homing.phase());
    if (homing.phase() == HomingPhase::kDone || homing.phase() == HomingPhase::kAborted) break;
  }
  return phases;
}

Homing MakeHoming(HomingConfig config) {
  auto homing = Homing::Create(std::move(config));
  EXPECT_TRUE(homing.ok()) << homing.status();
  return *std::move(homing);
}

TEST(HomingTest, Create_InvalidConfig_InvalidArgument) {
  EXPECT_EQ(Homing::Create({.limits = {0, 1, 1}}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Homing::Create({.limits = kHomingLimits, .direction = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Homing::Create({.limits = kHomingLimits, .timeout_s = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(HomingTest, Advance_MoveToFeature_PhasesAndReportedHome) {
  // D-39: VA move to the configured home target; the reference makes it read home_position.
  auto axis_or = Axis::Create({}, 37);
  ASSERT_TRUE(axis_or.ok());
  Axis axis = *std::move(axis_or);
  Homing homing =
      MakeHoming({.limits = kHomingLimits, .feature_position_mm = 2, .home_position_mm = 5});
  EXPECT_EQ(homing.phase(), HomingPhase::kIdle);
  ASSERT_TRUE(homing.Start(axis).ok());
  EXPECT_THAT(
      RunHoming(homing, axis),
      ElementsAre(HomingPhase::kSearching, HomingPhase::kSettingReference, HomingPhase::kDone));
  EXPECT_TRUE(homing.homed());
  EXPECT_TRUE(homing.status().ok());
  EXPECT_EQ(axis.reference_offset(), 3);
  EXPECT_NEAR(axis.demand().position, 5, 1e-12);
  axis.Advance(kTick);
  EXPECT_NEAR(axis.actual().position, 5, 1e-12);
  EXPECT_NEAR(axis.physical_position(), 2, 1e-12);
  EXPECT_TRUE(axis.in_target());
}

TEST(HomingTest, Advance_WithInitialPosition_GoesThereAfterReference) {
  Axis axis;
  Homing homing = MakeHoming({.limits = kHomingLimits,
                              .feature_position_mm = -20,
                              .home_position_mm = 0,
                              .initial_position_mm = 10.0,
                              .initial_limits = Limits{200, 2000, 2000}});
  ASSERT_TRUE(homing.Start(axis).ok());
  EXPECT_THAT(RunHoming(homing, axis),
              ElementsAre(HomingPhase::kSearching, HomingPhase::kSettingReference,
                          HomingPhase::kGoingToInitialPosition, HomingPhase::kDone));
  EXPECT_EQ(axis.demand().position, 10);
  EXPECT_NEAR(axis.physical_position(), -10, 0.2 + 1e-9);  // actual one tick behind
  axis.Advance(kTick);
  EXPECT_NEAR(axis.physical_position(), -10, 1e-9);
}

TEST(HomingTest, Advance_SwitchSearch_EdgeBecomesHomePosition) {
  auto axis_or = Axis::Create({}, 50);
  ASSERT_TRUE(axis_or.ok());
  Axis axis = *std::move(axis_or);
  Homing homing = MakeHoming({.method = HomingMethod::kSwitch,
                              .limits = kHomingLimits,
                              .feature_position_mm = -10,
                              .home_position_mm = 0,
                              .direction = -1});
  ASSERT_TRUE(homing.Start(axis).ok());
  EXPECT_THAT(
      RunHoming(homing, axis),
      ElementsAre(HomingPhase::kSearching, HomingPhase::kSettingReference, HomingPhase::kDone));
  // The edge at physical −10 reads 0; the axis stopped just beyond it (v²/2d plus ~2 ticks).
  EXPECT_EQ(axis.reference_offset(), 10);
  EXPECT_LT(axis.demand().position, 0);
  EXPECT_GT(axis.demand().position, -(100.0 * 100 / 2000 + 100 * 3 * kTick));
}

TEST(HomingTest, Advance_SwitchNotFound_AbortsNotFound) {
  Axis axis;
  Homing homing = MakeHoming({.method = HomingMethod::kSwitch,
                              .limits = kHomingLimits,
                              .feature_position_mm = 100,
                              .direction = 1,
                              .max_search_distance_mm = 20});
  ASSERT_TRUE(homing.Start(axis).ok());
  RunHoming(homing, axis);
  EXPECT_EQ(homing.phase(), HomingPhase::kAborted);
  EXPECT_EQ(homing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_FALSE(homing.homed());
  EXPECT_EQ(axis.reference_offset(), 0);
  for (int i = 0; i < 1000; ++i) axis.Advance(kTick);
  EXPECT_FALSE(axis.motion_active());  // stopped
}

TEST(HomingTest, Advance_Timeout_AbortsDeadlineExceeded) {
  Axis axis;
  Homing homing =
      MakeHoming({.limits = kHomingLimits, .feature_position_mm = 1000, .timeout_s = 0.5});
  ASSERT_TRUE(homing.Start(axis).ok());
  RunHoming(homing, axis);
  EXPECT_EQ(homing.phase(), HomingPhase::kAborted);
  EXPECT_EQ(homing.status().code(), absl::StatusCode::kDeadlineExceeded);
}

TEST(HomingTest, Abort_WhileSearching_StopsAndNotHomed) {
  // linmot-mc.md D-06: releasing the bit stops with the quick-stop deceleration, Homed = 0.
  Axis axis;
  Homing homing = MakeHoming({.limits = kHomingLimits, .feature_position_mm = 100});
  ASSERT_TRUE(homing.Start(axis).ok());
  for (int i = 0; i < 300; ++i) homing.Advance(axis, kTick);
  homing.Abort(axis, 10000);
  EXPECT_EQ(homing.phase(), HomingPhase::kAborted);
  EXPECT_EQ(homing.status().code(), absl::StatusCode::kCancelled);
  for (int i = 0; i < 100; ++i) homing.Advance(axis, kTick);
  EXPECT_FALSE(axis.motion_active());
  EXPECT_LT(axis.demand().position, 100);
  EXPECT_FALSE(homing.homed());
}

}  // namespace
}  // namespace drivegw::sim::motion
