// The motion-command checks every family shares (adapters/core/motion_limits.h): the codes and
// the exact texts the LinUDP, DeviceNet and Trinamic drives answered with before the checks
// moved to core, including LinUDP's D-42 note, and the order velocity, acceleration, deceleration.
#include "adapters/core/motion_limits.h"

#include <gtest/gtest.h>

#include <limits>

namespace drivegw {
namespace {

AxisConfig Axis() {
  AxisConfig a;
  a.min_mm = -10;
  a.max_mm = 100;
  a.max_velocity_mm_s = 500;
  a.max_acceleration_mm_s2 = 2000;
  return a;
}

TEST(MotionLimitsTest, ProfileLimitZeroOrNotFinite_InvalidArgumentMustBePositive) {
  const absl::Status zero = CheckProfileLimit("move_absolute.velocity_mm_s", 0, 500, "axis.v");
  EXPECT_EQ(zero.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(zero.message(), "move_absolute.velocity_mm_s: 0 must be positive");
  const absl::Status nan = CheckProfileLimit("f", std::numeric_limits<double>::quiet_NaN(), 500,
                                             "axis.v", " (linmot-mc.md D-42)");
  EXPECT_EQ(nan.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(nan.message(), "f: nan must be positive (linmot-mc.md D-42)");
}

TEST(MotionLimitsTest, ProfileLimitAboveAxis_OutOfRangeNamingTheAxisField) {
  const absl::Status s = CheckProfileLimit("stop.deceleration_mm_s2", 2500.5, 2000,
                                           "axis.max_acceleration_mm_s2", " (note)");
  EXPECT_EQ(s.code(), absl::StatusCode::kOutOfRange);
  // The note belongs to the "must be positive" text only.
  EXPECT_EQ(s.message(),
            "stop.deceleration_mm_s2: 2500.5 exceeds axis limit 2000 "
            "(axis.max_acceleration_mm_s2)");
  EXPECT_TRUE(CheckProfileLimit("f", 2000, 2000, "axis.a").ok());
}

TEST(MotionLimitsTest, MoveProfile_ChecksVelocityThenAccelerationThenDeceleration) {
  const AxisConfig axis = Axis();
  EXPECT_TRUE(CheckMoveProfile("move_absolute", 500, 2000, 1, axis).ok());
  EXPECT_EQ(CheckMoveProfile("move_absolute", 0, 0, 0, axis).message(),
            "move_absolute.velocity_mm_s: 0 must be positive");
  EXPECT_EQ(CheckMoveProfile("move_relative", 10, 3000, 0, axis).message(),
            "move_relative.acceleration_mm_s2: 3000 exceeds axis limit 2000 "
            "(axis.max_acceleration_mm_s2)");
  EXPECT_EQ(CheckMoveProfile("move_velocity", 10, 100, -1, axis, " (linmot-mc.md D-42)").message(),
            "move_velocity.deceleration_mm_s2: -1 must be positive (linmot-mc.md D-42)");
  EXPECT_EQ(CheckMoveProfile("move_velocity", 600, 100, 100, axis).message(),
            "move_velocity.velocity_mm_s: 600 exceeds axis limit 500 (axis.max_velocity_mm_s)");
}

TEST(MotionLimitsTest, AxisPosition_AbsoluteAndRelativeTexts) {
  const AxisConfig axis = Axis();
  EXPECT_TRUE(CheckAxisPosition("move_absolute.position_mm", 100, 100, axis).ok());
  const absl::Status absolute = CheckAxisPosition("move_absolute.position_mm", 101, 101, axis);
  EXPECT_EQ(absolute.code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(absolute.message(),
            "move_absolute.position_mm: 101 is outside the axis range [-10, 100]");
  const absl::Status relative = CheckAxisPosition("move_relative.distance_mm", -20, -15, axis);
  EXPECT_EQ(relative.code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(relative.message(),
            "move_relative.distance_mm: -20 takes the axis to -15, outside the axis range "
            "[-10, 100]");
  const absl::Status inf =
      CheckAxisPosition("move_relative.distance_mm", std::numeric_limits<double>::infinity(),
                        std::numeric_limits<double>::infinity(), axis);
  EXPECT_EQ(inf.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(inf.message(), "move_relative.distance_mm: inf is not a finite number");
}

}  // namespace
}  // namespace drivegw
