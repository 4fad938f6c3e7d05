// Trinamic PACK contract cases of §8.1 (framing and transport) plus CT-46/CT-47 (address change,
// hardware reset): exact request bytes on a real pty, reply bytes compared exactly in both reply
// framings R8 and R9 (G-01); time from the simulator's injected clock.
#include <cstdint>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

const Bytes kQueryPos0 = {0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0};
const Bytes kBodyPos0Zero = {0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
const Bytes kQueryInfo = {0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0};

// CT-02 "Little-endian, signed parameters" — target ADAPTER + PACK (this is the PACK half) —
// L475, L503, L701: "after the motion a `$20` query for motor 5 (`01 20 05 F0 00 00 00 00 00`)
// returns body `20 05 00 E7 FF FF 00 00`".
TEST(TrinamicPack, CT02_LittleEndianSigned_PackHalf) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x23, 0x05, 0x00, 0xE7, 0xFF, 0xFF, 0x00, 0x00});  // motor 5 -> -6400
    line.RunUntilIdle(5);
    EXPECT_EQ(line.Query({0x01, 0x20, 0x05, 0xF0, 0, 0, 0, 0, 0}),
              line.Wire({0x20, 0x05, 0x00, 0xE7, 0xFF, 0xFF, 0x00, 0x00}));
  });
}

// CT-03 "Incomplete word is not executed" — target PACK — L375: "When only the 8 bytes
// `01 27 00 88 13 00 00 00` are written. Then motor 0's position is unchanged: after 150 ms of
// silence `01 20 00 F0 00 00 00 00 00` returns body `20 00 00 00 00 00 00 00`."
TEST(TrinamicPack, CT03_IncompleteWordNotExecuted) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x41, 0x32, 0x00, 0, 0, 0, 0, 0});  // packet timeout 50 x 2 ms
    line.Write({0x01, 0x27, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00});
    line.Advance(150ms);
    EXPECT_EQ(line.Query(kQueryPos0), line.Wire(kBodyPos0Zero));
    EXPECT_EQ(line.server->counters().partial_timeouts, 1u);
  });
}

// CT-04 "Packet timeout discards a partial word" — target PACK — L279, L838: "When 5 bytes
// `01 27 00 88 13` are written, 150 ms pass, and then `01 20 00 F0 00 00 00 00 00` is written.
// Then the reply body is `20 00 00 00 00 00 00 00`."
TEST(TrinamicPack, CT04_PacketTimeoutDiscardsPartialWord) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x41, 0x32, 0x00, 0, 0, 0, 0, 0});
    line.Write({0x01, 0x27, 0x00, 0x88, 0x13});
    line.Advance(150ms);
    EXPECT_EQ(line.Query(kQueryPos0), line.Wire(kBodyPos0Zero));
  });
}

// Counter-check of CT-04: within the timeout the partial word is completed by the next bytes,
// so the case above can fail.
TEST(TrinamicPack, CT04_WithinTimeout_WordIsCompleted) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x41, 0x32, 0x00, 0, 0, 0, 0, 0});
    line.Write({0x01, 0x27, 0x00, 0x88, 0x13});
    line.Advance(50ms);
    line.Write({0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(line.Query(kQueryPos0), line.Wire({0x20, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00}));
  });
}

// CT-05 "Break aborts a partial word" — target PACK — L279: "Given the bytes `01 27 00 88` have
// been received. When a break is received (simulator: out-of-band break hook; hardware:
// `tcsendbreak`) followed by `01 20 00 F0 00 00 00 00 00`. Then the reply body is
// `20 00 00 00 00 00 00 00`."
TEST(TrinamicPack, CT05_BreakAbortsPartialWord) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x27, 0x00, 0x88});
    line.server->Break();  // a pty carries no break (§2.7, G-39)
    EXPECT_EQ(line.Query(kQueryPos0), line.Wire(kBodyPos0Zero));
    EXPECT_EQ(line.server->counters().breaks, 1u);
  });
}

// CT-06 "Address filtering on a multi-drop line" — target PACK — L273, L275, L281: "Given two
// simulated PACKs with addresses `01` and `02` on one simulated RS-485 line. When
// `02 27 00 88 13 00 00 00 00` is sent. Then `$20` for motor 0 returns position 5000
// (`88 13 00 00`) from PACK `02` and position 0 from PACK `01`, and PACK `01` sends nothing in
// response to the `02` word."
TEST(TrinamicPack, CT06_AddressFilteringMultiDrop) {
  ForBothFramings(
      [](ServerOptions& o) {
        ControllerOptions second = o.controller;
        second.address = 0x02;
        o.more_units.push_back(second);
      },
      [](PackLine& line) {
        line.Write({0x02, 0x27, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00});
        line.Advance(100ms);
        EXPECT_TRUE(line.Drain().empty()) << "a write command gets no reply from either PACK";
        EXPECT_EQ(line.Query({0x02, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
                  line.Wire({0x20, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00, 0x00}));
        EXPECT_EQ(line.Query(kQueryPos0), line.Wire(kBodyPos0Zero));
        EXPECT_TRUE(line.Drain().empty()) << "exactly one PACK answered each query";
      });
}

// CT-07 "Reply only after the switchover delay" — target PACK — L283, L833: "Given default
// switchover time 6 ms. When `01 43 F0 00 00 00 00 00 00` is completely received at `t0`. Then the
// first reply byte starts no earlier than `t0 + 6 ms`. When `01 40 41 00 0A 00 00 00 00` (divisor
// 65 unchanged, switchover 10 × 2 ms) is sent and the query is repeated, then the reply starts no
// earlier than 20 ms after the request."
TEST(TrinamicPack, CT07_ReplyOnlyAfterSwitchover) {
  ForBothFramings([](PackLine& line) {
    line.Write(kQueryInfo);  // completely received at t0 = clock now
    line.Advance(5ms);
    EXPECT_TRUE(line.Drain().empty()) << "reply before t0 + 6 ms";
    line.Advance(1ms);
    auto r = line.port->ReadExactly(line.framing() == ReplyFraming::kR9 ? 9 : 8, 2s);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(*r, line.Wire({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));

    line.Write({0x01, 0x40, 0x41, 0x00, 0x0A, 0x00, 0x00, 0x00, 0x00});
    line.Write(kQueryInfo);
    line.Advance(19ms);
    EXPECT_TRUE(line.Drain().empty()) << "reply before t0 + 20 ms";
    line.Advance(1ms);
    r = line.port->ReadExactly(line.framing() == ReplyFraming::kR9 ? 9 : 8, 2s);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(*r, line.Wire({0x43, 0x94, 0x00, 0x1F, 0x34, 0x12, 0x00, 0x00}));
  });
}

// CT-08 "Baud-rate change" — target PACK + ADAPTER (this is the PACK half) — L273, L832: "the
// adapter sends `01 40 82 00 03 00 00 00 00` at 19200 baud, reconfigures its port to 9600 before
// the next word, and the next query `01 43 F0 …` is answered (the simulator verifies the peer
// speed through the shared pty termios and ignores words received at the wrong speed)."
TEST(TrinamicPack, CT08_BaudChange_PackHalf) {
  ForBothFramings([](ServerOptions& o) { o.check_peer_baud = true; },
                  [](PackLine& line) {
                    line.Write({0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00});
                    // Still at 19200: line noise for a PACK listening at 9600.
                    line.Write(kQueryInfo);
                    line.Advance(100ms);
                    EXPECT_TRUE(line.Drain().empty()) << "a word at the old speed was answered";
                    EXPECT_EQ(line.server->counters().noise_bytes, 9u);
                    transport::SerialConfig config = line.port->config();
                    config.baud = 9600;
                    line.port.reset();
                    auto reopened = transport::SerialPort::Open(config);
                    ASSERT_TRUE(reopened.ok()) << reopened.status();
                    line.port.emplace(*std::move(reopened));
                    EXPECT_EQ(line.Query(kQueryInfo),
                              line.Wire({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
                  });
}

// CT-09 "No reply to write commands" — target PACK — reply tables exist only for the queries:
// "When `01 14 00 80 00 FF 01 00 00` is sent. Then no byte is received within 100 ms."
TEST(TrinamicPack, CT09_NoReplyToWriteCommands) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x14, 0x00, 0x80, 0x00, 0xFF, 0x01, 0x00, 0x00});
    line.Advance(100ms);
    EXPECT_TRUE(line.Drain().empty());
    EXPECT_EQ(line.server->counters().words, 1u) << "the word was received and executed";
  });
}

// CT-46 "Address change" — target PACK — L840-843: "When `01 42 05 00 00 00 00 00 00`. Then
// `01 43 F0 00 00 00 00 00 00` gets no reply within 100 ms and `05 43 F0 00 00 00 00 00 00` gets
// a `$43` reply."
TEST(TrinamicPack, CT46_AddressChange) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x42, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    line.Write(kQueryInfo);
    line.Advance(100ms);
    EXPECT_TRUE(line.Drain().empty());
    EXPECT_EQ(line.Query({0x05, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}),
              line.Wire({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
  });
}

// CT-47 "Hardware reset restores defaults" — target PACK — L895-902, L853, L228: "Given
// `01 14 00 80 00 2C 01 00 00` (vmax 300) and a `$43` read (reset flag now 0). When
// `01 CC 00 00 00 00 00 00 00`. Then one `00` byte is emitted, queries within the next ~1 s are
// not answered, afterwards `$43` reports reset flag 1, and a 100 000-µstep move of motor 0 reaches
// velocity 511 again."
TEST(TrinamicPack, CT47_HardwareResetRestoresDefaults) {
  ForBothFramings([](PackLine& line) {
    line.Write({0x01, 0x14, 0x00, 0x80, 0x00, 0x2C, 0x01, 0x00, 0x00});
    EXPECT_EQ(line.Body(kQueryInfo), Bytes({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
    line.Write({0x01, 0xCC, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    auto zero = line.port->ReadExactly(1, 2s);
    ASSERT_TRUE(zero.ok()) << zero.status();
    EXPECT_EQ(*zero, Bytes{0x00});
    line.Advance(500ms);
    line.Write(kQueryInfo);
    line.Advance(100ms);
    EXPECT_TRUE(line.Drain().empty()) << "answered while resetting";
    line.Advance(500ms);  // 1.1 s after the `$CC`
    EXPECT_EQ(line.Query(kQueryInfo), line.Wire({0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00}));
    line.Write({0x01, 0x23, 0x00, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});
    int vmax = 0;
    for (int i = 0; i < 30; ++i) {
      line.Advance(100ms);
      vmax = std::max(vmax, line.Velocity(0));
    }
    EXPECT_EQ(vmax, 511) << "vmax back at the default (§5.12)";
  });
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
