// ControllerSession::ChangeBaud and the reset-rate probe fallback (G-40, CT-08; decision 1098)
// against the simulated SIXpack on a real pty with its peer-speed check on: words at the wrong
// speed are line noise to it (decision 1045).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "adapters/core/clock.h"
#include "adapters/trinamic/session.h"
#include "sim/trinamic/server.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;
using sim::trinamic::Controller;
using ::testing::HasSubstr;

struct Line {
  Line() {
    static std::atomic<int> n{0};
    sim::trinamic::ServerOptions o;
    o.check_peer_baud = true;
    o.pty_path = (std::filesystem::temp_directory_path() /
                  ("dgw-trbaud-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
                     .string();
    auto s = sim::trinamic::TrinamicServer::Start(o, SteadyClock::Instance());
    EXPECT_TRUE(s.ok()) << s.status();
    if (!s.ok()) return;
    server = *std::move(s);
    transport::SerialConfig config;
    config.device = server->slave_path();
    config.baud = 19200;
    SessionOptions so;
    so.address = 1;
    so.offline_after_misses = 1;
    so.probe_timeout = 100ms;
    so.retry_min = 10ms;
    so.retry_max = 20ms;
    so.break_duration = 1ms;
    so.reset_baud = kResetBaud;
    auto session_or = ControllerSession::OpenSerial(config, so);
    EXPECT_TRUE(session_or.ok()) << session_or.status();
    if (session_or.ok()) session = *session_or;
  }
  ~Line() {
    session.reset();
    if (server) server->Stop();
  }
  int SimDivisor() {
    int d = 0;
    server->WithController([&](Controller& c) { d = c.globals().baud_divisor; });
    return d;
  }
  std::unique_ptr<sim::trinamic::TrinamicServer> server;
  std::shared_ptr<ControllerSession> session;
};

struct ResetCounter : SessionObserver {
  void OnControllerReset(uint8_t) noexcept override { ++resets; }
  std::atomic<int> resets{0};
};

Command Word40(int64_t divisor) { return *MakeCommand(1, Opcode::kSetBaudRate, {divisor, 3}); }
Command Query43() { return *MakeCommand(1, Opcode::kUnitInformation, {0xF0}); }

TEST(SessionBaudTest, ChangeBaud_SwitchesOwnPortVerifiesAndRefusesOddDivisors) {
  Line line;
  ASSERT_NE(line.session, nullptr);
  ASSERT_TRUE(line.session->Probe().ok());
  EXPECT_EQ(line.session->baud(), 19200);

  const absl::Status odd = line.session->ChangeBaud(Word40(100), SessionClock::now() + 200ms);
  EXPECT_EQ(odd.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(odd.message(), HasSubstr("$40.divisor: 100"));
  EXPECT_EQ(line.session->ChangeBaud(Query43(), SessionClock::now() + 200ms).code(),
            absl::StatusCode::kInvalidArgument);

  line.server->ClearWords();
  ASSERT_TRUE(line.session->ChangeBaud(Word40(130), SessionClock::now() + 200ms).ok());
  EXPECT_EQ(line.session->baud(), 9600);
  EXPECT_EQ(line.SimDivisor(), 130);
  // `$40` at 19200, then the verifying `$43` understood at 9600 (CT-08).
  const auto words = line.server->words();
  ASSERT_GE(words.size(), 2u);
  EXPECT_EQ(words[words.size() - 2],
            (std::vector<uint8_t>{0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(words.back(),
            (std::vector<uint8_t>{0x01, 0x43, 0xF0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_TRUE(line.session->Transact(Query43(), SessionClock::now() + 200ms).ok());
  // Back to 19200 the same way.
  ASSERT_TRUE(line.session->ChangeBaud(Word40(65), SessionClock::now() + 200ms).ok());
  EXPECT_EQ(line.session->baud(), 19200);
  EXPECT_EQ(line.SimDivisor(), 65);
}

TEST(SessionBaudTest, ResetPack_ProbeFallsBackTo19200AndReportsTheReset) {
  Line line;
  ASSERT_NE(line.session, nullptr);
  ResetCounter observer;
  const int observer_id = line.session->AddObserver(&observer);
  ASSERT_TRUE(line.session->Probe().ok());
  const int power_up = observer.resets.load();  // the simulator's power-up flag
  ASSERT_TRUE(line.session->ChangeBaud(Word40(130), SessionClock::now() + 200ms).ok());
  ASSERT_EQ(line.session->baud(), 9600);

  line.server->WithController([](Controller& c) { c.Reset(); });  // power cycle: 19200 (L899)
  const auto noise = line.server->counters().noise_bytes;
  EXPECT_FALSE(line.session->Transact(Query43(), SessionClock::now() + 100ms).ok());
  EXPECT_GT(line.server->counters().noise_bytes, noise);
  EXPECT_EQ(line.session->link_state(), LinkState::kOffline);
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  absl::Status probe = line.session->Probe();
  while (!probe.ok() && std::chrono::steady_clock::now() < deadline) {
    probe = line.session->Probe();
  }
  ASSERT_TRUE(probe.ok()) << probe;
  EXPECT_EQ(line.session->baud(), 19200);
  EXPECT_EQ(line.session->link_state(), LinkState::kOnline);
  EXPECT_EQ(observer.resets.load(), power_up + 1);
  line.session->RemoveObserver(observer_id);
}

}  // namespace
}  // namespace drivegw::trinamic
