// Trinamic unit conversion tests against the numbers of trinamic-sixpack.md §5.1, §5.3, §5.12.
#include "adapters/trinamic/units.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace drivegw::trinamic {
namespace {

using ::testing::HasSubstr;

// §5.1 table of K (microsteps/s per velocity unit).
TEST(TrinamicUnits, VelocityUnitTable) {
  struct Row {
    int clkdiv, div;
    double k;
  };
  for (const Row& r : {Row{0, 0, 1220.703}, Row{0, 1, 610.352}, Row{0, 3, 152.588},
                       Row{2, 0, 406.901}, Row{4, 1, 122.070}, Row{5, 2, 50.863}, Row{5, 3, 25.431},
                       Row{31, 3, 4.768}, Row{31, 0, 38.147}}) {
    EXPECT_NEAR(*MicrostepsPerVelocityUnit({r.clkdiv, r.div}), r.k, 0.001)
        << r.clkdiv << "/" << r.div;
  }
}

// §5.1 checks against the manual (L363, L61).
TEST(TrinamicUnits, VelocityRegisterToMicrostepsPerSecond) {
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(511, {5, 2}), 25990.8, 0.1);
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(5, {5, 2}), 254.3, 0.1);
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(100, {5, 2}), 5086.3, 0.1);
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(4, {5, 3}), 101.7, 0.1);
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(1, {31, 3}), 4.77, 0.01);
  EXPECT_NEAR(*VelocityToMicrostepsPerSecond(-511, {5, 2}), -25990.8, 0.1);
  // Max v at clkdiv 0, div 0 is 163 (200 kHz, L497).
  EXPECT_TRUE(VelocityToMicrostepsPerSecond(163, {0, 0}).ok());
  auto over = VelocityToMicrostepsPerSecond(164, {0, 0});
  ASSERT_FALSE(over.ok());
  EXPECT_THAT(std::string(over.status().message()), HasSubstr("exceeds 200000"));
  EXPECT_FALSE(VelocityToMicrostepsPerSecond(200, {0, 0}).ok());  // CT-55
  EXPECT_TRUE(VelocityToMicrostepsPerSecond(327, {0, 1}).ok());
  EXPECT_FALSE(VelocityToMicrostepsPerSecond(328, {0, 1}).ok());
  EXPECT_EQ(VelocityToMicrostepsPerSecond(512, {5, 2}).status().message(),
            "velocity: 512 exceeds 511");
  EXPECT_EQ(VelocityToMicrostepsPerSecond(1, {32, 2}).status().message(), "clkdiv: 32 exceeds 31");
  EXPECT_EQ(VelocityToMicrostepsPerSecond(1, {5, 4}).status().message(), "div: 4 exceeds 3");
}

TEST(TrinamicUnits, MicrostepsPerSecondToVelocityRegister) {
  EXPECT_EQ(*MicrostepsPerSecondToVelocity(25990.8, {5, 2}), 511);
  EXPECT_EQ(*MicrostepsPerSecondToVelocity(254.3, {5, 2}), 5);
  EXPECT_EQ(*MicrostepsPerSecondToVelocity(-5086, {5, 2}), -100);
  EXPECT_EQ(*MicrostepsPerSecondToVelocity(0, {5, 2}), 0);
  auto too_fast = MicrostepsPerSecondToVelocity(26100, {5, 2});  // 513.1 units
  ASSERT_FALSE(too_fast.ok());
  EXPECT_EQ(too_fast.status().message(), "velocity: 513 exceeds 511");
  EXPECT_FALSE(MicrostepsPerSecondToVelocity(250000, {0, 0}).ok());
  // 199 999 Hz rounds to v 164 = 200 195 Hz: refused, never clamped.
  EXPECT_FALSE(MicrostepsPerSecondToVelocity(199999, {0, 0}).ok());
  for (int v = -511; v <= 511; v += 73) {
    EXPECT_EQ(*MicrostepsPerSecondToVelocity(*VelocityToMicrostepsPerSecond(v, {5, 2}), {5, 2}), v);
  }
}

// §5.3: defaults amax 128 → 50 863 µsteps/s² (3179 full steps/s²).
TEST(TrinamicUnits, Acceleration) {
  EXPECT_NEAR(*AmaxToMicrostepsPerSecond2(128, {5, 2}), 50863, 1);
  EXPECT_NEAR(*AmaxToMicrostepsPerSecond2(128, {5, 2}) / 16, 3179, 1);
  EXPECT_EQ(*MicrostepsPerSecond2ToAmax(50863, {5, 2}), 128);
  EXPECT_EQ(AmaxToMicrostepsPerSecond2(0, {5, 2}).status().message(), "amax: 0 below 1");
  EXPECT_EQ(AmaxToMicrostepsPerSecond2(32768, {5, 2}).status().message(),
            "amax: 32768 exceeds 32767");
  EXPECT_EQ(MicrostepsPerSecond2ToAmax(1, {5, 2}).status().message(), "amax: 0 below 1");
  EXPECT_FALSE(MicrostepsPerSecond2ToAmax(1e12, {5, 2}).ok());
  for (int a : {1, 128, 16384, 32767}) {
    EXPECT_EQ(*MicrostepsPerSecond2ToAmax(*AmaxToMicrostepsPerSecond2(a, {5, 2}), {5, 2}), a);
  }
}

TEST(TrinamicUnits, PositionMm) {
  // 400-step motor (6400 µsteps/rev, L364) on a 5 mm lead screw: 1280 µsteps per mm.
  EXPECT_DOUBLE_EQ(*MicrostepsToMm(6400, 1280), 5.0);
  EXPECT_DOUBLE_EQ(*MicrostepsToMm(-1234, 1280), -1234.0 / 1280);
  EXPECT_EQ(*MmToMicrosteps(5.0, 1280), 6400);
  EXPECT_EQ(*MmToMicrosteps(-0.5, 1280), -640);
  EXPECT_EQ(*MmToMicrosteps(1.0 / 1280 * 0.6, 1280), 1);  // rounds to nearest
  auto far = MmToMicrosteps(2e6, 1280);
  ASSERT_FALSE(far.ok());
  EXPECT_THAT(std::string(far.status().message()), HasSubstr("position.microsteps"));
  EXPECT_THAT(std::string(far.status().message()), HasSubstr("exceeds 2147483647"));
  EXPECT_FALSE(MmToMicrosteps(1, 0).ok());
  EXPECT_FALSE(MicrostepsToMm(1, -1).ok());
}

TEST(TrinamicUnits, VelocityAndAccelerationInMm) {
  // Defaults, 200-step motor: v 511 = 8.12 rev/s (§5.1); with 3200 µsteps per unit (1 rev = 1
  // unit).
  EXPECT_NEAR(*VelocityToMmPerSecond(511, {5, 2}, 3200), 8.12, 0.01);
  EXPECT_EQ(*MmPerSecondToVelocity(8.12, {5, 2}, 3200), 511);
  EXPECT_NEAR(*AmaxToMmPerSecond2(128, {5, 2}, 1280), 50863.0 / 1280, 0.01);
  EXPECT_EQ(*MmPerSecond2ToAmax(50863.0 / 1280, {5, 2}, 1280), 128);
  EXPECT_EQ(MmPerSecondToVelocity(100, {5, 2}, 3200).status().message(),
            "velocity.microstep_hz: 320000 exceeds 200000");
}

}  // namespace
}  // namespace drivegw::trinamic
