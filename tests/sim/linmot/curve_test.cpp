// Time curves 040h-045h on the simulated drive (linmot-mc.md §5.5 L515-L535, §7 D-29 L1009;
// docs/decisions/606-linmot-sim-time-curves.md): curves stored through the RTC curve service,
// D-29 evaluation, defaults 14C9h-14CBh, "To Pos" scaling, errors 0062h/0089h, aborts.
#include <cmath>
#include <vector>

#include "adapters/linmot/linudp/curve_info_block.h"
#include "adapters/linmot/mc/error_codes.h"
#include "sim/linmot/parameters.h"
#include "tests/sim/linmot/device_fixture.h"

namespace drivegw::sim::linmot::testing {
namespace {

using linudp::RtcCommand;

// 0 -> 10 mm -> 30 mm over 0.5 s: y(0.5) = 10 mm, y(1) = 30 mm.
const std::vector<int32_t> kRamp = {0, 100'000, 300'000};
constexpr uint32_t kHalfSecond = 50'000;  // x-Length, 10 us

mc::McCommand Curve(uint8_t sub, std::vector<int64_t> values) {
  return mc::McCommand{0x04, sub, std::move(values)};
}

class CurveTest : public DeviceFixture {
 protected:
  void SetUp() override {
    DeviceFixture::SetUp();
    Ready();  // state 8, homed, at 0
  }

  linudp::RtcReply Rtc(RtcCommand id, uint16_t w2, uint16_t w3 = 0, uint16_t w4 = 0) {
    rtc_count_ = static_cast<uint8_t>(rtc_count_ % 15 + 1);
    linudp::Request r;
    r.response_definition = linudp::kRespRtc;
    r.rtc = linudp::RtcRequest{rtc_count_, static_cast<uint8_t>(id), w2, w3, w4};
    auto reply = dev_->Handle(r);
    EXPECT_TRUE(reply && reply->rtc);
    return reply && reply->rtc ? *reply->rtc : linudp::RtcReply{};
  }
  // The curve service download sequence (linmot-linudp.md L350): 0x50, 0x51 x 18, 0x52 x N.
  void Store(uint16_t id, const std::vector<int32_t>& points, uint32_t x_length) {
    linudp::CurveInfoBlock info;
    info.curve_id = id;
    info.point_count = static_cast<uint16_t>(points.size());
    info.x_length = x_length;
    const std::vector<uint8_t> block = linudp::EncodeCurveInfoBlock(info);
    const std::vector<uint8_t> data = linudp::EncodeCurveData(points);
    ASSERT_EQ(Rtc(RtcCommand::kStartAddingCurve, id, static_cast<uint16_t>(block.size()),
                  static_cast<uint16_t>(data.size()))
                  .status,
              linudp::kRtcStatusDone);
    for (size_t at = 0; at < block.size(); at += 4) {
      auto byte = [&](size_t i) -> uint16_t { return i < block.size() ? block[i] : 0; };
      Rtc(RtcCommand::kAddCurveInfoBlock, id, static_cast<uint16_t>(byte(at) | byte(at + 1) << 8),
          static_cast<uint16_t>(byte(at + 2) | byte(at + 3) << 8));
    }
    uint8_t last = 0;
    for (int32_t p : points) {
      const auto u = static_cast<uint32_t>(p);
      last = Rtc(RtcCommand::kAddCurveData, id, static_cast<uint16_t>(u & 0xFFFF),
                 static_cast<uint16_t>(u >> 16))
                 .status;
    }
    ASSERT_EQ(last, linudp::kRtcStatusDone);
  }
  // Ticks until Motion Active drops; returns the simulated milliseconds.
  int RunToEnd(int limit_ms = 5000) {
    int t = 0;
    while (Sw().motion_active() && t < limit_ms) {
      Ms(1);
      ++t;
    }
    return t;
  }
  void MoveTo(double mm) {
    Mc(GoTo(mm));
    RunToEnd();
    Ms(3);
    ASSERT_NEAR(DemandMm(), mm, 1e-9);
  }

  uint8_t rtc_count_ = 0;
};

TEST_F(CurveTest, Default040_FollowsD29WithTheDefaultsOf14C9h_EndsInTarget) {
  Store(5, kRamp, kHalfSecond);
  ASSERT_TRUE(dev_->parameters().WriteRam(upid::kCurveOffset, 100'000).ok());  // 10 mm
  Mc(Curve(0x0, {5}));
  EXPECT_TRUE(Sw().motion_active());
  EXPECT_NEAR(DemandMm(), 10.0, 1e-9);  // offset + (y(0) - y(0))
  Ms(125);
  EXPECT_NEAR(DemandMm(), 15.0, 1e-6);  // tau 0.25: half way to the second point
  Ms(125);
  EXPECT_NEAR(DemandMm(), 20.0, 1e-6);  // tau 0.5: y = 10 mm
  Ms(1);
  EXPECT_NEAR(DemandVelocity(), 80.0, 1e-6);  // 20 mm in 0.25 s on the second segment
  EXPECT_TRUE(Sw().motion_active());
  EXPECT_FALSE(Sw().in_target_position());
  const int rest = RunToEnd();
  EXPECT_EQ(251 + rest, 500);
  EXPECT_EQ(dev_->demand_position(), 400'000);  // 10 + 30 mm
  Ms(2);
  EXPECT_TRUE(Sw().in_target_position());
  EXPECT_EQ(dev_->actual_position(), 400'000);
  EXPECT_FALSE(dev_->running_curve().has_value());
}

TEST_F(CurveTest, FromDemand041_OffsetIsTheDemand_ScalesFrom14CAhAnd14CBh) {
  Store(6, kRamp, kHalfSecond);
  MoveTo(50);
  ASSERT_TRUE(dev_->parameters().WriteRam(upid::kCurveAmplitudeScale, 500).ok());  // 50 %
  ASSERT_TRUE(dev_->parameters().WriteRam(upid::kCurveTimeScale, 20000).ok());     // 200 %
  Mc(Curve(0x1, {6}));
  EXPECT_EQ(RunToEnd(), 250);           // 0.5 s x 100 % / 200 %
  EXPECT_NEAR(DemandMm(), 65.0, 1e-6);  // 50 + 0.5 x 30
}

TEST_F(CurveTest, ToPos042_AmplitudeReachesTheTarget_DefaultTime) {
  Store(7, kRamp, kHalfSecond);
  Mc(Curve(0x2, {7, 600'000}));  // 60 mm: scale 200 %
  Ms(250);
  EXPECT_NEAR(DemandMm(), 20.0, 1e-6);  // 2 x y(0.5)
  EXPECT_EQ(250 + RunToEnd(), 500);
  EXPECT_EQ(dev_->demand_position(), 600'000);
}

TEST_F(CurveTest, ToPos043_CurveTimeFromTheCommand) {
  Store(7, kRamp, kHalfSecond);
  Mc(Curve(0x3, {7, 150'000, 20'000}));  // 15 mm in 0.2 s
  EXPECT_EQ(RunToEnd(), 200);
  EXPECT_EQ(dev_->demand_position(), 150'000);
}

TEST_F(CurveTest, Scaled044_OffsetTimeScaleAndNegativeAmplitude) {
  Store(8, kRamp, kHalfSecond);
  MoveTo(100);
  Mc(Curve(0x4, {8, 1'000'000, 5000, -1000}));  // at 100 mm, 50 % speed, -100 %
  Ms(500);
  EXPECT_NEAR(DemandMm(), 90.0, 1e-6);  // tau 0.5 of a 1 s curve
  EXPECT_EQ(500 + RunToEnd(), 1000);
  EXPECT_EQ(dev_->demand_position(), 700'000);
}

TEST_F(CurveTest, Timed045_OffsetCurveTimeAmplitude) {
  Store(9, kRamp, kHalfSecond);
  MoveTo(20);
  Mc(Curve(0x5, {9, 200'000, 30'000, 500}));  // 0.3 s, 50 %
  EXPECT_EQ(RunToEnd(), 300);
  EXPECT_EQ(dev_->demand_position(), 350'000);
}

TEST_F(CurveTest, UndefinedCurve_Raises0062h) {
  Mc(Curve(0x0, {42}));
  EXPECT_EQ(dev_->error_code(), mc::kCurveNotDefined);
  EXPECT_TRUE(Sw().error());
  EXPECT_FALSE(Sw().motion_active());
}

TEST_F(CurveTest, StoredBlockThatIsNoCurve_Raises0062h) {
  // Four bytes of info: stored by the curve service, but not a curve the layout describes.
  ASSERT_EQ(Rtc(RtcCommand::kStartAddingCurve, 3, 4, 8).status, linudp::kRtcStatusDone);
  Rtc(RtcCommand::kAddCurveInfoBlock, 3, 1, 2);
  Rtc(RtcCommand::kAddCurveData, 3, 0, 0);
  Rtc(RtcCommand::kAddCurveData, 3, 100, 0);
  Mc(Curve(0x0, {3}));
  EXPECT_EQ(dev_->error_code(), mc::kCurveNotDefined);
}

TEST_F(CurveTest, ToPosScaleBeyond2000Percent_Raises0089h) {
  Store(7, kRamp, kHalfSecond);
  Mc(Curve(0x2, {7, 10'000'000}));  // 1000 mm over a 30 mm curve: 3333 %
  EXPECT_EQ(dev_->error_code(), mc::kCurveAmpScaleError);
}

TEST_F(CurveTest, ToPosOnAFlatCurve_Raises0089h) {
  Store(4, {0, 50'000, 0}, kHalfSecond);  // y(1) = y(0)
  Mc(Curve(0x3, {4, 100'000, 10'000}));
  EXPECT_EQ(dev_->error_code(), mc::kCurveAmpScaleError);
}

TEST_F(CurveTest, ScaledAmplitudeBeyond2000Percent_Raises0089h) {
  Store(8, kRamp, kHalfSecond);
  Mc(Curve(0x4, {8, 0, 10000, 20001}));
  EXPECT_EQ(dev_->error_code(), mc::kCurveAmpScaleError);
}

TEST_F(CurveTest, NewMotionCommand_AbortsTheCurve) {
  Store(5, kRamp, kHalfSecond);
  Mc(Curve(0x0, {5}));
  Ms(100);
  ASSERT_TRUE(dev_->running_curve().has_value());
  Mc(GoTo(5));
  EXPECT_FALSE(dev_->running_curve().has_value());
  RunToEnd();
  Ms(3);
  EXPECT_EQ(dev_->demand_position(), 50'000);
  EXPECT_TRUE(Sw().in_target_position());
}

TEST_F(CurveTest, Freeze_AbortsTheCurve_ReleaseGoesToTheLastVaiTarget) {
  Store(5, kRamp, kHalfSecond);
  MoveTo(40);
  Mc(Curve(0x4, {5, 400'000, 10000, 1000}));  // 40 -> 70 mm
  Ms(200);
  Cw(mc::kOperational & ~mc::kFreezeN);
  EXPECT_EQ(Main(), 13);
  EXPECT_FALSE(dev_->running_curve().has_value());
  Ms(200);
  EXPECT_FALSE(Sw().motion_active());
  Cw(mc::kOperational);
  EXPECT_EQ(Main(), 8);
  RunToEnd();
  EXPECT_EQ(dev_->demand_position(), 400'000);  // §7 L1008: not resumed, back to 40 mm
}

TEST_F(CurveTest, QuickStop_AbortsTheCurve) {
  Store(5, kRamp, kHalfSecond);
  Mc(Curve(0x0, {5}));
  Ms(100);
  Cw(mc::kOperational & ~mc::kQuickStopN);
  EXPECT_FALSE(dev_->running_curve().has_value());
  Ms(500);
  EXPECT_FALSE(Sw().motion_active());
  EXPECT_LT(DemandMm(), 30.0);  // stopped, never reached the end
}

}  // namespace
}  // namespace drivegw::sim::linmot::testing
