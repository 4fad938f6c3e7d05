// Trinamic PACK contract cases of §8.4 (reference search): exact request bytes on a real pty,
// replies compared exactly in both framings (G-01); the switch lives in the simulator's world
// model (§1.4, §7), whose rotor position is read by introspection.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

bool Homing(int action) { return action >= 20 && action <= 29; }

// Reference switch active for physical positions <= -1000 relative to the start (CT-38).
void SwitchBelowMinus1000(ServerOptions& o) {
  o.controller.world[0].has_switch = true;
  o.controller.world[0].switch_low = -1'000'000'000;
  o.controller.world[0].switch_high = -1000;
}

int64_t Rotor(PackLine& line) {
  int64_t rotor = 0;
  line.WithUnit(0, [&](Controller& c) { rotor = c.state(0).rotor; });
  return rotor;
}

// CT-38 "Switch search with FastRef, stop after search" — target PACK — L678-685, L565, L588,
// L616: "Given the world model's reference switch is active for physical positions ≤ −1000
// (relative to the start), `01 15 00 00 19 00 00 10 02` (NullLeft; FastRef; no FilterSwitch;
// polarity matched to the world model), `01 16 00 64 00 FF 0F 01 00` (stop after search). When
// `01 22 00 00 00 00 00 00 00`. Then `$20` reports action codes within 20..29 until completion,
// the 7-segment decimal point is lit meanwhile, and finally action 0 with the zero point at the
// physical switch edge (±1 µstep)."
TEST(TrinamicPack, CT38_SwitchSearchFastRefStopAfterSearch) {
  ForBothFramings(SwitchBelowMinus1000, [](PackLine& line) {
    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x10, 0x02});
    line.Write({0x01, 0x16, 0x00, 0x64, 0x00, 0xFF, 0x0F, 0x01, 0x00});
    line.Write({0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    int samples = 0;
    while (samples < 2000) {
      // The display is read at the instant the `$20` query is received (its reply is computed
      // then, and sent after the switchover).
      bool point = false;
      line.WithUnit(0, [&](Controller& c) { point = c.DisplayPoint(); });
      const int action = line.Action(0);
      if (action == 0) {
        EXPECT_FALSE(point) << "decimal point after the search";
        break;
      }
      ASSERT_TRUE(Homing(action)) << "action " << action;
      ASSERT_TRUE(point) << "decimal point during the search (L66)";
      line.Advance(20ms);
      ++samples;
    }
    EXPECT_GT(samples, 5);
    // Stop after search: the motor ramps to the new zero, which is the switch edge (L616, G-12).
    EXPECT_EQ(line.Body(QueryWord(0x20, 0)), Body20(0, 0));
    EXPECT_LE(std::abs(Rotor(line) - (-1000)), 1) << "zero point at the switch edge";
  });
}

// CT-39 "`$15` AutoNullCmd starts the same search" — target PACK — L574-575, L682: "When
// `01 15 00 00 19 00 00 14 02` (NullLeft + AutoNullCmd; FastRef). Then the action enters 20..29
// exactly as with `$22`."
TEST(TrinamicPack, CT39_AutoNullCmdStartsSameSearch) {
  for (ReplyFraming framing : {ReplyFraming::kR8, ReplyFraming::kR9}) {
    SCOPED_TRACE(FramingName(framing));
    ServerOptions o = CommonSetup(framing);
    SwitchBelowMinus1000(o);
    PackLine with_15(o);
    o.pty_path.clear();
    PackLine with_22(o);
    ASSERT_TRUE(with_15.ok() && with_22.ok());
    with_15.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x14, 0x02});
    with_22.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x10, 0x02});
    with_22.Write({0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    bool entered = false;
    for (int i = 0; i < 150; ++i) {
      const Bytes a = with_15.Body(QueryWord(0x20, 0));
      const Bytes b = with_22.Body(QueryWord(0x20, 0));
      ASSERT_EQ(a, b) << "sample " << i;
      ASSERT_EQ(a.size(), 8u);
      entered = entered || Homing(a[6]);
      with_15.Advance(14ms);
      with_22.Advance(14ms);
    }
    EXPECT_TRUE(entered);
  }
}

// CT-40 "Resume previous position after search" — target PACK — L680, L616: "As CT-38 but `$16`
// P5 = 0 (`01 16 00 64 00 FF 0F 00 00`) and `01 27 00 88 13 00 00 00 00` (5000) before the search.
// Then after referencing the motor drives to position 5000 of the new coordinate system and ends
// with action 0 (`$20` body `20 00 88 13 00 00 00 00`)."
TEST(TrinamicPack, CT40_ResumePreviousPositionAfterSearch) {
  ForBothFramings(SwitchBelowMinus1000, [](PackLine& line) {
    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x10, 0x02});
    line.Write({0x01, 0x16, 0x00, 0x64, 0x00, 0xFF, 0x0F, 0x00, 0x00});
    line.Write({0x01, 0x27, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    line.Advance(20ms);
    EXPECT_TRUE(Homing(line.Action(0)));
    line.RunUntilIdle(0, 50ms);
    EXPECT_EQ(line.Query(QueryWord(0x20, 0)),
              line.Wire({0x20, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00}));
    EXPECT_LE(std::abs(Rotor(line) - (-1000 + 5000)), 1) << "5000 from the switch edge";
  });
}

// CT-41 "Search repeats when no switch is found" — target PACK — L680: "Given no switch anywhere
// and `01 15 00 00 19 00 00 10 02` (poslimit 6400, NullLeft, FastRef). When `$22` for motor 0.
// Then in each search pass the motor travels at most 8000 µsteps (1.25 × 6400) plus its braking
// distance (≈ 254 µsteps from vrefmax 100 with defaults) before stopping and restarting, and the
// action stays within 20..29 for at least three passes."
TEST(TrinamicPack, CT41_SearchRepeatsWithoutSwitch) {
  ForBothFramings([](ServerOptions& o) { o.controller.world[0].has_switch = false; },
                  [](PackLine& line) {
                    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x10, 0x02});
                    line.Write({0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
                    // A pass starts where the search restarts after a stop (action 20 -> 21,
                    // §5.7); samples every 6 ms (the switchover step of each query), so each
                    // restart position is seen at most 6 ms × 5086 µsteps/s ≈ 31 µsteps late.
                    std::vector<int32_t> restarts;
                    int previous_action = 20;
                    for (int i = 0; i < 2500 && restarts.size() < 4; ++i) {
                      const Bytes body = line.Body(QueryWord(0x20, 0));
                      ASSERT_EQ(body.size(), 8u);
                      ASSERT_TRUE(Homing(body[6])) << "action " << int{body[6]};
                      if (previous_action == 20 && body[6] == 21) {
                        restarts.push_back(BodyI32(body, 2));
                      }
                      previous_action = body[6];
                    }
                    ASSERT_GE(restarts.size(), 4u) << "at least three passes";
                    for (size_t k = 1; k < restarts.size(); ++k) {
                      const int32_t travel = restarts[k - 1] - restarts[k];  // leftwards
                      EXPECT_GT(travel, 8000) << "pass " << k;
                      EXPECT_LE(travel, 8000 + 254 + 40) << "pass " << k;
                    }
                  });
}

// CT-42 "Mechanical reference" — target PACK — L570-571, L589-590, L662: "Given
// `01 15 00 00 19 00 00 10 04` (NullLeft; MechRef). When `$22`. Then `$20` reports action 30 while
// the motor drives 8000 µsteps in negative direction, then action 0 and position 0 (G-14)."
TEST(TrinamicPack, CT42_MechanicalReference) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x10, 0x04});
    line.Write({0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    line.Advance(20ms);
    int action = line.Action(0);
    int samples = 0;
    int32_t lowest = 0;
    while (action != 0 && samples < 500) {
      ASSERT_EQ(action, 30);
      const Bytes body = line.Body(QueryWord(0x20, 0));
      ASSERT_EQ(body.size(), 8u);
      lowest = std::min(lowest, BodyI32(body, 2));
      action = body[6];
      line.Advance(20ms);
      ++samples;
    }
    EXPECT_GT(samples, 3);
    EXPECT_LT(lowest, -7000) << "drove in negative direction";
    EXPECT_EQ(line.Query(QueryWord(0x20, 0)), line.Wire(Body20(0, 0)));
    EXPECT_EQ(Rotor(line), -8000) << "8000 µsteps = 5/4 × poslimit 6400 (L571)";
  });
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
