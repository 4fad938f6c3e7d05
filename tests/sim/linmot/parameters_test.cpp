// Parameters: the UPID table, typed wire conversion, RAM/ROM (D-31) and the 002x bit rule.
#include "sim/linmot/parameters.h"

#include "gtest/gtest.h"

namespace drivegw::sim::linmot {
namespace {

TEST(ParametersTest, ForOptions_DefaultsFollowStrokeAndHoming) {
  SimOptions o;
  o.stroke_min_mm = -20;
  o.stroke_max_mm = 80;
  o.home_position_mm = 5;
  const Parameters p = Parameters::ForOptions(o);
  EXPECT_EQ(p.Get(upid::kMinimalPosition), -200000);
  EXPECT_EQ(p.Get(upid::kMaximalPosition), 800000);
  EXPECT_EQ(p.Get(upid::kHomePosition), 50000);
  EXPECT_EQ(p.Get(upid::kInTargetWindow), 100);  // D-10 default
  ASSERT_NE(p.Find(upid::kActualPosition), nullptr);
  EXPECT_TRUE(p.Find(upid::kActualPosition)->read_only);
}

TEST(ParametersTest, WriteRam_KeepsRomUntilBoot_RomSurvivesBoot) {
  Parameters p = Parameters::ForOptions(SimOptions{});
  ASSERT_TRUE(p.WriteRam(upid::kPredefVelocity, 500000).ok());
  EXPECT_EQ(p.ReadRom(upid::kPredefVelocity).value(), 1000000);
  p.Boot();  // D-31: RAM := ROM
  EXPECT_EQ(p.Get(upid::kPredefVelocity), 1000000);
  ASSERT_TRUE(p.WriteRom(upid::kPredefVelocity, 250000).ok());
  p.Boot();
  EXPECT_EQ(p.Get(upid::kPredefVelocity), 250000);
  p.RestoreRomDefaults();
  p.Boot();
  EXPECT_EQ(p.Get(upid::kPredefVelocity), 1000000);
}

TEST(ParametersTest, Write_Errors_NameUpidAndLimit) {
  Parameters p = Parameters::ForOptions(SimOptions{});
  EXPECT_TRUE(absl::IsNotFound(p.WriteRam(0x1450, 1)));
  EXPECT_TRUE(absl::IsFailedPrecondition(p.WriteRam(upid::kActualPosition, 1)));
  const absl::Status s = p.WriteRam(upid::kTriggerMode, 7);
  EXPECT_TRUE(absl::IsOutOfRange(s));
  EXPECT_NE(s.message().find("170Ch"), std::string::npos) << s;
  EXPECT_NE(s.message().find("[0, 4]"), std::string::npos) << s;
  EXPECT_TRUE(absl::IsFailedPrecondition(p.ReadRom(upid::kDemandPosition).status()));
}

TEST(ParametersTest, FromWire_ChecksType) {
  const Parameters p = Parameters::ForOptions(SimOptions{});
  EXPECT_EQ(p.FromWire(upid::kMinimalPosition, 0xFFFFFFFF).value(), -1);            // SInt32
  EXPECT_EQ(p.FromWire(upid::kPredefVelocity, 0x80000000u).value(), 0x80000000LL);  // UInt32
  EXPECT_TRUE(absl::IsOutOfRange(p.FromWire(upid::kTriggerMode, 70000).status()));  // UInt16
}

TEST(ParametersTest, FromLiveWrite_BoolUsesBitZero) {
  // linmot-mc.md LMC-19 / MC22 L1152.
  const Parameters p = Parameters::ForOptions(SimOptions{});
  EXPECT_EQ(p.FromLiveWrite(upid::kMotorRequiresHoming, 0xFFFFFFFE).value(), 0);
  EXPECT_EQ(p.FromLiveWrite(upid::kMotorRequiresHoming, 0x00000001).value(), 1);
  EXPECT_EQ(p.FromLiveWrite(upid::kTriggerMode, 0xABCD0003).value(), 3);
}

TEST(ParametersTest, NextUpid_ListsAllThenModified) {
  Parameters p = Parameters::ForOptions(SimOptions{});
  EXPECT_EQ(p.NextUpid(0, false), upid::kOperatingSubHours);
  EXPECT_EQ(p.NextUpid(0x1474, false), upid::kPositionLagStandingMax);
  EXPECT_EQ(p.NextUpid(0x10000, false), std::nullopt);
  EXPECT_EQ(p.NextUpid(0, true), std::nullopt);
  ASSERT_TRUE(p.WriteRom(upid::kQuickStopDeceleration, 123).ok());
  EXPECT_EQ(p.NextUpid(0, true), upid::kQuickStopDeceleration);
}

}  // namespace
}  // namespace drivegw::sim::linmot
