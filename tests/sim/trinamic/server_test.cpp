// Tests for sim/trinamic/server: the simulated SIXpack over a real pty with a manual clock —
// replies, motion advanced by the clock, packet timeout, silent controller and power loss.
#include "sim/trinamic/server.h"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "adapters/transport/serial_port.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::trinamic {
namespace {

using ::testing::ElementsAre;
using namespace std::chrono_literals;

std::string TempLink() {
  return (std::filesystem::temp_directory_path() /
          ("dgw-trsim-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name()))
      .string();
}

struct Fixture {
  explicit Fixture(ServerOptions options = {}) {
    options.pty_path = TempLink();
    auto s = TrinamicServer::Start(options, clock);
    EXPECT_TRUE(s.ok()) << s.status();
    server = *std::move(s);
    transport::SerialConfig config;
    config.device = options.pty_path;
    config.baud = 19200;
    auto p = transport::SerialPort::Open(config);
    EXPECT_TRUE(p.ok()) << p.status();
    port.emplace(*std::move(p));
  }
  std::vector<uint8_t> Query(const std::vector<uint8_t>& word, size_t n = 8) {
    EXPECT_TRUE(port->Write(word).ok());
    auto r = port->ReadExactly(n, 2s);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<uint8_t>{};
  }
  // Waits (with a deadline) until the server has read `n` bytes in total.
  void WaitBytesIn(uint64_t n) {
    const auto deadline = std::chrono::steady_clock::now() + 2s;
    while (server->counters().bytes_in < n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    ASSERT_EQ(server->counters().bytes_in, n);
  }

  ManualClock clock;
  std::unique_ptr<TrinamicServer> server;
  std::optional<transport::SerialPort> port;
};

TEST(TrinamicServer, UnitInformation_OverPty_R8) {
  Fixture f;
  EXPECT_THAT(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}),
              ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
}

TEST(TrinamicServer, RampAdvancedByInjectedClock_R9) {
  ServerOptions o;
  o.controller.framing = ReplyFraming::kR9;
  Fixture f(o);
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x23, 0x00, 0x10, 0x27, 0, 0, 0, 0}).ok());
  f.WaitBytesIn(9);
  f.clock.Advance(5s);
  EXPECT_THAT(f.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}, 9),
              ElementsAre(0xF0, 0x20, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00));
}

TEST(TrinamicServer, PacketTimeout_DiscardsPartialWord) {
  Fixture f;
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x20, 0x00, 0xF0}).ok());
  f.WaitBytesIn(4);
  f.clock.Advance(200ms);  // > default 100 ms (G-04)
  EXPECT_THAT(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}),
              ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
  EXPECT_EQ(f.server->counters().partial_timeouts, 1u);
}

TEST(TrinamicServer, SilentController_ExecutesButNeverAnswers) {
  Fixture f;
  f.server->SetSilent(true);
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x27, 0x00, 0x05, 0, 0, 0, 0, 0}).ok());
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}).ok());
  f.WaitBytesIn(18);
  auto r = f.port->ReadAvailable(50ms);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->empty());
  f.server->SetSilent(false);
  EXPECT_THAT(f.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              ElementsAre(0x20, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00));
}

TEST(TrinamicServer, ResetAtChosenTime_ZeroByteAndResetFlag) {
  ServerOptions o;
  o.faults.reset_after = 1s;
  Fixture f(o);
  EXPECT_EQ(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0})[2], 1);
  EXPECT_EQ(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0})[2], 0);
  f.clock.Advance(1500ms);
  // The stray 00 after the reset (L228), then the reply with the reset flag set (L853).
  EXPECT_THAT(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}, 9),
              ElementsAre(0x00, 0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
  EXPECT_EQ(f.server->counters().resets, 1u);
}

TEST(TrinamicServer, LostStepsAndStuckSwitch_VisibleInController) {
  Fixture f;
  f.server->LoseSteps(0, 7);
  f.server->SetStuckSwitch(1, true);
  EXPECT_EQ(f.Query({0x01, 0x30, 0x01, 0xF0, 0, 0, 0, 0, 0})[4], 1);
  f.server->WithController([](Controller& c) { EXPECT_EQ(c.state(0).rotor, 7); });
}

TEST(TrinamicServer, ValidateOptions_BadTimeout) {
  ServerOptions o;
  o.default_packet_timeout = 1ms;
  EXPECT_FALSE(ValidateOptions(o).ok());
}

TEST(TrinamicServer, MoreUnits_DuplicateAddressRejected) {
  ServerOptions o;
  ControllerOptions second;
  second.address = 1;  // same as options.controller
  o.more_units.push_back(second);
  const absl::Status s = ValidateOptions(o);
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(std::string(s.message()), ::testing::HasSubstr("more_units"));
}

TEST(TrinamicServer, MoreUnits_EachUnitFramesAndAnswersItself) {
  ServerOptions o;
  ControllerOptions second;
  second.address = 7;
  o.more_units.push_back(second);
  Fixture f(o);
  ASSERT_EQ(f.server->unit_count(), 2u);
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x07, 0x27, 0x01, 0x09, 0, 0, 0, 0, 0}).ok());
  EXPECT_THAT(f.Query({0x07, 0x20, 0x01, 0xF0, 0, 0, 0, 0, 0}),
              ElementsAre(0x20, 0x01, 0x09, 0x00, 0x00, 0x00, 0x00, 0x00));
  f.server->WithUnit(0, [](Controller& c) { EXPECT_EQ(c.state(1).position, 0); });
  f.server->WithUnit(1, [](Controller& c) { EXPECT_EQ(c.state(1).position, 9); });
}

TEST(TrinamicServer, Turnaround_ReplyHeldUntilSwitchoverOnClock) {
  ServerOptions o;
  o.turnaround = true;
  Fixture f(o);
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}).ok());
  f.WaitBytesIn(9);
  f.server->WithController([](Controller&) {});
  auto r = f.port->ReadAvailable(30ms);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->empty()) << "no reply before 6 ms have passed on the injected clock";
  f.clock.Advance(6ms);
  auto reply = f.port->ReadExactly(8, 2s);
  ASSERT_TRUE(reply.ok()) << reply.status();
  EXPECT_EQ((*reply)[0], 0x43);
}

TEST(TrinamicServer, HardwareReset_StrayZeroByteThenBusy) {
  Fixture f;
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0xCC, 0, 0, 0, 0, 0, 0, 0}).ok());
  auto zero = f.port->ReadExactly(1, 2s);
  ASSERT_TRUE(zero.ok()) << zero.status();
  EXPECT_THAT(*zero, ElementsAre(0x00));
  EXPECT_EQ(f.server->counters().reset_bytes, 1u);
  f.clock.Advance(1100ms);
  EXPECT_EQ(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0})[2], 1);  // reset flag (L853)
}

TEST(TrinamicServer, CheckPeerBaud_WordsAtTheWrongSpeedAreNoise) {
  ServerOptions o;
  o.check_peer_baud = true;
  Fixture f(o);
  // `$40` divisor 130 = 9600 baud (§2.1); the host still sends at 19200 afterwards.
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x40, 0x82, 0x00, 0x03, 0, 0, 0, 0}).ok());
  f.WaitBytesIn(9);
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x27, 0x00, 0x05, 0, 0, 0, 0, 0}).ok());
  f.WaitBytesIn(18);
  EXPECT_EQ(f.server->counters().noise_bytes, 9u);
  // The host switches its port to 9600 (both pty ends share one termios, §2.7).
  transport::SerialConfig config;
  config.device = f.port->config().device;
  config.baud = 9600;
  f.port.reset();
  auto p = transport::SerialPort::Open(config);
  ASSERT_TRUE(p.ok()) << p.status();
  f.port.emplace(*std::move(p));
  EXPECT_THAT(f.Query({0x01, 0x20, 0x00, 0xF0, 0, 0, 0, 0, 0}),
              ElementsAre(0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00))
      << "the `$27` sent at 19200 was not executed";
}

TEST(TrinamicServer, Break_DiscardsPartialWordOfEveryUnit) {
  Fixture f;
  ASSERT_TRUE(f.port->Write(std::vector<uint8_t>{0x01, 0x27, 0x00}).ok());
  f.WaitBytesIn(3);
  f.server->Break();
  EXPECT_EQ(f.server->counters().breaks, 1u);
  EXPECT_THAT(f.Query({0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0}),
              ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
}

}  // namespace
}  // namespace drivegw::sim::trinamic
