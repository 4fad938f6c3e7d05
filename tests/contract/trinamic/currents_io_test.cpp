// Trinamic PACK contract cases whose observable is introspection (§8.5: CT-43 peak current,
// CT-44 coil currents, CT-45 ready output): the pure controller, fed the exact request bytes and
// advanced in 2 ms ticks (trinamic-sixpack.md §5.9, L505-528, L803-825).
#include <cmath>
#include <cstdint>
#include <vector>

#include "adapters/trinamic/codec.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

Controller Pack() {
  auto c = Controller::Create(CommonSetup(ReplyFraming::kR8).controller);
  EXPECT_TRUE(c.ok()) << c.status();
  return *std::move(c);
}

void Send(Controller& c, const Bytes& word) {
  auto command = drivegw::trinamic::DecodeCommand(word);
  ASSERT_TRUE(command.ok()) << command.status();
  EXPECT_FALSE(c.Handle(*command).has_value()) << "a write command has no reply";
}

// CT-43 "Peak current is set per pair" — target PACK — L505-512: "When `01 10 01 FF 00 00 00 00
// 00`. Then (introspection) the peak current of motors 0 and 1 is unchanged (400 mA). When
// `01 10 00 FF 00 00 00 00 00`. Then both motors 0 and 1 have 796.9 mA (SIXpack)."
TEST(TrinamicPack, CT43_PeakCurrentPerPair) {
  Controller c = Pack();
  Send(c, {0x01, 0x10, 0x01, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_DOUBLE_EQ(c.PeakCurrentMa(0), 400.0);
  EXPECT_DOUBLE_EQ(c.PeakCurrentMa(1), 400.0);
  Send(c, {0x01, 0x10, 0x00, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_NEAR(c.PeakCurrentMa(0), 796.9, 0.05);
  EXPECT_NEAR(c.PeakCurrentMa(1), 796.9, 0.05);
  EXPECT_DOUBLE_EQ(c.PeakCurrentMa(2), 400.0) << "the next pair is untouched";
}

// CT-44 "Current control and stand-by" — target PACK — L514-528, L366: "Given `01 10 00 80 00 00
// 00 00 00` and `01 11 00 08 02 01 00 F4 01`. When motor 0 performs a 100 000-µstep move. Then
// (introspection) its current is 400 mA while accelerating/decelerating, 300 mA at constant
// velocity, 200 mA standing, and 0 mA from 1000 ms ± 2 ms after the stop."
TEST(TrinamicPack, CT44_CurrentControlAndStandby) {
  Controller c = Pack();
  Send(c, {0x01, 0x10, 0x00, 0x80, 0x00, 0x00, 0x00, 0x00, 0x00});
  Send(c, {0x01, 0x11, 0x00, 0x08, 0x02, 0x01, 0x00, 0xF4, 0x01});
  c.Advance(kTick);
  EXPECT_DOUBLE_EQ(c.CoilCurrentMa(0), 200.0) << "standing";
  Send(c, {0x01, 0x23, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});
  int accelerating = 0;
  int constant = 0;
  int ticks = 0;
  int previous = 0;
  while (c.state(0).action != Action::kInactive && ticks < 5000) {
    c.Advance(kTick);
    ++ticks;
    if (c.state(0).action == Action::kInactive) break;
    const int v = std::abs(c.state(0).v64);  // 64 × velocity (§5.3)
    const double ma = c.CoilCurrentMa(0);
    if (v != previous) {
      ASSERT_DOUBLE_EQ(ma, 400.0) << "tick " << ticks << " v64 " << v;
      ++accelerating;
    } else {
      ASSERT_DOUBLE_EQ(ma, 300.0) << "tick " << ticks << " v64 " << v;
      ++constant;
    }
    previous = v;
  }
  ASSERT_EQ(c.state(0).action, Action::kInactive);
  EXPECT_EQ(c.state(0).position, 100000);
  EXPECT_GT(accelerating, 400) << "acceleration and deceleration phases";
  EXPECT_GT(constant, 1000) << "constant-velocity phase";
  // The stop tick is t = 0: 200 mA up to 1000 ms − 2 ms, 0 mA from 1000 ms + 2 ms (L524-528).
  EXPECT_DOUBLE_EQ(c.CoilCurrentMa(0), 200.0);
  c.Advance(kTick * 499);  // 998 ms after the stop
  EXPECT_DOUBLE_EQ(c.CoilCurrentMa(0), 200.0);
  c.Advance(kTick * 2);  // 1002 ms
  EXPECT_DOUBLE_EQ(c.CoilCurrentMa(0), 0.0);
}

// CT-45 "Ready output" — target PACK — L803-825: "Given `01 32 01 01 00 01 00 00 00` and
// `01 33 3F 3F 00 00 00 00 00`. When motor 0 starts a ramp. Then TTLOUT1 becomes active (low)
// within 2 ms, and returns to READY (high) within 2 ms after the motor stops."
TEST(TrinamicPack, CT45_ReadyOutput) {
  Controller c = Pack();
  Send(c, {0x01, 0x32, 0x01, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00});
  Send(c, {0x01, 0x33, 0x3F, 0x3F, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_TRUE(c.Ttlout1High()) << "READY while all motors stand";
  Send(c, {0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00});
  c.Advance(kTick);
  EXPECT_FALSE(c.Ttlout1High()) << "active within 2 ms of the start";
  int ticks = 0;
  while (c.state(0).action != Action::kInactive && ticks < 5000) {
    ASSERT_FALSE(c.Ttlout1High()) << "tick " << ticks;
    c.Advance(kTick);
    ++ticks;
  }
  // The stop happened within the last tick: READY now, i.e. within 2 ms.
  EXPECT_TRUE(c.Ttlout1High());
  // With motor 0 masked out of `$33` the output stays READY during the motion.
  Send(c, {0x01, 0x33, 0x3E, 0x3E, 0x00, 0x00, 0x00, 0x00, 0x00});
  Send(c, {0x01, 0x23, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
  c.Advance(kTick);
  EXPECT_NE(c.state(0).action, Action::kInactive);
  EXPECT_TRUE(c.Ttlout1High());
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
