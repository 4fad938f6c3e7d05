// Trinamic PACK contract cases of §8.2 (status queries) plus CT-48 (power-down mode): exact
// request bytes on a real pty, reply bytes compared exactly in both framings (G-01).
#include <cstdint>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

// CT-12 "Position query" — target PACK — L649-663, L431-441: "Given motor 2 set to −1234 with
// `01 27 02 2E FB FF FF 00 00`. When `01 20 02 F0 00 00 00 00 00`. Then body
// `20 02 2E FB FF FF 00 00`."
TEST(TrinamicPack, CT12_PositionQuery) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x27, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00});
    EXPECT_EQ(line.Query({0x01, 0x20, 0x02, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00}));
  });
}

// CT-13 "Stop flag is cleared on read" — target PACK — L663: "Given a stop condition has occurred
// on motor 0 (as in CT-33). When `01 20 00 F0 00 00 00 00 00` is sent twice. Then the first body
// has byte 7 = `01`, the second byte 7 = `00`."
TEST(TrinamicPack, CT13_StopFlagClearedOnRead) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x15, 0x00, 0x00, 0x19, 0x00, 0x00, 0x40, 0x20});  // StopNull; StopNoRef
    line.Write({0x01, 0x31, 0x00, 0x64, 0x00, 0x84, 0x03, 0x00, 0x00});  // limits 100 / 900
    line.WithUnit(0, [](Controller& c) { c.SetAnalog(0, 500); });
    line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});  // rotate +300
    line.Advance(500ms);
    line.WithUnit(0, [](Controller& c) { c.SetAnalog(0, 901); });
    line.Advance(10ms);
    const Bytes first = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
    const Bytes second = line.Body({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
    ASSERT_EQ(first.size(), 8u);
    ASSERT_EQ(second.size(), 8u);
    EXPECT_EQ(first[7], 0x01);
    EXPECT_EQ(second[7], 0x00);
    EXPECT_EQ(Bytes(first.begin(), first.begin() + 7), Bytes(second.begin(), second.begin() + 7))
        << "only the stop flag differs";
  });
}

// CT-14 "Velocity query while rotating" — target PACK — L665-676, L711-718: "When
// `01 25 01 2C 01 00 00 00 00` (motor 1, +300) and 0.4 s elapse. Then `01 21 01 F0 00 00 00 00 00`
// returns body `21 01 2C 01 0F 00 00 00`. When `01 25 01 D4 FE 00 00 00 00` (−300) and 0.8 s
// elapse. Then the body is `21 01 D4 FE 0F 00 00 00`."
TEST(TrinamicPack, CT14_VelocityQueryWhileRotating) {
  ForBothFramings([](PackLine& line) {
    const Bytes query = {0x01, 0x21, 0x01, 0xF0, 0, 0, 0, 0, 0};
    line.Write({0x01, 0x25, 0x01, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
    line.Advance(400ms);
    EXPECT_EQ(line.Query(query), line.Wire({0x21, 0x01, 0x2C, 0x01, 0x0F, 0x00, 0x00, 0x00}));
    line.Write({0x01, 0x25, 0x01, 0xD4, 0xFE, 0x00, 0x00, 0x00, 0x00});
    line.Advance(800ms);
    EXPECT_EQ(line.Query(query), line.Wire({0x21, 0x01, 0xD4, 0xFE, 0x0F, 0x00, 0x00, 0x00}));
  });
}

// CT-15 "All-motor activity, immediate" — target PACK — L738-756: "Given motor 0 in a ramp
// (`01 23 00 A0 86 01 00 00 00`) and motor 1 rotating (`01 25 01 2C 01 00 00 00 00`). When
// `01 28 F0 00 00 00 00 00 00`. Then body bytes 0-6 are `28 05 0F 00 00 00 00`." Byte 7 is
// undefined and sent as 00 (G-02).
TEST(TrinamicPack, CT15_AllMotorActivityImmediate) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x23, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x25, 0x01, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
    line.Advance(100ms);
    EXPECT_EQ(line.Query({0x01, 0x28, 0xF0, 0x00, 0, 0, 0, 0, 0}),
              line.Wire({0x28, 0x05, 0x0F, 0x00, 0x00, 0x00, 0x00, 0x00}));
  });
}

// CT-16 "All-motor activity, delayed" — target PACK — L740: "Given motor 0 moving to 100 000
// (≈ 4.35 s). When `01 28 F0 01 00 00 00 00 00`. Then no reply arrives while motor 0 is active,
// and a reply with body bytes 0-6 `28 00 00 00 00 00 00` starts within 10 ms plus the switchover
// time (6 ms) after motor 0 became inactive."
TEST(TrinamicPack, CT16_AllMotorActivityDelayed) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x23, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});
    line.Write({0x01, 0x28, 0xF0, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00});
    auto active = [&] {
      bool a = false;
      line.WithUnit(0, [&](Controller& c) { a = c.state(0).action != Action::kInactive; });
      return a;
    };
    for (int i = 0; i < 21; ++i) {  // 4.2 s, motor 0 still ramping
      line.Advance(200ms);
      ASSERT_TRUE(active());
      ASSERT_TRUE(line.Drain(5ms).empty()) << "delayed reply while motor 0 is active";
    }
    while (active() && line.clock.Now().time_since_epoch() < 10s) {
      line.Advance(2ms);
      if (active()) {
        ASSERT_TRUE(line.Drain(5ms).empty()) << "delayed reply while motor 0 active";
      }
    }
    const TimePoint inactive_seen = line.clock.Now();  // the tick ended within the last 2 ms
    // The server writes a due reply synchronously inside Advance (Settle), so its reply counter
    // tells the clock time of sending; the bytes are then read with a generous real deadline.
    const uint64_t sent_before = line.server->counters().replies;
    while (line.server->counters().replies == sent_before &&
           line.clock.Now() - inactive_seen <= 16ms) {
      line.Advance(2ms);
    }
    auto read = line.port->ReadExactly(line.framing() == ReplyFraming::kR9 ? 9 : 8, 2s);
    ASSERT_TRUE(read.ok()) << read.status();
    const Bytes reply = *read;
    EXPECT_EQ(reply, line.Wire({0x28, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
    EXPECT_LE(line.clock.Now() - inactive_seen, 16ms) << "10 ms + switchover 6 ms (L740, L283)";
  });
}

// CT-18 "Unit information and reset flag" — target PACK — L845-855: "Given a freshly reset
// simulator with firmware 148, serial number `0x1234`, temperature 31 °C. When
// `01 43 F0 00 00 00 00 00 00` is sent twice. Then the bodies are `43 94 01 1F 34 12 00 00` and
// `43 94 00 1F 34 12 00 00`."
TEST(TrinamicPack, CT18_UnitInformationAndResetFlag) {
  ForBothFramings(
      [](ServerOptions& o) {
        o.controller.firmware = 148;
        o.controller.serial_number = 0x1234;
        o.controller.temperature_c = 31;
      },
      [](PackLine& line) {
        const Bytes query = {0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0};
        EXPECT_EQ(line.Query(query), line.Wire({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
        EXPECT_EQ(line.Query(query), line.Wire({0x43, 0x94, 0x00, 0x1F, 0x34, 0x12, 0x00, 0x00}));
      });
}

// CT-19 "Supply voltage channel" — target PACK — L779-788: "Given supply 24.0 V. When
// `01 30 07 F0 00 00 00 00 00`. Then body bytes 0-3 are `30 07 10 02` (528 = 24 × 22). Given
// supply 13.0 V, then bytes 2-3 are `1E 01` (286)."
TEST(TrinamicPack, CT19_SupplyVoltageChannel) {
  ForBothFramings([](PackLine& line) {
    const Bytes query = {0x01, 0x30, 0x07, 0xF0, 0, 0, 0, 0, 0};
    Bytes body = line.Body(query);
    ASSERT_EQ(body.size(), 8u);
    EXPECT_EQ(Bytes(body.begin(), body.begin() + 4), Bytes({0x30, 0x07, 0x10, 0x02}));
    line.WithUnit(0, [](Controller& c) { c.SetSupplyVolts(13.0); });
    body = line.Body(query);
    ASSERT_EQ(body.size(), 8u);
    EXPECT_EQ(Bytes(body.begin() + 2, body.begin() + 4), Bytes({0x1E, 0x01}));
  });
}

// CT-20 "Jumper bits" — target PACK (the adapter's bit-rate report is its own case) —
// L293-305, L790: "Given jumpers JP1 and JP2 both set (1 Mbit/s). When any `$30` query. Then body
// byte 5 (P4) bits 6 and 7 both show the "set" state (polarity per G-19)". G-19: 1 = set.
TEST(TrinamicPack, CT20_JumperBits) {
  ForBothFramings(
      [](ServerOptions& o) {
        o.controller.jumper1 = true;
        o.controller.jumper2 = true;
      },
      [](PackLine& line) {
        for (uint8_t channel : {0, 3, 7}) {
          const Bytes body = line.Body({0x01, 0x30, channel, 0xF0, 0, 0, 0, 0, 0});
          ASSERT_EQ(body.size(), 8u);
          EXPECT_EQ(body[5] & 0xC0, 0xC0) << "channel " << int{channel};
        }
      });
  // Both jumpers open (250 kbit/s default): both bits clear, so the case above can fail.
  ForBothFramings([](PackLine& line) {
    const Bytes body = line.Body({0x01, 0x30, 0x00, 0xF0, 0, 0, 0, 0, 0});
    ASSERT_EQ(body.size(), 8u);
    EXPECT_EQ(body[5] & 0xC0, 0x00);
  });
}

// CT-48 "Power-down mode" — target PACK — L873-893: "Given a simulator with firmware 149. When
// `01 45 F0 04 00 00 00 00 00` (activate). Then body byte 1 bit 2 (state before) and bit 3 (state
// after) are 0. When the supply falls to 12.5 V. Then all motors stop and
// `01 45 F0 00 00 00 00 00 00` returns byte 1 with bits 2 and 3 set. When the supply returns to
// 24 V and `01 45 F0 08 00 00 00 00 00` is sent. Then byte 1 bit 2 = 1 and bit 3 = 0 and motors
// accept motion commands again."
TEST(TrinamicPack, CT48_PowerDownMode) {
  ForBothFramings([](ServerOptions& o) { o.controller.firmware = 149; },
                  [](PackLine& line) {
                    Bytes body = line.Body({0x01, 0x45, 0xF0, 0x04, 0, 0, 0, 0, 0});
                    ASSERT_EQ(body.size(), 8u);
                    EXPECT_EQ(body[0], 0x45);
                    EXPECT_EQ(body[1] & 0x0C, 0x00);
                    line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
                    line.Write({0x01, 0x23, 0x02, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});
                    line.Advance(500ms);
                    ASSERT_EQ(line.Velocity(0), 300);
                    line.WithUnit(0, [](Controller& c) { c.SetSupplyVolts(12.5); });
                    line.Advance(2ms);
                    EXPECT_EQ(line.Body({0x01, 0x28, 0xF0, 0x00, 0, 0, 0, 0, 0}),
                              Bytes({0x28, 0, 0, 0, 0, 0, 0, 0}))
                        << "all motors stopped";
                    body = line.Body({0x01, 0x45, 0xF0, 0x00, 0, 0, 0, 0, 0});
                    ASSERT_EQ(body.size(), 8u);
                    EXPECT_EQ(body[1] & 0x0C, 0x0C);
                    line.WithUnit(0, [](Controller& c) { c.SetSupplyVolts(24.0); });
                    body = line.Body({0x01, 0x45, 0xF0, 0x08, 0, 0, 0, 0, 0});
                    ASSERT_EQ(body.size(), 8u);
                    EXPECT_EQ(body[1] & 0x0C, 0x04);
                    line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
                    line.Advance(500ms);
                    EXPECT_EQ(line.Velocity(0), 300) << "motion accepted again";
                  });
}

// Counter-check of CT-48: while the power-down state holds, a motion command is not executed.
TEST(TrinamicPack, CT48_MotorsHeldWhilePoweredDown) {
  ForBothFramings([](ServerOptions& o) { o.controller.firmware = 149; },
                  [](PackLine& line) {
                    line.Body({0x01, 0x45, 0xF0, 0x04, 0, 0, 0, 0, 0});
                    line.WithUnit(0, [](Controller& c) { c.SetSupplyVolts(12.5); });
                    line.Advance(2ms);
                    line.Write({0x01, 0x25, 0x00, 0x2C, 0x01, 0x00, 0x00, 0x00, 0x00});
                    line.Advance(500ms);
                    EXPECT_EQ(line.Velocity(0), 0);
                  });
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
