// Curve runner helpers (adapters/core/curve_run.h; decision 013): set points at a bus cycle
// (end point exact, a cycle longer than the curve, one-interval curves, uneven ends) and the legs
// of a curve run as moves (end point exact, max legs, equal durations, leg velocities).
#include "adapters/core/curve_run.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace drivegw {
namespace {

using ::testing::DoubleNear;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

CurveSamples Samples(double step, std::vector<double> positions) {
  Curve c;
  c.name = "c";
  c.shape = PositionTimeCurve{step, std::move(positions)};
  auto s = SampleCurve(c);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *s : CurveSamples{};
}

// ---------------------------------------------------------------- ResampleCurve

TEST(ResampleCurveTest, CycleDividesDuration_InterpolatesAndEndsOnEndPoint) {
  // 0 → 10 → 4 mm over 2 × 0.1 s, sampled every 0.025 s: 9 set points.
  const CurveSamples s = Samples(0.1, {0, 10, 4});
  auto r = ResampleCurve(s, 0.025);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_THAT(*r, ElementsAre(DoubleNear(0, 1e-12), DoubleNear(2.5, 1e-12), DoubleNear(5, 1e-12),
                              DoubleNear(7.5, 1e-12), DoubleNear(10, 1e-12), DoubleNear(8.5, 1e-12),
                              DoubleNear(7, 1e-12), DoubleNear(5.5, 1e-12), 4.0));
  EXPECT_EQ(r->back(), 4.0);  // exactly, not interpolated
}

TEST(ResampleCurveTest, UnevenEnd_LastSetPointIsTheEndPointExactly) {
  // 0.3 s at 0.07 s: t = 0, .07, .14, .21, .28 then the end (0.3 s) — 6 set points.
  const CurveSamples s = Samples(0.1, {1, 2, 3, 4.123456789});
  auto r = ResampleCurve(s, 0.07);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->size(), 6u);
  EXPECT_NEAR((*r)[4], 3 + 0.8 * 1.123456789, 1e-12);
  EXPECT_EQ(r->back(), 4.123456789);
}

TEST(ResampleCurveTest, FloatingPointDurationDoesNotAddACycle) {
  // 0.3 / 0.1 = 2.9999999999999996 and 0.7 / 0.1 = 6.999999999999999 in doubles: no extra cycle.
  const CurveSamples three = Samples(0.1, {0, 1, 2, 3});
  auto r3 = ResampleCurve(three, 0.1);
  ASSERT_TRUE(r3.ok());
  EXPECT_THAT(*r3, ElementsAre(DoubleNear(0, 1e-9), DoubleNear(1, 1e-9), DoubleNear(2, 1e-9), 3.0));
  const CurveSamples seven = Samples(0.1, {0, 1, 2, 3, 4, 5, 6, 7});
  auto r7 = ResampleCurve(seven, 0.1);
  ASSERT_TRUE(r7.ok());
  EXPECT_EQ(r7->size(), 8u);
  // 1 ms cycle over a 1 s curve: exactly 1001 set points.
  auto r1 = ResampleCurve(Samples(0.5, {0, 5, 10}), 0.001);
  ASSERT_TRUE(r1.ok());
  EXPECT_EQ(r1->size(), 1001u);
  EXPECT_NEAR((*r1)[500], 5, 1e-9);
}

TEST(ResampleCurveTest, PeriodLongerThanTheCurve_StartAndEndOnly) {
  const CurveSamples s = Samples(0.01, {3, 4, 6});
  auto r = ResampleCurve(s, 1.0);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_THAT(*r, ElementsAre(3.0, 6.0));
}

TEST(ResampleCurveTest, OneIntervalCurve) {
  const CurveSamples s = Samples(0.004, {-1, 1});
  auto r = ResampleCurve(s, 0.002);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_THAT(*r, ElementsAre(-1.0, DoubleNear(0, 1e-12), 1.0));
  // Period equal to the only interval: start and end.
  auto same = ResampleCurve(s, 0.004);
  ASSERT_TRUE(same.ok());
  EXPECT_THAT(*same, ElementsAre(-1.0, 1.0));
}

TEST(ResampleCurveTest, ResamplesTheDerivedVelocityLikeAnyColumn) {
  // The STOBER runner feeds the velocity forward by resampling the velocity column the same way.
  CurveSamples s = Samples(0.1, {0, 1, 3});
  CurveSamples v = s;
  v.position_mm = s.velocity_mm_s;  // 10, 15, 20 mm/s
  auto r = ResampleCurve(v, 0.05);
  ASSERT_TRUE(r.ok());
  EXPECT_THAT(*r, ElementsAre(DoubleNear(10, 1e-9), DoubleNear(12.5, 1e-9), DoubleNear(15, 1e-9),
                              DoubleNear(17.5, 1e-9), 20.0));
}

TEST(ResampleCurveTest, RefusesBadPeriodAndEmptyCurve) {
  const CurveSamples s = Samples(0.1, {0, 1});
  for (double p : {0.0, -0.001, std::numeric_limits<double>::infinity(),
                   std::numeric_limits<double>::quiet_NaN()}) {
    auto r = ResampleCurve(s, p);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << p;
  }
  EXPECT_THAT(std::string(ResampleCurve(s, 0).status().message()), HasSubstr("must be > 0"));
  EXPECT_EQ(ResampleCurve(CurveSamples{}, 0.001).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- SegmentCurve

TEST(SegmentCurveTest, FewerPointsThanLegs_OneLegPerInterval) {
  const CurveSamples s = Samples(0.5, {0, 2, 2, -1});
  const auto legs = SegmentCurve(s, 10);
  ASSERT_EQ(legs.size(), 3u);
  EXPECT_DOUBLE_EQ(legs[0].end_time_s, 0.5);
  EXPECT_DOUBLE_EQ(legs[0].position_mm, 2);
  EXPECT_DOUBLE_EQ(legs[0].velocity_mm_s, 4);
  EXPECT_DOUBLE_EQ(legs[1].velocity_mm_s, 0);  // a leg that stands still
  EXPECT_DOUBLE_EQ(legs[2].end_time_s, 1.5);
  EXPECT_DOUBLE_EQ(legs[2].position_mm, -1);
  EXPECT_DOUBLE_EQ(legs[2].velocity_mm_s, 6);  // a speed: |distance| / duration
}

TEST(SegmentCurveTest, MaxLegs_EqualDurationsEndingOnSamples_LastOnTheEndPoint) {
  // 101 samples of p = t² (h = 0.01 s) in 4 legs of 25 intervals.
  std::vector<double> p;
  for (int i = 0; i <= 100; ++i) p.push_back(0.0001 * i * i);
  const CurveSamples s = Samples(0.01, p);
  const auto legs = SegmentCurve(s, 4);
  ASSERT_EQ(legs.size(), 4u);
  for (size_t k = 0; k < legs.size(); ++k) {
    EXPECT_NEAR(legs[k].end_time_s, 0.25 * static_cast<double>(k + 1), 1e-12) << k;
  }
  EXPECT_EQ(legs.back().position_mm, p.back());
  EXPECT_NEAR(legs[0].velocity_mm_s, 0.0625 / 0.25, 1e-12);
  EXPECT_NEAR(legs[1].velocity_mm_s, (0.25 - 0.0625) / 0.25, 1e-12);
}

TEST(SegmentCurveTest, UnevenShare_RoundsToTheNearestSampleAndNeverRepeats) {
  // 10 intervals in 3 legs: ends at samples 3, 7, 10 (3.33 → 3, 6.67 → 7).
  const CurveSamples s = Samples(0.1, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10});
  const auto legs = SegmentCurve(s, 3);
  ASSERT_EQ(legs.size(), 3u);
  EXPECT_DOUBLE_EQ(legs[0].position_mm, 3);
  EXPECT_DOUBLE_EQ(legs[1].position_mm, 7);
  EXPECT_DOUBLE_EQ(legs[2].position_mm, 10);
  // 9 intervals in 8 legs: strictly increasing end times.
  const auto many = SegmentCurve(Samples(0.1, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9}), 8);
  ASSERT_EQ(many.size(), 8u);
  for (size_t k = 1; k < many.size(); ++k) EXPECT_GT(many[k].end_time_s, many[k - 1].end_time_s);
  EXPECT_DOUBLE_EQ(many.back().position_mm, 9);
}

TEST(SegmentCurveTest, OneLeg_GoesStraightToTheEnd) {
  const CurveSamples s = Samples(0.2, {5, 9, 1, 7});
  const auto legs = SegmentCurve(s, 1);
  ASSERT_EQ(legs.size(), 1u);
  EXPECT_NEAR(legs[0].end_time_s, 0.6, 1e-12);
  EXPECT_DOUBLE_EQ(legs[0].position_mm, 7);
  EXPECT_NEAR(legs[0].velocity_mm_s, 2 / 0.6, 1e-12);
}

TEST(SegmentCurveTest, OneIntervalCurve_OneLeg) {
  const auto legs = SegmentCurve(Samples(0.05, {1, 2}), 100);
  ASSERT_EQ(legs.size(), 1u);
  EXPECT_DOUBLE_EQ(legs[0].end_time_s, 0.05);
  EXPECT_DOUBLE_EQ(legs[0].position_mm, 2);
  EXPECT_NEAR(legs[0].velocity_mm_s, 20, 1e-9);
}

TEST(SegmentCurveTest, NoLegsForZeroMaxOrASinglePoint) {
  EXPECT_THAT(SegmentCurve(Samples(0.1, {0, 1, 2}), 0), IsEmpty());
  CurveSamples one;
  one.time_step_s = 0.1;
  one.position_mm = {3};
  EXPECT_THAT(SegmentCurve(one, 5), IsEmpty());
}

}  // namespace
}  // namespace drivegw
