// Trinamic PACK contract cases of §8.6 (CAN): exact frames on the user-space UDP multicast CAN
// bus, the PACK's RS-232 port as a pty (takeover, tunnel), time from the injected clock.
#include <cstdint>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/contract/trinamic/pack_line.h"

namespace drivegw::sim::trinamic::contract {
namespace {

using ::testing::ElementsAre;

constexpr uint32_t kCmdId = 0x008;    // A = 01 << 3 (L289)
constexpr uint32_t kReplyId = 0x780;  // RA = F0 << 3 (L291)

// The host side of the PACK's RS-232 port.
transport::SerialPort OpenSerial(CanPack& pack) {
  transport::SerialConfig config;
  config.device = pack.server->serial_path();
  config.baud = 19200;
  auto p = transport::SerialPort::Open(config);
  EXPECT_TRUE(p.ok()) << p.status();
  return *std::move(p);
}

// Waits until the server has read `n` bytes from its serial endpoint.
void WaitSerialIn(CanPack& pack, uint64_t n) {
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  while (pack.server->counters().serial_bytes_in < n &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::yield();
  }
  ASSERT_EQ(pack.server->counters().serial_bytes_in, n);
}

// CT-49 "CAN command and reply mapping" — target PACK — L289-291: "Given the simulator in CAN
// mode at address `01` and motor 2 at −1234. When a frame ID `0x008`, DLC 8, data
// `20 02 F0 00 00 00 00 00` is sent. Then a frame ID `0x780`, DLC 8, data
// `20 02 2E FB FF FF 00 00` is received."
TEST(TrinamicPack, CT49_CanCommandAndReplyMapping) {
  CanPack pack;
  ASSERT_TRUE(pack.ok());
  pack.Send(kCmdId, {0x27, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00});
  pack.Send(kCmdId, {0x20, 0x02, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00});
  auto f = pack.Next();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->id, kReplyId);
  EXPECT_FALSE(f->extended);
  EXPECT_EQ(f->dlc, 8);
  EXPECT_THAT(FrameData(*f), ElementsAre(0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00));
}

// CT-51 "CAN takes over from serial" — target PACK — L291: "Given the simulator reachable over
// pty and `vcan`, serial queries answered. When one valid CAN instruction (ID `0x008`,
// `43 F0 00 00 00 00 00 00`) has been received. Then a following serial `01 43 F0 …` gets no
// reply and serial motion commands have no effect." Serial replies in both framings (G-01).
TEST(TrinamicPack, CT51_CanTakesOverFromSerial) {
  for (ReplyFraming framing : {ReplyFraming::kR8, ReplyFraming::kR9}) {
    SCOPED_TRACE(FramingName(framing));
    CanServerOptions o;
    o.serial_endpoint = true;
    o.serial_framing = framing;
    CanPack pack(o);
    ASSERT_TRUE(pack.ok());
    transport::SerialPort serial = OpenSerial(pack);
    const Bytes info = {0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0};
    ASSERT_TRUE(serial.Write(info).ok());
    auto r = serial.ReadExactly(framing == ReplyFraming::kR9 ? 9 : 8, 2s);
    ASSERT_TRUE(r.ok()) << r.status();
    Bytes expected = {0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00};
    if (framing == ReplyFraming::kR9) expected.insert(expected.begin(), kRa);
    EXPECT_EQ(*r, expected) << "serial control before the takeover";

    pack.Send(kCmdId, {0x43, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});
    auto f = pack.Next();
    ASSERT_TRUE(f.has_value());
    EXPECT_EQ(f->id, kReplyId);
    EXPECT_THAT(FrameData(*f), ElementsAre(0x43, 0x94, 0x00, 0x1F, 0x34, 0x12, 0x00, 0x00));
    EXPECT_TRUE(pack.server->can_mode());

    ASSERT_TRUE(serial.Write(info).ok());
    ASSERT_TRUE(serial.Write(Bytes{0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00}).ok());
    WaitSerialIn(pack, 27);
    pack.clock.Advance(1s);
    pack.Settle();
    auto silence = serial.ReadAvailable(50ms);
    ASSERT_TRUE(silence.ok());
    EXPECT_TRUE(silence->empty()) << "serial query answered after the takeover";
    pack.Send(kCmdId, {0x20, 0x00, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00});
    f = pack.Next();
    ASSERT_TRUE(f.has_value());
    EXPECT_THAT(FrameData(*f), ElementsAre(0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00))
        << "the serial `$23` had no effect";
  }
}

// CT-52 "CAN command queue" — target PACK — L303: "When 16 commands (`$27` for motors 0-5 with
// distinct values, then `$20` queries) are sent back to back. Then all are executed in order and
// the last reply arrives within 40 ms."
TEST(TrinamicPack, CT52_CanCommandQueue) {
  CanServerOptions o;
  o.command_time = 2ms;  // ~2 ms per command (L303)
  CanPack pack(o);
  ASSERT_TRUE(pack.ok());
  std::vector<uint8_t> queried;
  for (uint8_t m = 0; m < 6; ++m) {
    const auto v = static_cast<uint32_t>(1000 * (m + 1) + m);
    pack.Send(kCmdId, {0x27, m, static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8), 0, 0, 0, 0});
  }
  for (uint8_t k = 0; k < 10; ++k) {
    const uint8_t m = k % 6;
    queried.push_back(m);
    pack.Send(kCmdId, {0x20, m, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00});
  }
  pack.WaitFrames(16);
  const TimePoint t0 = pack.clock.Now();
  std::vector<Bytes> replies;
  // Settle runs the queue synchronously, so the reply counter gives the clock time of sending;
  // the frames are read afterwards with a generous real deadline.
  while (pack.server->counters().replies < queried.size() && pack.clock.Now() - t0 <= 40ms) {
    pack.clock.Advance(2ms);
    pack.Settle();
  }
  EXPECT_LE(pack.clock.Now() - t0, 40ms);
  EXPECT_GE(pack.clock.Now() - t0, 32ms) << "16 commands × ~2 ms (L303), not all at once";
  while (replies.size() < queried.size()) {
    auto f = pack.Next();
    if (!f) break;
    EXPECT_EQ(f->id, kReplyId);
    replies.push_back(FrameData(*f));
  }
  ASSERT_EQ(replies.size(), queried.size());
  for (size_t k = 0; k < replies.size(); ++k) {
    const uint8_t m = queried[k];
    const auto v = static_cast<uint32_t>(1000 * (m + 1) + m);
    EXPECT_THAT(replies[k], ElementsAre(0x20, m, static_cast<uint8_t>(v),
                                        static_cast<uint8_t>(v >> 8), 0, 0, 0, 0))
        << "reply " << k;
  }
  EXPECT_EQ(pack.server->counters().queue_overflows, 0u);
}

// CT-53 "RS-232 tunnel, host to device" — target PACK — L315: "Given CAN mode. When frame ID
// `0x009`, DLC 3, data `41 42 43`. Then the bytes `41 42 43` appear on the simulator's serial
// endpoint."
TEST(TrinamicPack, CT53_TunnelHostToDevice) {
  CanServerOptions o;
  o.serial_endpoint = true;
  CanPack pack(o);
  ASSERT_TRUE(pack.ok());
  transport::SerialPort serial = OpenSerial(pack);
  pack.Send(kCmdId, {0x43, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00});  // CAN mode (L291)
  ASSERT_TRUE(pack.Next().has_value());
  pack.Send(0x009, {0x41, 0x42, 0x43});
  auto r = serial.ReadExactly(3, 2s);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_THAT(*r, ElementsAre(0x41, 0x42, 0x43));
}

// CT-54 "RS-232 tunnel, device to host" — target PACK — L317, L857-869, L838: "Given CAN mode and
// frame ID `0x008` data `44 F0 20 04 00 00 00 00` (forward to response address `0x20`, packets of
// 4). Then a reply frame ID `0x780` with data byte 1 = `00` (send buffer empty). When
// `31 32 33 34` arrive on the serial endpoint. Then one frame ID `0x100`, DLC 4, data
// `31 32 33 34` is sent. When two more bytes `35 36` arrive and the `$41` timeout elapses. Then
// one frame ID `0x100`, DLC 2, data `35 36` is sent."
TEST(TrinamicPack, CT54_TunnelDeviceToHost) {
  CanServerOptions o;
  o.serial_endpoint = true;
  CanPack pack(o);
  ASSERT_TRUE(pack.ok());
  transport::SerialPort serial = OpenSerial(pack);
  pack.Send(kCmdId, {0x44, 0xF0, 0x20, 0x04, 0x00, 0x00, 0x00, 0x00});
  auto f = pack.Next();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->id, kReplyId);
  EXPECT_EQ(f->dlc, 8);
  EXPECT_EQ(f->data[1], 0x00) << "send buffer empty";

  ASSERT_TRUE(serial.Write(Bytes{0x31, 0x32, 0x33, 0x34}).ok());
  f = pack.Next();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->id, 0x100u);
  EXPECT_THAT(FrameData(*f), ElementsAre(0x31, 0x32, 0x33, 0x34));

  ASSERT_TRUE(serial.Write(Bytes{0x35, 0x36}).ok());
  WaitSerialIn(pack, 6);
  pack.Settle();
  EXPECT_FALSE(pack.Next(50ms).has_value()) << "a short packet before the timeout";
  pack.clock.Advance(100ms);  // `$41` not set: the 100 ms default (G-04, decision 1037)
  pack.Settle();
  f = pack.Next();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->id, 0x100u);
  EXPECT_THAT(FrameData(*f), ElementsAre(0x35, 0x36));
}

}  // namespace
}  // namespace drivegw::sim::trinamic::contract
