// Curves: sampling of both shapes, the finite-difference derivation, and every validation error
// naming field, value, limit and point index (docs/decisions/012-curves.md).
#include "adapters/core/curve.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace drivegw {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using LM = LinMotParametricCurve;

AxisConfig Axis() {
  AxisConfig a;
  a.min_mm = 0;
  a.max_mm = 100;
  a.max_velocity_mm_s = 500;
  a.max_acceleration_mm_s2 = 10000;
  return a;
}

Curve PtCurve(double step, std::vector<double> positions) {
  Curve c;
  c.name = "pt";
  c.shape = PositionTimeCurve{step, std::move(positions)};
  return c;
}

Curve LmCurve(LM lm) {
  Curve c;
  c.name = "lm";
  c.shape = std::move(lm);
  return c;
}

LM GoodLm() {
  LM lm;
  lm.curve_id = 7;
  lm.x_length_s = 0.4;                          // 4 segments of 0.1 s
  lm.points = {0, 10000, 20000, 30000, 40000};  // 0, 1, 2, 3, 4 mm
  lm.offset_mm = 10;
  return lm;
}

std::string FirstMessage(const Curve& c, const AxisConfig& axis = Axis()) {
  return std::string(ValidateCurve(c, axis).message());
}

TEST(CurveSampleTest, PositionTime_CentralDifferencesInsideOneSidedAtEnds) {
  // p = t² sampled at h = 0.5 s: v = 2t, a = 2 exactly for central differences.
  const Curve c = PtCurve(0.5, {0, 0.25, 1, 2.25, 4});
  auto s = SampleCurve(c);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_THAT(s->t_s, ElementsAre(0, 0.5, 1, 1.5, 2));
  EXPECT_THAT(s->velocity_mm_s, ElementsAre(0.5, 1, 2, 3, 3.5));
  EXPECT_THAT(s->acceleration_mm_s2, ElementsAre(2, 2, 2, 2, 2));
}

TEST(CurveSampleTest, TwoPoints_ConstantVelocityZeroAcceleration) {
  auto s = SampleCurve(PtCurve(0.25, {1, 2}));
  ASSERT_TRUE(s.ok());
  EXPECT_THAT(s->velocity_mm_s, ElementsAre(4, 4));
  EXPECT_THAT(s->acceleration_mm_s2, ElementsAre(0, 0));
}

TEST(CurveSampleTest, Summary_DurationStartEndMinMaxPeaks) {
  auto sum = SummarizeCurve(PtCurve(0.1, {5, 7, 3, 4}));
  ASSERT_TRUE(sum.ok());
  EXPECT_DOUBLE_EQ(sum->duration_s, 0.3);
  EXPECT_EQ(sum->start_mm, 5);
  EXPECT_EQ(sum->end_mm, 4);
  EXPECT_EQ(sum->min_mm, 3);
  EXPECT_EQ(sum->max_mm, 7);
  EXPECT_NEAR(sum->peak_velocity_mm_s, 20, 1e-9);        // one-sided start (7 - 5) / 0.1
  EXPECT_NEAR(sum->peak_acceleration_mm_s2, 600, 1e-9);  // |3 - 14 + 5| / 0.01 at index 1
}

TEST(CurveSampleTest, LinMot_OffsetAmplitudeRelativeToFirstPointAndTimeScale) {
  LM lm = GoodLm();
  lm.points = {5000, 15000, 25000};  // first point is not 0: only the difference counts (D-29)
  lm.x_length_s = 0.2;
  lm.amplitude_scale_pct = 200;
  lm.time_scale_pct = 50;  // half speed: twice the time
  auto s = SampleCurve(LmCurve(lm));
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_DOUBLE_EQ(s->time_step_s, 0.2);
  ASSERT_EQ(s->position_mm.size(), 3u);
  EXPECT_DOUBLE_EQ(s->position_mm[0], 10);
  EXPECT_DOUBLE_EQ(s->position_mm[1], 12);
  EXPECT_DOUBLE_EQ(s->position_mm[2], 14);
  EXPECT_DOUBLE_EQ(s->velocity_mm_s[1], 10);
  auto sum = SummarizeCurve(LmCurve(lm));
  ASSERT_TRUE(sum.ok());
  EXPECT_DOUBLE_EQ(sum->duration_s, 0.4);
}

TEST(CurveSampleTest, TooFewPointsOrBadStep_Refused) {
  EXPECT_THAT(SampleCurve(PtCurve(0.1, {1})).status().message(), HasSubstr("minimum 2"));
  EXPECT_THAT(SampleCurve(PtCurve(0, {1, 2})).status().message(), HasSubstr("time_step_s"));
}

TEST(CurveValidateTest, GoodCurves_Pass) {
  EXPECT_TRUE(ValidateCurve(PtCurve(0.1, {10, 20, 30, 40}), Axis()).ok());
  EXPECT_TRUE(ValidateCurve(LmCurve(GoodLm()), Axis()).ok());
  EXPECT_THAT(CurveErrors(LmCurve(GoodLm()), Axis()), IsEmpty());
}

TEST(CurveValidateTest, TimeStep_ZeroNegativeNanInf_Refused) {
  for (double step : {0.0, -0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    EXPECT_THAT(FirstMessage(PtCurve(step, {1, 2})), HasSubstr("time_step_s: ")) << step;
    EXPECT_THAT(FirstMessage(PtCurve(step, {1, 2})), HasSubstr("finite value > 0")) << step;
  }
}

TEST(CurveValidateTest, FewerThanTwoPoints_Refused) {
  EXPECT_EQ(FirstMessage(PtCurve(0.1, {5})), "points: count 1 is below the minimum 2");
  LM lm = GoodLm();
  lm.points = {0};
  EXPECT_EQ(FirstMessage(LmCurve(lm)), "points: count 1 is below the minimum 2");
}

TEST(CurveValidateTest, NonFinitePosition_NamesIndex) {
  EXPECT_EQ(FirstMessage(PtCurve(0.1, {1, std::nan(""), 2})),
            "points[1]: position nan is not finite");
}

TEST(CurveValidateTest, Name_EmptyOrTooLong_Refused) {
  Curve c = PtCurve(0.1, {1, 2});
  c.name = "";
  EXPECT_EQ(FirstMessage(c), "name: length 0 is outside 1..128");
  c.name = std::string(129, 'x');
  EXPECT_EQ(FirstMessage(c), "name: length 129 is outside 1..128");
}

TEST(CurveValidateTest, Stroke_BelowAndAbove_NameIndexAndLimit) {
  EXPECT_EQ(FirstMessage(PtCurve(1, {1, -0.5, 1})),
            "points[1]: position -0.5 mm is below axis.min_mm 0");
  EXPECT_EQ(FirstMessage(PtCurve(1, {99, 100.25, 99})),
            "points[1]: position 100.25 mm exceeds axis.max_mm 100");
}

TEST(CurveValidateTest, Velocity_NamesIndexValueAndLimit) {
  // One jump of 162.48 mm between points 17 and 18 at h = 0.1 s: the central difference at both
  // points is 162.48 / 0.2 = 812.4 mm/s; every other point is at rest.
  std::vector<double> p(30, 10.0);
  for (size_t i = 18; i < p.size(); ++i) p[i] = 10 + 162.48;
  AxisConfig axis = Axis();
  axis.max_mm = 200;
  axis.max_acceleration_mm_s2 = 1e9;  // only the velocity limit speaks
  const auto errors = CurveErrors(PtCurve(0.1, p), axis);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "points[17]: velocity 812.4 mm/s exceeds axis.max_velocity_mm_s 500");
  EXPECT_EQ(errors[1], "points[18]: velocity 812.4 mm/s exceeds axis.max_velocity_mm_s 500");
  EXPECT_EQ(FirstMessage(PtCurve(0.1, p), axis),
            "points[17]: velocity 812.4 mm/s exceeds axis.max_velocity_mm_s 500 (and 1 more)");
  // Negative velocity is limited by magnitude.
  std::vector<double> down(p.rbegin(), p.rend());
  EXPECT_THAT(CurveErrors(PtCurve(0.1, down), axis),
              ElementsAre("points[11]: velocity -812.4 mm/s exceeds axis.max_velocity_mm_s 500",
                          "points[12]: velocity -812.4 mm/s exceeds axis.max_velocity_mm_s 500"));
  // Exactly at the limit passes.
  axis.max_velocity_mm_s = 812.4 + 1e-9;
  EXPECT_THAT(CurveErrors(PtCurve(0.1, p), axis), IsEmpty());
}

TEST(CurveValidateTest, Acceleration_NamesIndexValueAndLimit) {
  // p = 0.5 a t² with a = 12000 mm/s², h = 0.01 s, inside stroke and velocity.
  std::vector<double> p;
  for (int i = 0; i < 5; ++i) p.push_back(10 + 0.5 * 12000 * (i * 0.01) * (i * 0.01));
  const auto errors = CurveErrors(PtCurve(0.01, p), Axis());
  ASSERT_FALSE(errors.empty());
  EXPECT_THAT(errors[0], HasSubstr("points[0]: acceleration 12000 mm/s2 exceeds "
                                   "axis.max_acceleration_mm_s2 10000"));
  EXPECT_THAT(FirstMessage(PtCurve(0.01, p)), HasSubstr("(and 4 more)"));
}

TEST(CurveValidateTest, LinMot_CurveIdOutside1To100) {
  for (int id : {0, 101, -3}) {
    LM lm = GoodLm();
    lm.curve_id = id;
    EXPECT_THAT(FirstMessage(LmCurve(lm)),
                HasSubstr(absl::StrCat("curve_id: ", id, " is outside 1..100")));
  }
  LM lm = GoodLm();
  for (int id : {1, 100}) {
    lm.curve_id = id;
    EXPECT_TRUE(ValidateCurve(LmCurve(lm), Axis()).ok()) << id;
  }
}

TEST(CurveValidateTest, LinMot_PointCountLimit) {
  LM lm = GoodLm();
  lm.x_length_s = 1000;
  lm.points.assign(LM::kMaxPoints, 0);
  EXPECT_TRUE(ValidateCurveShape(LmCurve(lm)).ok());
  lm.points.push_back(0);
  EXPECT_THAT(FirstMessage(LmCurve(lm)),
              HasSubstr("points: count 16384 exceeds the LinMot limit 16383"));
}

TEST(CurveValidateTest, LinMot_XLength_RangeAndUnit) {
  LM lm = GoodLm();
  for (double x : {0.0, -1.0, std::nan(""), 50000.0}) {
    lm.x_length_s = x;
    EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("x_length_s: ")) << x;
    EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("UInt32 in 10 us")) << x;
  }
  lm.x_length_s = 0.000015;
  EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("not a whole number of 10 us units"));
  lm.x_length_s = 0.4;
  EXPECT_TRUE(ValidateCurveShape(LmCurve(lm)).ok());
}

TEST(CurveValidateTest, LinMot_AmplitudeScale_RangeAndUnit) {
  LM lm = GoodLm();
  lm.points = {0, 1};
  for (double a : {-2000.0, 2000.0, 0.1}) {
    lm.amplitude_scale_pct = a;
    EXPECT_TRUE(ValidateCurveShape(LmCurve(lm)).ok()) << a;
  }
  lm.amplitude_scale_pct = 2000.1;
  EXPECT_EQ(FirstMessage(LmCurve(lm)), "amplitude_scale_pct: 2000.1 is outside -2000..2000 %");
  lm.amplitude_scale_pct = -2000.5;
  EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("is outside -2000..2000 %"));
  lm.amplitude_scale_pct = 50.05;
  EXPECT_EQ(FirstMessage(LmCurve(lm)),
            "amplitude_scale_pct: 50.05 is not a whole number of 0.1 % units");
}

TEST(CurveValidateTest, LinMot_TimeScale_RangeAndUnit) {
  LM lm = GoodLm();
  lm.time_scale_pct = 200;
  EXPECT_TRUE(ValidateCurveShape(LmCurve(lm)).ok());
  lm.time_scale_pct = 0.01;
  EXPECT_TRUE(ValidateCurveShape(LmCurve(lm)).ok());
  for (double t : {0.0, 200.01, -5.0}) {
    lm.time_scale_pct = t;
    EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("time_scale_pct: ")) << t;
    EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("is outside (0, 200] %")) << t;
  }
  lm.time_scale_pct = 12.345;
  EXPECT_EQ(FirstMessage(LmCurve(lm)),
            "time_scale_pct: 12.345 is not a whole number of 0.01 % units");
}

TEST(CurveValidateTest, LinMot_UnknownYUnit_Refused) {
  LM lm = GoodLm();
  lm.y_unit = static_cast<LM::YUnit>(7);  // e.g. a value read from a newer stored row
  EXPECT_EQ(FirstMessage(LmCurve(lm)),
            "y_unit: only position in 0.1 um is defined (linmot-mc.md §7)");
}

TEST(CurveValidateTest, LinMot_OffsetOutsideSInt32) {
  LM lm = GoodLm();
  lm.offset_mm = 300000;
  EXPECT_THAT(FirstMessage(LmCurve(lm)), HasSubstr("offset_mm: 300000 is outside +-214748"));
}

TEST(CurveValidateTest, LinMot_ScaledCurveChecksAxisLimits) {
  LM lm = GoodLm();
  lm.amplitude_scale_pct = 2000;  // 4 mm × 20 = 80 mm above offset 10 → 90 mm: inside
  EXPECT_TRUE(ValidateCurve(LmCurve(lm),
                            [] {
                              AxisConfig a = Axis();
                              a.max_velocity_mm_s = 1000;
                              return a;
                            }())
                  .ok());
  lm.offset_mm = 30;  // 110 mm at the end
  EXPECT_THAT(CurveErrors(LmCurve(lm), Axis()),
              ::testing::Contains("points[4]: position 110 mm exceeds axis.max_mm 100"));
  // Time scale 200 %: twice as fast, 20 mm per 0.05 s = 400 mm/s at 2000 % amplitude.
  lm.offset_mm = 10;
  lm.time_scale_pct = 200;
  AxisConfig slow = Axis();
  slow.max_velocity_mm_s = 300;
  EXPECT_THAT(FirstMessage(LmCurve(lm), slow),
              HasSubstr("points[0]: velocity 400 mm/s exceeds axis.max_velocity_mm_s 300"));
}

TEST(CurveSetValidateTest, DuplicateNamesIdsAndPrefixedCurveErrors) {
  CurveSet set{"press-line", "two strokes", {LmCurve(GoodLm()), PtCurve(0.1, {10, 20})}};
  EXPECT_TRUE(ValidateCurveSet(set, Axis()).ok());
  set.curves[1].name = "lm";
  EXPECT_EQ(std::string(ValidateCurveSetShape(set).message()),
            "curves[1] 'lm': name: listed twice in curve set 'press-line'");
  set.curves[1] = LmCurve(GoodLm());
  set.curves[1].name = "lm2";
  EXPECT_EQ(std::string(ValidateCurveSetShape(set).message()),
            "curves[1] 'lm2': curve_id: 7 is used by another curve of the set");
  set.curves[1] = PtCurve(0.1, {10, 200});
  EXPECT_TRUE(ValidateCurveSetShape(set).ok());  // the axis is not part of the shape
  EXPECT_THAT(std::string(ValidateCurveSet(set, Axis()).message()),
              HasSubstr("curves[1] 'pt': points[0]: velocity 1900 mm/s exceeds"));
  set.name = "";
  EXPECT_EQ(std::string(ValidateCurveSetShape(set).message()),
            "curve_set.name: length 0 is outside 1..128");
}

}  // namespace
}  // namespace drivegw
