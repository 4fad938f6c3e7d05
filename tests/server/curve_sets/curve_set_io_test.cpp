// Curve sets between API messages and core types (decision 014): round trips of both curve kinds,
// absent LinMot scales read as 100 %, errors naming the field, and the download hash (stable,
// sensitive to every wire field).
#include "server/core/curve_set_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::server {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;

LinMotParametricCurve Wire() {
  LinMotParametricCurve c;
  c.curve_id = 7;
  c.x_length_s = 0.5;
  c.points = {0, 1000, -2000, 3000};
  c.offset_mm = 1.5;
  c.amplitude_scale_pct = 50;
  c.time_scale_pct = 120;
  return c;
}

TEST(CurveSetIoTest, CurveProtoRoundTrip_BothKindsEqual) {
  Curve pt{"lift", "up", PositionTimeCurve{0.01, {0, 0.1 + 0.2, 1e-7}}};
  auto back = CurveFromProto("c", CurveToProto(pt));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, pt);

  Curve lm{"cam", "", Wire()};
  auto lm_back = CurveFromProto("c", CurveToProto(lm));
  ASSERT_TRUE(lm_back.ok()) << lm_back.status();
  EXPECT_EQ(*lm_back, lm);
}

TEST(CurveSetIoTest, CurveFromProto_AbsentScalesAre100Percent_MissingShapeNamed) {
  v1::Curve c;
  c.set_name("cam");
  c.mutable_linmot()->set_curve_id(3);
  auto lm = CurveFromProto("curve_set.curves[4]", c);
  ASSERT_TRUE(lm.ok()) << lm.status();
  const auto& shape = std::get<LinMotParametricCurve>(lm->shape);
  EXPECT_EQ(shape.amplitude_scale_pct, 100);
  EXPECT_EQ(shape.time_scale_pct, 100);

  c.mutable_linmot()->set_y_unit(static_cast<v1::LinMotYUnit>(9));
  auto unit = CurveFromProto("curve_set.curves[4]", c);
  EXPECT_EQ(unit.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(unit.status().message(), HasSubstr("curve_set.curves[4].linmot.y_unit"));

  v1::Curve none;
  none.set_name("x");
  auto missing = CurveFromProto("curve_set.curves[1]", none);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(missing.status().message(),
              HasSubstr("curve_set.curves[1]: curve 'x' needs a shape"));
}

TEST(CurveSetIoTest, LinMotCurveHash_StableFormatAndEveryWireFieldCounts) {
  const std::string h = LinMotCurveHash(Wire());
  EXPECT_THAT(h, MatchesRegex("fnv1a64:[0-9a-f]{16}"));
  EXPECT_EQ(LinMotCurveHash(Wire()), h);
  auto differs = [&](auto change) {
    LinMotParametricCurve c = Wire();
    change(c);
    return LinMotCurveHash(c) != h;
  };
  EXPECT_TRUE(differs([](auto& c) { c.curve_id = 8; }));
  EXPECT_TRUE(differs([](auto& c) { c.x_length_s = 0.50001; }));
  EXPECT_TRUE(differs([](auto& c) { c.points[2] = -2001; }));
  EXPECT_TRUE(differs([](auto& c) { c.points.push_back(0); }));
  EXPECT_TRUE(differs([](auto& c) { c.offset_mm = 1.5001; }));
  EXPECT_TRUE(differs([](auto& c) { c.amplitude_scale_pct = 50.1; }));
  EXPECT_TRUE(differs([](auto& c) { c.time_scale_pct = 120.01; }));
}

TEST(CurveSetIoTest, CurvePlotOf_TwoPointCurve_OneSidedSlopeZeroAcceleration) {
  Curve c{"step", "", PositionTimeCurve{0.5, {10, 20}}};
  auto plot = CurvePlotOf(c);
  ASSERT_TRUE(plot.ok()) << plot.status();
  ASSERT_EQ(plot->velocity_mm_s_size(), 2);
  EXPECT_DOUBLE_EQ(plot->velocity_mm_s(0), 20);
  EXPECT_DOUBLE_EQ(plot->velocity_mm_s(1), 20);
  EXPECT_DOUBLE_EQ(plot->acceleration_mm_s2(1), 0);
  EXPECT_DOUBLE_EQ(plot->summary().duration_s(), 0.5);
  EXPECT_EQ(plot->curve(), "step");

  Curve one{"one", "", PositionTimeCurve{0.5, {10}}};
  EXPECT_EQ(CurvePlotOf(one).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace drivegw::server
