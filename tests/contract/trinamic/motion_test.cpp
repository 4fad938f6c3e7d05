// Trinamic PACK contract cases of §8.3 (motion): exact request bytes on a real pty, replies
// compared exactly in both framings (G-01), durations from the injected clock (±2 %).
#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

const Bytes kRamp0To100k = {0x01, 0x23, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00};

// Cases that compare several motors at one instant query without the switchover step, so the
// clock stands still between the queries (the PACK's replies are computed on receipt anyway).
void NoTurnaround(ServerOptions& o) { o.turnaround = false; }

double Seconds(Duration d) { return ToSeconds(d); }

// CT-21 "Trapezoidal ramp completes exactly" — target PACK — L60, L545-561, L689-701, L489-495:
// "When `01 23 00 A0 86 01 00 00 00` (motor 0 → 100 000). Then during motion `$20` reports action
// 5, the maximum `$21` velocity is 511 (25 990.8 µsteps/s), motion ends after 4.35 s ± 2 %, and
// `$20` returns body `20 00 A0 86 01 00 00 00`."
TEST(TrinamicPack, CT21_TrapezoidalRampCompletesExactly) {
  ForBothFramings([](PackLine& line) {
    line.Write(kRamp0To100k);
    const TimePoint t0 = line.clock.Now();
    int vmax = 0;
    Bytes body;
    while (line.clock.Now() - t0 < 10s) {
      body = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});  // each query: +6 ms
      ASSERT_EQ(body.size(), 8u);
      if (body[6] == 0) break;
      ASSERT_EQ(body[6], 5) << "action during the ramp";
      vmax = std::max(vmax, line.Velocity(0));
    }
    const double t = Seconds(line.clock.Now() - t0);
    EXPECT_EQ(vmax, 511);
    EXPECT_NEAR(t, 4.35, 4.35 * 0.02);
    EXPECT_EQ(line.Wire(body), line.Wire({0x20, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00}));
  });
}

// CT-22 "Acceleration rate" — target PACK — L557-559, L713: "When `01 25 00 FF 01 00 00 00 00`
// (rotate motor 0 at +511) from standstill. Then the velocity starts at vstart (5), never
// increases by more than 2 per 2 ms, and reaches 511 after 0.506 s ± 0.01 s."
TEST(TrinamicPack, CT22_AccelerationRate) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    line.Write({0x01, 0x25, 0x00, 0xFF, 0x01, 0x00, 0x00, 0x00, 0x00});
    const TimePoint t0 = line.clock.Now();
    line.Advance(2ms);
    int v = line.Velocity(0);
    EXPECT_EQ(v, 5) << "first tick at vstart (L545)";
    while (v < 511 && line.clock.Now() - t0 < 1s) {
      line.Advance(2ms);
      const int next = line.Velocity(0);
      ASSERT_GE(next, v);
      ASSERT_LE(next - v, 2) << "amax/64 = 2 per 2 ms (L557)";
      v = next;
    }
    EXPECT_EQ(v, 511);
    EXPECT_NEAR(Seconds(line.clock.Now() - t0), 0.506, 0.01);
  });
}

// CT-23 "Ramp start ignored while active" — target PACK — L691: "Given motor 0 ramping to 100 000
// (action 5). When `01 23 00 00 00 00 00 00 00` (target 0). Then motor 0 still ends at 100 000."
TEST(TrinamicPack, CT23_RampStartIgnoredWhileActive) {
  ForBothFramings([](PackLine& line) {
    line.Write(kRamp0To100k);
    line.Advance(1s);
    ASSERT_EQ(line.Action(0), 5);
    line.Write({0x01, 0x23, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    line.RunUntilIdle(0);
    EXPECT_EQ(line.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00}));
  });
}

// CT-24 "On-the-fly target change" — target PACK — L691, L722: "Given motor 0 ramping to 100 000
// and past position 20 000. When `01 26 00 50 C3 00 00 00 00` (50 000). Then motor 0 ends at
// 50 000, action 0."
TEST(TrinamicPack, CT24_OnTheFlyTargetChange) {
  ForBothFramings([](PackLine& line) {
    line.Write(kRamp0To100k);
    while (line.Position(0) <= 20000) line.Advance(50ms);
    line.Write({0x01, 0x26, 0x00, 0x50, 0xC3, 0x00, 0x00, 0x00, 0x00});
    line.RunUntilIdle(0);
    EXPECT_EQ(line.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x00, 0x50, 0xC3, 0x00, 0x00, 0x00, 0x00}));
  });
}

// CT-25 "Late target change overshoots and returns" — target PACK — L722: "Given motor 0 at vmax
// heading for 100 000. When `$26` sets a target 100 µsteps ahead of the current position. Then the
// motor decelerates with amax, passes the target, reverses and ends exactly at the target."
TEST(TrinamicPack, CT25_LateTargetChangeOvershootsAndReturns) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    line.Write(kRamp0To100k);
    line.Advance(1500ms);
    ASSERT_EQ(line.Velocity(0), 511) << "at vmax";
    const int32_t target = line.Position(0) + 100;
    line.Write(Word32(0x26, 0, target));
    int v = 511;
    int32_t farthest = target;
    bool reversed = false;
    for (int i = 0; i < 2000 && line.Action(0) != 0; ++i) {
      line.Advance(2ms);
      const int next = line.Velocity(0);
      if (next < 0 && v >= 0) {
        // The turn: braked down to vstart, then off again at −vstart (L545, §5.4).
        ASSERT_LE(v, 5 + 2);
        ASSERT_EQ(next, -5);
        reversed = true;
      } else if (!reversed) {
        ASSERT_LE(std::abs(next - v), 2) << "decelerates with amax/64 per 2 ms (L557)";
      }
      v = next;
      farthest = std::max(farthest, line.Position(0));
    }
    EXPECT_GT(farthest, target) << "passes the target";
    EXPECT_TRUE(reversed) << "reverses";
    EXPECT_EQ(line.Body(QueryWord(0x20, 0)), Body20(0, target));
  });
}

// CT-26 "`$26` alone does not start a standing motor; `$26` + `$23` does" — target PACK — L691,
// L722: "Given motor 0 standing at 0. When `01 26 00 10 27 00 00 00 00`. Then after 200 ms motor 0
// is still at 0, action 0. When `01 23 00 10 27 00 00 00 00` follows. Then motor 0 ends at 10 000."
TEST(TrinamicPack, CT26_SetTargetAloneDoesNotStart) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x26, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00});
    line.Advance(200ms);
    EXPECT_EQ(line.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
    line.Write({0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00});
    line.RunUntilIdle(0);
    EXPECT_EQ(line.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00}));
  });
}

// CT-27 "Ramp command stops a rotation" — target PACK — L693: "Given motor 0 rotating at +300
// (action 15). When `01 23 00 10 27 00 00 00 00`. Then the velocity falls to 0, action becomes 0,
// and the motor does not continue towards 10 000."
TEST(TrinamicPack, CT27_RampCommandStopsRotation) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
    line.Advance(1s);
    ASSERT_EQ(line.Action(0), 15);
    const int32_t before = line.Position(0);
    ASSERT_GT(before, 10000) << "already past 10 000, so a ramp would turn back";
    line.Write({0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00});
    line.Advance(1s);
    EXPECT_EQ(line.Query({0x01, 0x21, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x21, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
    const int32_t stopped = line.Position(0);
    EXPECT_GE(stopped, before) << "did not turn towards 10 000";
    line.Advance(1s);
    EXPECT_EQ(line.Position(0), stopped);
  });
}

// CT-28 "Rotation overrides an active ramp" — target PACK — L713: "Given motor 0 ramping to
// 100 000. When `01 25 00 38 FF 00 00 00 00` (−200). Then the next `$20`/`$21` shows action 15 and
// the velocity moves towards −200 by at most amax/64 per 2 ms."
TEST(TrinamicPack, CT28_RotationOverridesActiveRamp) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    line.Write(kRamp0To100k);
    line.Advance(500ms);
    int v = line.Velocity(0);
    ASSERT_GT(v, 0);
    line.Write({0x01, 0x25, 0x00, 0x38, 0xFF, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(line.Action(0), 15);
    for (int i = 0; i < 500 && v != -200; ++i) {
      line.Advance(2ms);
      const Bytes body = line.Body({0x01, 0x21, 0x00, 0xF0, 0, 0, 0, 0, 0});
      ASSERT_EQ(body.size(), 8u);
      EXPECT_EQ(body[4], 15);
      const int next = BodyI16(body, 2);
      ASSERT_LE(next, v) << "towards -200";
      // From standstill a reversal starts at vstart (L545); otherwise |dv| <= amax/64 = 2.
      if (!(v > 0 && next < 0)) {
        ASSERT_LE(v - next, 2);
      }
      v = next;
    }
    EXPECT_EQ(v, -200);
  });
}

// CT-29 "Selective stop" — target PACK — L765-771: "Given motors 0, 1, 2 ramping towards 100 000
// at v > vstart. When `01 2A 03 00 00 00 00 00 00`. Then motors 0 and 1 end exactly at the
// positions they had when the command was executed (after overshoot and return) and motor 2
// continues to 100 000."
TEST(TrinamicPack, CT29_SelectiveStop) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    for (uint8_t m : {0, 1, 2}) line.Write(Word32(0x23, m, 100000));
    line.Advance(500ms);
    ASSERT_GT(line.Velocity(0), 5);
    const int32_t p0 = line.Position(0);
    const int32_t p1 = line.Position(1);
    line.Write({0x01, 0x2A, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    line.RunUntilIdle(2);
    line.RunUntilIdle(0);
    line.RunUntilIdle(1);
    EXPECT_EQ(line.Body(QueryWord(0x20, 0)), Body20(0, p0));
    EXPECT_EQ(line.Body(QueryWord(0x20, 1)), Body20(1, p1));
    EXPECT_EQ(line.Body(QueryWord(0x20, 2)), Body20(2, 100000));
  });
}

// CT-30 "Parallel start" — target PACK — L758-763: "Given `01 26 00 E8 03 00 00 00 00`,
// `01 26 01 D0 07 00 00 00 00`, `01 26 02 B8 0B 00 00 00 00` (targets 1000, 2000, 3000; motors
// standing). When `01 29 07 00 00 00 00 00 00`. Then motors 0-2 leave action 0 in the same 2 ms
// tick and end at 1000, 2000, 3000; motor 3 is untouched."
TEST(TrinamicPack, CT30_ParallelStart) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    line.Write({0x01, 0x26, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x26, 0x01, 0xD0, 0x07, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x26, 0x02, 0xB8, 0x0B, 0x00, 0x00, 0x00, 0x00});
    line.Advance(10ms);
    const Bytes idle = {0x28, 0, 0, 0, 0, 0, 0, 0};
    EXPECT_EQ(line.Body({0x01, 0x28, 0xF0, 0x00, 0, 0, 0, 0, 0}), idle);
    line.Write({0x01, 0x29, 0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(line.Body({0x01, 0x28, 0xF0, 0x00, 0, 0, 0, 0, 0}),
              Bytes({0x28, 0x05, 0x05, 0x05, 0x00, 0x00, 0x00, 0x00}));
    line.RunUntilIdle(2, 20ms);
    line.RunUntilIdle(1, 20ms);
    line.RunUntilIdle(0, 20ms);
    EXPECT_EQ(line.Body(QueryWord(0x20, 0)), Body20(0, 1000));
    EXPECT_EQ(line.Body(QueryWord(0x20, 1)), Body20(1, 2000));
    EXPECT_EQ(line.Body(QueryWord(0x20, 2)), Body20(2, 3000));
    EXPECT_EQ(line.Body(QueryWord(0x20, 3)), Body20(3, 0));
  });
}

// CT-31 "Two-axis linear interpolation (chapter 7 example)" — target PACK — L443-469, L904-912:
// "When `01 26 00 E8 03 00 00 00 00`, `01 26 01 D0 07 00 00 00 00`, `01 50 03 00 00 00 00 00 00`.
// Then motors 0 and 1 become inactive in the same 2 ms tick (hardware: within 10 ms), end at 1000
// and 2000, and every intermediate sample satisfies `|pos1 − 2 × pos0| ≤ 2`."
TEST(TrinamicPack, CT31_TwoAxisLinearInterpolation) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    line.Write({0x01, 0x26, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x26, 0x01, 0xD0, 0x07, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x50, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    int samples = 0;
    for (; samples < 5000; ++samples) {
      line.Advance(2ms);
      const Bytes b0 = line.Body(QueryWord(0x20, 0));
      const Bytes b1 = line.Body(QueryWord(0x20, 1));
      ASSERT_EQ(b0.size(), 8u);
      ASSERT_EQ(b1.size(), 8u);
      ASSERT_LE(std::abs(BodyI32(b1, 2) - 2 * BodyI32(b0, 2)), 2) << "sample " << samples;
      ASSERT_EQ(b0[6] == 0, b1[6] == 0) << "inactive in different ticks, sample " << samples;
      if (b0[6] == 0) break;
    }
    EXPECT_GT(samples, 10);
    EXPECT_EQ(line.Body(QueryWord(0x20, 0)), Body20(0, 1000));
    EXPECT_EQ(line.Body(QueryWord(0x20, 1)), Body20(1, 2000));
  });
}

// CT-32 "Set actual position" — target PACK — L728-734: "When `01 27 03 88 13 00 00 00 00`. Then
// `01 20 03 F0 00 00 00 00 00` returns body `20 03 88 13 00 00 00 00`."
TEST(TrinamicPack, CT32_SetActualPosition) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x27, 0x03, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(line.Query({0x01, 0x20, 0x03, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x03, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00}));
  });
}

// The analogue-stop setup of CT-33..35: `01 15 00 00 19 00 00 40 <P6>`, `01 31 00 64 00 84 03 00
// 00` (channel 0: left limit 100, right limit 900), channel 0 value 500, motor 0 at +300.
void AnalogStopSetup(PackLine& line, uint8_t p6) {
  line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x40, p6});
  line.Write({0x01, 0x31, 0x00, 0x64, 0x00, 0x84, 0x03, 0x00, 0x00});
  line.WithUnit(0, [](Controller& c) { c.SetAnalog(0, 500); });
  line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
  line.Advance(500ms);
  ASSERT_EQ(line.Velocity(0), 300);
  line.WithUnit(0, [](Controller& c) { c.SetAnalog(0, 901); });
}

// CT-33 "Analogue stop, hard, without reference search" — target PACK — L794-801, L581-584,
// L593-599: "Given `01 15 00 00 19 00 00 40 20` (StopNull; StopNoRef), `01 31 00 64 00 84 03 00
// 00` (channel 0: left limit 100, right limit 900), channel 0 value 500, motor 0 rotating at +300.
// When the channel 0 value becomes 901. Then within one 2 ms tick the velocity is 0, action 0,
// and the next `$20` body has byte 7 = `01`."
TEST(TrinamicPack, CT33_AnalogueStopHardWithoutReference) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    AnalogStopSetup(line, 0x20);
    line.Advance(2ms);
    EXPECT_EQ(line.Query({0x01, 0x21, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x21, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
    const Bytes body = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
    ASSERT_EQ(body.size(), 8u);
    EXPECT_EQ(body[6], 0x00);
    EXPECT_EQ(body[7], 0x01);
  });
}

// CT-34 "Analogue stop, hard, with automatic reference search" — target PACK — L796, L582, L598:
// "As CT-33 but `01 15 00 00 19 00 00 40 00` (StopNoRef clear). Then after the stop the action
// enters 20..29 (reference search) without a further command."
TEST(TrinamicPack, CT34_AnalogueStopHardWithReferenceSearch) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    AnalogStopSetup(line, 0x00);
    line.Advance(2ms);
    const int action = line.Action(0);
    EXPECT_GE(action, 20);
    EXPECT_LE(action, 29);
  });
}

// CT-35 "Analogue stop, soft" — target PACK — L594-596, L796: "As CT-33 but `01 15 00 00 19 00 00
// 40 30` (StopSoft + StopNoRef). Then the velocity decreases by at most amax/64 per 2 ms until 0,
// and the stop flag is set."
TEST(TrinamicPack, CT35_AnalogueStopSoft) {
  ForBothFramings(NoTurnaround, [](PackLine& line) {
    AnalogStopSetup(line, 0x30);
    int v = 300;
    int ticks = 0;
    while (v != 0 && ticks < 1000) {
      line.Advance(2ms);
      ++ticks;
      const int next = line.Velocity(0);
      ASSERT_LE(next, v);
      // Like every ramp the stop ends at vstart: the last step drops from below vstart + amax/64
      // to 0 (L545, §5.4); before that at most amax/64 = 2 per 2 ms (L557).
      if (next != 0 || v > 5 + 2) {
        ASSERT_LE(v - next, 2) << "amax/64 = 2 per 2 ms";
      }
      v = next;
    }
    EXPECT_EQ(v, 0);
    EXPECT_GT(ticks, 100) << "a soft stop, not an abrupt one";
    const Bytes body = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
    ASSERT_EQ(body.size(), 8u);
    EXPECT_EQ(body[6], 0x00);
    EXPECT_EQ(body[7], 0x01);
  });
}

// CT-36 "Rotary axis wraps" — target PACK — L570, L695-698, L713: "Given `01 15 00 00 19 00 00 12
// 00` (rotary, NullLeft, poslimit 6400) and `01 27 00 70 17 00 00 00 00` (6000). When
// `01 25 00 64 00 00 00 00 00` (+100) for 1 s. Then every `$20` position lies in 0 … 6399 and the
// sequence wraps from ≥ 6000 to < 400."
TEST(TrinamicPack, CT36_RotaryAxisWraps) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x12, 0x00});
    line.Write({0x01, 0x27, 0x00, 0x70, 0x17, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x25, 0x00, 0x64, 0x00, 0x00, 0x00, 0x00, 0x00});
    const TimePoint t0 = line.clock.Now();
    int32_t previous = 6000;
    int wraps = 0;
    while (line.clock.Now() - t0 < 1s) {
      line.Advance(14ms);  // + 6 ms switchover per query: a sample every 20 ms
      const int32_t p = line.Position(0);
      ASSERT_GE(p, 0);
      ASSERT_LE(p, 6399);
      if (p < previous) {
        EXPECT_GE(previous, 6000);
        EXPECT_LT(p, 400);
        ++wraps;
      }
      previous = p;
    }
    EXPECT_GE(wraps, 1);
  });
}

// CT-37 "PI controller" — target PACK — L703-709, L636-645: "When `01 24 00 E8 03 00 00 00 00` on
// inactive motor 0. Then the next `$20` reports action 10 (`0A`) and the position converges to
// 1000 (|error| ≤ 1 after 2 s)."
TEST(TrinamicPack, CT37_PiController) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x24, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(line.Action(0), 0x0A);
    line.Advance(2s);
    const Bytes body = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
    ASSERT_EQ(body.size(), 8u);
    EXPECT_LE(std::abs(BodyI32(body, 2) - 1000), 1);
    EXPECT_EQ(body[6], 0x0A);
  });
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
