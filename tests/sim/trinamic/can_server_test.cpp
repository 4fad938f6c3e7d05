// Tests for sim/trinamic/can_server: the simulated SIXpack on the UDP multicast CAN bus with a
// scripted master channel and a manual clock — byte-exact replies in the codec's CAN form,
// motion and the delayed `$28` advanced by the clock, foreign and malformed frames, faults.
#include "sim/trinamic/can_server.h"

#include <unistd.h>

#include <chrono>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/transport/can_channel.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::trinamic {
namespace {

using ::testing::ElementsAre;
using namespace std::chrono_literals;

constexpr char kGroup[] = "239.74.163.77";

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

CanBusConfig Bus(uint16_t port) {
  CanBusConfig c;
  c.kind = CanBusConfig::Kind::kUdpMulticast;
  c.group = kGroup;
  c.port = port;
  return c;
}

// Waits for a condition with a real-time deadline; never a fixed sleep.
template <typename Pred>
bool WaitFor(Pred pred, std::chrono::milliseconds timeout = 3000ms) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::yield();
  }
  return pred();
}

struct Fixture {
  explicit Fixture(CanServerOptions options = {}) {
    const uint16_t port = RandomPort();
    auto m = transport::OpenCanChannel(Bus(port));
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *std::move(m);
    options.can = Bus(port);
    auto s = TrinamicCanServer::Start(options, clock);
    EXPECT_TRUE(s.ok()) << s.status();
    if (s.ok()) server = *std::move(s);
  }
  bool ok() const { return master != nullptr && server != nullptr; }

  void Send(uint32_t id, const std::vector<uint8_t>& data) {
    ASSERT_TRUE(master->Send(transport::MakeCanFrame(id, data)).ok());
  }
  // The next frame within the timeout, nullopt if none.
  std::optional<transport::CanFrame> Next(std::chrono::milliseconds timeout = 3000ms) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= std::chrono::nanoseconds(0)) return std::nullopt;
      auto f = master->Receive(left);
      if (f.ok() && f->has_value()) return **f;
    }
  }
  void WaitCommands(uint64_t n) {
    ASSERT_TRUE(WaitFor([&] { return server->counters().commands >= n; }));
  }

  ManualClock clock;
  std::unique_ptr<transport::CanChannel> master;
  std::unique_ptr<TrinamicCanServer> server;
};

std::vector<uint8_t> Data(const transport::CanFrame& f) {
  return std::vector<uint8_t>(f.payload().begin(), f.payload().end());
}

TEST(TrinamicCanServer, UnitInformation_ByteExactWithCodecCanForm) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f.server->command_id(), 0x008);
  f.Send(0x008, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});
  auto r = f.Next();
  ASSERT_TRUE(r);
  // The serial R8 body of the same query (server_test), re-encoded by the codec for CAN.
  auto reply = drivegw::trinamic::DecodeReply(
      std::vector<uint8_t>{0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00},
      drivegw::trinamic::ReplyFraming::kR8);
  ASSERT_TRUE(reply.ok()) << reply.status();
  reply->response_address = 0xF0;
  auto expected = drivegw::trinamic::EncodeReplyCan(*reply);
  ASSERT_TRUE(expected.ok()) << expected.status();
  EXPECT_EQ(r->id, expected->id);
  EXPECT_EQ(r->id, 0x780u);
  EXPECT_FALSE(r->extended);
  EXPECT_EQ(r->dlc, 8);
  EXPECT_EQ(r->data, expected->data);
  EXPECT_THAT(Data(*r), ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
  EXPECT_EQ(f.server->counters().replies, 1u);
}

TEST(TrinamicCanServer, MotionAdvancedByManualClock_ReplyToResponseAddress) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  f.Send(0x008, {0x23, 0x00, 0x10, 0x27, 0, 0, 0, 0});  // motor 0 to 10000
  f.WaitCommands(1);
  f.clock.Advance(5s);
  ASSERT_TRUE(drivegw::trinamic::ValidateResponseAddress(0x7E).ok());
  f.Send(0x008, {0x20, 0x00, 0x7E, 0, 0, 0, 0, 0});  // query position, RA 0x7E
  auto r = f.Next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->id, 0x3F0u);  // 0x7E << 3
  EXPECT_THAT(Data(*r), ElementsAre(0x20, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00));
}

TEST(TrinamicCanServer, QueryActivities_DelayedReplyWhenMotorStops) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  f.Send(0x008, {0x23, 0x03, 0xD0, 0x07, 0, 0, 0, 0});  // motor 3 to 2000
  f.Send(0x008, {0x28, 0xF0, 0x08, 0, 0, 0, 0, 0});     // wait for motor 3
  f.WaitCommands(2);
  EXPECT_FALSE(f.Next(200ms));  // still moving: no answer yet
  f.clock.Advance(10s);
  auto r = f.Next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->id, 0x780u);
  EXPECT_THAT(Data(*r), ElementsAre(0x28, 0, 0, 0, 0, 0, 0, 0));
}

TEST(TrinamicCanServer, OtherAddressIgnored) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  f.Send(0x010, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});  // address 2
  f.Send(0x009, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});  // tunnel id of address 1
  EXPECT_FALSE(f.Next(200ms));
  f.Send(0x008, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});
  auto r = f.Next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->id, 0x780u);
  const CanServerCounters c = f.server->counters();
  EXPECT_EQ(c.commands, 1u);
  EXPECT_EQ(c.malformed, 0u);
}

TEST(TrinamicCanServer, MalformedFramesCountedAndDropped) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  f.Send(0x008, {0x43, 0xF0, 0x00});  // DLC 3 (G-27: always 8)
  ASSERT_TRUE(f.master->Send(transport::MakeCanRtrFrame(0x008, 8)).ok());
  ASSERT_TRUE(WaitFor([&] { return f.server->counters().malformed >= 2; }));
  EXPECT_FALSE(f.Next(100ms));
  f.Send(0x008, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});  // the server survived
  auto r = f.Next();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->data[0], 0x43);
  EXPECT_EQ(f.server->counters().malformed, 2u);
  EXPECT_EQ(f.server->counters().commands, 1u);
}

TEST(TrinamicCanServer, SilentController_ExecutesButNeverAnswers) {
  CanServerOptions o;
  o.faults.silent = true;
  Fixture f(o);
  ASSERT_TRUE(f.ok());
  f.Send(0x008, {0x23, 0x00, 0x10, 0x27, 0, 0, 0, 0});
  f.Send(0x008, {0x43, 0xF0, 0, 0, 0, 0, 0, 0});
  f.WaitCommands(2);
  EXPECT_FALSE(f.Next(200ms));
  f.server->SetSilent(false);
  f.clock.Advance(5s);
  f.Send(0x008, {0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
  auto r = f.Next();
  ASSERT_TRUE(r);
  EXPECT_THAT(Data(*r), ElementsAre(0x20, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00));
}

TEST(TrinamicCanServer, ResetAtChosenTime_SetsResetFlagWithoutStrayFrame) {
  CanServerOptions o;
  o.faults.reset_after = 1s;
  Fixture f(o);
  ASSERT_TRUE(f.ok());
  f.Send(0x008, {0x23, 0x00, 0x10, 0x27, 0, 0, 0, 0});
  f.WaitCommands(1);
  f.clock.Advance(2s);
  ASSERT_TRUE(WaitFor([&] { return f.server->counters().resets == 1; }));
  EXPECT_FALSE(f.Next(100ms));  // no 00 byte on CAN
  bool flag = false;
  int32_t position = -1;
  f.server->WithController([&](Controller& c) {
    flag = c.reset_flag();
    position = c.state(0).position;
  });
  EXPECT_TRUE(flag);
  EXPECT_EQ(position, 0);
}

TEST(TrinamicCanServer, StopIsPromptAndIdempotent) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  const auto t0 = std::chrono::steady_clock::now();
  f.server->Stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  f.server->Stop();
}

TEST(TrinamicCanServer, Start_RejectsInvalidOptions) {
  CanServerOptions o;
  o.controller.axes = 5;
  ManualClock clock;
  auto s = TrinamicCanServer::Start(o, clock);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(TrinamicCanServer, CommandQueue_SeventeenthCommandDropped) {
  CanServerOptions o;
  o.command_time = 2ms;  // L303
  Fixture f(o);
  ASSERT_TRUE(f.ok());
  for (uint8_t k = 0; k < 17; ++k) f.Send(0x008, {0x27, 0x00, k, 0, 0, 0, 0, 0});
  f.WaitCommands(17);
  EXPECT_EQ(f.server->counters().queue_overflows, 1u);  // G-27, decision 1041
  f.clock.Advance(40ms);
  f.Send(0x008, {0x20, 0x00, 0xF0, 0, 0, 0, 0, 0});
  f.WaitCommands(18);
  f.clock.Advance(2ms);
  auto r = f.Next();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->data[2], 15) << "the 16th command (value 15) was the last one executed";
}

TEST(TrinamicCanServer, SerialEndpoint_TunnelIgnoredBeforeTakeoverAndResetReturnsSerial) {
  CanServerOptions o;
  o.serial_endpoint = true;
  Fixture f(o);
  ASSERT_TRUE(f.ok());
  transport::SerialConfig config;
  config.device = f.server->serial_path();
  config.baud = 19200;
  auto serial = transport::SerialPort::Open(config);
  ASSERT_TRUE(serial.ok()) << serial.status();
  f.Send(0x009, {0x41});  // tunnel frame before any CAN instruction: dropped (decision 1042)
  ASSERT_TRUE(WaitFor([&] { return f.server->counters().tunnel_dropped == 1; }));
  EXPECT_FALSE(f.server->can_mode());
  f.Send(0x008, {0xCC, 0, 0, 0, 0, 0, 0, 0});  // CAN instruction: takeover, then `$CC`
  auto zero = serial->ReadExactly(1, 2s);
  ASSERT_TRUE(zero.ok()) << zero.status();
  EXPECT_THAT(*zero, ElementsAre(0x00));  // stray 00 on the RS-232 (L228, L902)
  EXPECT_FALSE(f.server->can_mode()) << "serial control again after the reset (G-28)";
  f.clock.Advance(1100ms);
  ASSERT_TRUE(serial->Write(std::vector<uint8_t>{0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}).ok());
  auto reply = serial->ReadExactly(8, 2s);
  ASSERT_TRUE(reply.ok()) << reply.status();
  EXPECT_THAT(*reply, ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
}

}  // namespace
}  // namespace drivegw::sim::trinamic
