// Server-side validation of the motion and native requests that had no test of their own
// (docs/reliability.md, bad-input inventory, gaps 5 and 6): every refusal names the request field,
// the value and the limit, with InvalidArgument for never-valid values and OutOfRange beyond the
// configured axis; defaults are applied as the header says.
#include "server/core/validation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <variant>

namespace drivegw::server {
namespace {

using ::testing::HasSubstr;

// Axis of 0..200 mm, 500 mm/s, 5000 mm/s².
AxisConfig Axis() {
  AxisConfig axis;
  axis.min_mm = 0;
  axis.max_mm = 200;
  axis.max_velocity_mm_s = 500;
  axis.max_acceleration_mm_s2 = 5000;
  return axis;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

v1::MoveRelativeRequest Relative(double distance, double v = 100, double a = 1000, double d = 0) {
  v1::MoveRelativeRequest r;
  r.set_name("drives/x1");
  r.set_distance_mm(distance);
  r.set_velocity_mm_s(v);
  r.set_acceleration_mm_s2(a);
  r.set_deceleration_mm_s2(d);
  return r;
}

void ExpectRefused(const absl::Status& s, absl::StatusCode code, const std::string& text) {
  EXPECT_EQ(s.code(), code) << s;
  EXPECT_THAT(s.message(), HasSubstr(text));
}

TEST(ValidateMoveRelative, TargetFromTheDemandPositionMustStayOnTheAxis) {
  // 150 + 40 = 190: inside; the deceleration defaults to the acceleration.
  auto ok = ValidateMoveRelative(Relative(40), Axis(), 150);
  ASSERT_TRUE(ok.ok()) << ok.status();
  const auto& move = std::get<MoveRelative>(*ok);
  EXPECT_DOUBLE_EQ(move.distance_mm, 40);
  EXPECT_DOUBLE_EQ(move.deceleration_mm_s2, 1000);

  ExpectRefused(ValidateMoveRelative(Relative(60), Axis(), 150).status(),
                absl::StatusCode::kOutOfRange,
                "move_relative.distance_mm: 60 from 150 mm ends at 210 mm, outside the axis "
                "range [0, 200]");
  ExpectRefused(ValidateMoveRelative(Relative(-151), Axis(), 150).status(),
                absl::StatusCode::kOutOfRange, "ends at -1 mm");
  // Exactly at both ends is allowed.
  EXPECT_TRUE(ValidateMoveRelative(Relative(50), Axis(), 150).ok());
  EXPECT_TRUE(ValidateMoveRelative(Relative(-150), Axis(), 150).ok());
}

TEST(ValidateMoveRelative, NonFiniteDistanceAndDynamicsNamed) {
  ExpectRefused(ValidateMoveRelative(Relative(kNaN), Axis(), 0).status(),
                absl::StatusCode::kInvalidArgument,
                "move_relative.distance_mm: nan is not a finite");
  ExpectRefused(ValidateMoveRelative(Relative(kInf), Axis(), 0).status(),
                absl::StatusCode::kInvalidArgument,
                "move_relative.distance_mm: inf is not a finite");
  ExpectRefused(ValidateMoveRelative(Relative(10, 0), Axis(), 0).status(),
                absl::StatusCode::kInvalidArgument,
                "move_relative.velocity_mm_s: 0 must be greater than 0");
  ExpectRefused(ValidateMoveRelative(Relative(10, 501), Axis(), 0).status(),
                absl::StatusCode::kOutOfRange,
                "move_relative.velocity_mm_s: 501 exceeds axis max_velocity_mm_s 500");
  ExpectRefused(ValidateMoveRelative(Relative(10, 100, 5001), Axis(), 0).status(),
                absl::StatusCode::kOutOfRange,
                "move_relative.acceleration_mm_s2: 5001 exceeds axis max_acceleration_mm_s2 5000");
  ExpectRefused(ValidateMoveRelative(Relative(10, 100, 1000, -1), Axis(), 0).status(),
                absl::StatusCode::kInvalidArgument,
                "move_relative.deceleration_mm_s2: -1 must not be negative");
}

v1::MoveAbsoluteRequest Absolute(double position, double v = 100, double a = 1000, double d = 0) {
  v1::MoveAbsoluteRequest r;
  r.set_name("drives/x1");
  r.set_position_mm(position);
  r.set_velocity_mm_s(v);
  r.set_acceleration_mm_s2(a);
  r.set_deceleration_mm_s2(d);
  return r;
}

// Gap 6: NaN and ±inf in every MoveAbsolute field, and a negative deceleration, are refused at the
// server layer naming the field (no adapter is needed to catch them).
TEST(ValidateMoveAbsolute, NonFiniteAndNegativeNamed) {
  ExpectRefused(ValidateMoveAbsolute(Absolute(kNaN), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.position_mm: nan is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(kInf), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.position_mm: inf is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(-kInf), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.position_mm: -inf is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, kNaN), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.velocity_mm_s: nan is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, kInf), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.velocity_mm_s: inf is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, 100, kNaN), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.acceleration_mm_s2: nan is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, 100, -kInf), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.acceleration_mm_s2: -inf is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, 100, 1000, kInf), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.deceleration_mm_s2: inf is not a finite number");
  ExpectRefused(ValidateMoveAbsolute(Absolute(10, 100, 1000, -1), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_absolute.deceleration_mm_s2: -1 must not be negative");
  ExpectRefused(ValidateMoveAbsolute(Absolute(-0.5), Axis()).status(),
                absl::StatusCode::kOutOfRange,
                "move_absolute.position_mm: -0.5 is below axis min_mm 0");
  auto ok = ValidateMoveAbsolute(Absolute(200, 500, 5000, 0), Axis());  // every limit itself
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_DOUBLE_EQ(std::get<MoveAbsolute>(*ok).deceleration_mm_s2, 5000);  // 0 = acceleration
}

v1::MoveVelocityRequest Velocity(double v, double a = 1000, double d = 0) {
  v1::MoveVelocityRequest r;
  r.set_name("drives/x1");
  r.set_velocity_mm_s(v);
  r.set_acceleration_mm_s2(a);
  r.set_deceleration_mm_s2(d);
  return r;
}

TEST(ValidateMoveVelocity, SignedVelocityCheckedByMagnitude) {
  auto back = ValidateMoveVelocity(Velocity(-500, 1000, 2000), Axis());
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_DOUBLE_EQ(std::get<MoveVelocity>(*back).velocity_mm_s, -500);  // the sign is the direction
  EXPECT_DOUBLE_EQ(std::get<MoveVelocity>(*back).deceleration_mm_s2, 2000);

  ExpectRefused(ValidateMoveVelocity(Velocity(0), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_velocity.velocity_mm_s: 0 has no direction; use Stop");
  ExpectRefused(ValidateMoveVelocity(Velocity(-501), Axis()).status(),
                absl::StatusCode::kOutOfRange,
                "move_velocity.velocity_mm_s: 501 exceeds axis max_velocity_mm_s 500");
  ExpectRefused(ValidateMoveVelocity(Velocity(kNaN), Axis()).status(),
                absl::StatusCode::kInvalidArgument, "move_velocity.velocity_mm_s: nan");
  ExpectRefused(ValidateMoveVelocity(Velocity(100, 0), Axis()).status(),
                absl::StatusCode::kInvalidArgument,
                "move_velocity.acceleration_mm_s2: 0 must be greater than 0");
  ExpectRefused(ValidateMoveVelocity(Velocity(100, 1000, 6000), Axis()).status(),
                absl::StatusCode::kOutOfRange,
                "move_velocity.deceleration_mm_s2: 6000 exceeds axis max_acceleration_mm_s2 5000");
}

TEST(ValidateStop, DecelerationDefaultsToTheAxisMaximumAndIsBounded) {
  v1::StopRequest r;
  r.set_name("drives/x1");
  auto fastest = ValidateStop(r, Axis());
  ASSERT_TRUE(fastest.ok()) << fastest.status();
  EXPECT_DOUBLE_EQ(std::get<StopMotion>(*fastest).deceleration_mm_s2, 5000);

  r.set_deceleration_mm_s2(1200);
  auto given = ValidateStop(r, Axis());
  ASSERT_TRUE(given.ok()) << given.status();
  EXPECT_DOUBLE_EQ(std::get<StopMotion>(*given).deceleration_mm_s2, 1200);

  r.set_deceleration_mm_s2(5000.5);
  ExpectRefused(ValidateStop(r, Axis()).status(), absl::StatusCode::kOutOfRange,
                "stop.deceleration_mm_s2: 5000.5 exceeds axis max_acceleration_mm_s2 5000");
  r.set_deceleration_mm_s2(-3);
  ExpectRefused(ValidateStop(r, Axis()).status(), absl::StatusCode::kInvalidArgument,
                "stop.deceleration_mm_s2: -3 must not be negative");
  r.set_deceleration_mm_s2(kInf);
  ExpectRefused(ValidateStop(r, Axis()).status(), absl::StatusCode::kInvalidArgument,
                "stop.deceleration_mm_s2: inf is not a finite number");
}

TEST(ValidateNative, LinMotMotionRangesNamed) {
  v1::SendNativeCommandRequest r;
  auto* m = r.mutable_linmot_motion();
  m->set_master_id(255);
  m->set_sub_id(15);
  m->set_parameters(std::string(30, '\x01'));
  auto ok = ValidateNative(r);
  ASSERT_TRUE(ok.ok()) << ok.status();
  const auto& mc = std::get<LinMotMcRequest>(*ok);
  EXPECT_EQ(mc.master_id, 255);
  EXPECT_EQ(mc.sub_id, 15);
  EXPECT_EQ(mc.parameters.size(), 30u);

  m->set_master_id(256);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_motion.master_id: 256 exceeds 255");
  m->set_master_id(1);
  m->set_sub_id(16);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_motion.sub_id: 16 exceeds 15");
  m->set_sub_id(0);
  m->set_parameters(std::string(31, '\0'));
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_motion.parameters: 31 bytes exceed 30");
}

TEST(ValidateNative, LinMotRtcRangesNamed) {
  v1::SendNativeCommandRequest r;
  auto* c = r.mutable_linmot_rtc();
  c->set_command_id(0x21);
  c->set_word2(65535);
  c->set_word3(1);
  c->set_word4(0);
  auto ok = ValidateNative(r);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(std::get<LinMotRtcRequest>(*ok).word2, 65535);

  c->set_command_id(300);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_rtc.command_id: 300 exceeds 255");
  c->set_command_id(1);
  c->set_word3(65536);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_rtc.word3: 65536 exceeds 65535");
  c->set_word3(0);
  c->set_word4(70000);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_rtc.word4: 70000 exceeds 65535");
}

TEST(ValidateNative, LinMotDeviceNetRangesNamed) {
  v1::SendNativeCommandRequest r;
  auto* c = r.mutable_linmot_devicenet();
  c->set_command(0xFFFF);
  c->set_value(-32768);
  EXPECT_TRUE(ValidateNative(r).ok());
  c->set_value(65535);
  EXPECT_TRUE(ValidateNative(r).ok());

  c->set_command(0x10000);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_devicenet.command: 65536 exceeds 65535");
  c->set_command(1);
  c->set_value(65536);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_devicenet.value: 65536 is outside [-32768, 65535]");
  c->set_value(-32769);
  ExpectRefused(ValidateNative(r).status(), absl::StatusCode::kInvalidArgument,
                "linmot_devicenet.value: -32769 is outside");
}

// Gap 5: a SendNativeCommandRequest with no command at all names the oneof and lists its members.
TEST(ValidateNative, EmptyOneof_InvalidArgumentNamingCommand) {
  v1::SendNativeCommandRequest r;
  r.set_name("drives/x1");
  const absl::Status s = ValidateNative(r).status();
  ExpectRefused(s, absl::StatusCode::kInvalidArgument,
                "command: one of linmot_motion, linmot_rtc, linmot_devicenet, trinamic, "
                "trinamic_tunnel, stober, canopen_sdo is required");
  // The family check leaves the missing command to ValidateNative instead of naming a family.
  EXPECT_TRUE(ValidateNativeFamily(r, "linmot").ok());
}

}  // namespace
}  // namespace drivegw::server
