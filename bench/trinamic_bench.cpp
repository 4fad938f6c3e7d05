// Trinamic SIXpack/QUADpack query rate: request/reply pairs per second through ControllerSession
// over a pseudo-terminal to the simulated controller (sim/trinamic), against the wire limit at
// 19200 and 115200 baud computed from the datagram sizes and the $40 switchover delay
// (trinamic-sixpack.md §2.3-2.5), and against a bare pty ping-pong of the same byte counts
// measured in the same run. A pty ignores the baud rate (§2.7): the measured rates are the
// host + pty + simulator rates; only the wire limit depends on the baud.
// Run: build/bench/trinamic_bench [transactions per scenario and round]
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/transport/pty.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/session.h"
#include "sim/trinamic/server.h"

namespace {

using Clock = std::chrono::steady_clock;
using drivegw::trinamic::ControllerSession;
using drivegw::trinamic::Opcode;
using drivegw::trinamic::ReplyFraming;
using drivegw::trinamic::SessionOptions;

constexpr int kRounds = 3;
constexpr size_t kRequestBytes = 9;     // §2.3
constexpr double kSwitchoverS = 0.006;  // $40 default, value 3 × 2 ms (§2.5)
constexpr double kGapS = 0.002;         // session command_gap (§2.5 [P])
constexpr double kBitsPerByte = 10.0;   // 8N1

int g_failures = 0;  // failed transactions / ping-pongs

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Wire limit in pairs/s: request + reply on the line, the controller's switchover delay before
// it answers, and the 2 ms the session leaves between words.
double WireLimit(int baud, size_t reply_bytes) {
  const double pair_s =
      static_cast<double>(kRequestBytes + reply_bytes) * kBitsPerByte / static_cast<double>(baud) +
      kSwitchoverS + kGapS;
  return 1.0 / pair_s;
}

// Bare pty ping-pong: 9 bytes from a SerialPort on the slave, `reply_bytes` echoed by a thread
// on the master. Returns pairs/s; 0 on failure.
double MeasurePtyPingPong(int baud, size_t reply_bytes, int n) {
  auto pty = drivegw::transport::PseudoTerminal::Open();
  if (!pty.ok()) {
    std::fprintf(stderr, "pty: %s\n", std::string(pty.status().message()).c_str());
    ++g_failures;
    return 0;
  }
  drivegw::transport::SerialConfig config;
  config.device = pty->slave_path();
  config.baud = baud;
  auto port = drivegw::transport::SerialPort::Open(config);
  if (!port.ok()) {
    std::fprintf(stderr, "serial: %s\n", std::string(port.status().message()).c_str());
    ++g_failures;
    return 0;
  }
  std::atomic<bool> echo_failed{false};
  std::thread echo([&] {
    const std::vector<uint8_t> reply(reply_bytes, 0x20);
    for (int i = 0; i < n; ++i) {
      auto got = pty->ReadExactly(kRequestBytes, std::chrono::seconds(2));
      if (!got.ok() || !pty->Write(reply).ok()) {
        echo_failed = true;
        return;
      }
    }
  });
  const std::vector<uint8_t> request(kRequestBytes, 0x01);
  int done = 0;
  const auto t0 = Clock::now();
  for (; done < n; ++done) {
    if (!port->Write(request).ok()) break;
    if (!port->ReadExactly(reply_bytes, std::chrono::seconds(2)).ok()) break;
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  echo.join();
  if (done != n || echo_failed) {
    std::fprintf(stderr, "pty ping-pong: %d of %d pairs\n", done, n);
    ++g_failures;
    return 0;
  }
  return n / s;
}

// `n` position queries through a ControllerSession at `baud` on the simulator's pty.
double MeasureSession(const std::string& device, int baud, const SessionOptions& options, int n,
                      size_t* reply_bytes) {
  drivegw::transport::SerialConfig config;
  config.device = device;
  config.baud = baud;
  auto session = ControllerSession::OpenSerial(config, options);
  if (!session.ok()) {
    std::fprintf(stderr, "session: %s\n", std::string(session.status().message()).c_str());
    ++g_failures;
    return 0;
  }
  if (absl::Status probe = (*session)->Probe(); !probe.ok()) {
    std::fprintf(stderr, "probe: %s\n", std::string(probe.message()).c_str());
    ++g_failures;
    return 0;
  }
  const auto framing = (*session)->framing();
  *reply_bytes = drivegw::trinamic::ReplySize(framing.value_or(ReplyFraming::kR8));
  auto command = drivegw::trinamic::MakeCommand(options.address, Opcode::kQueryPosition,
                                                {0, options.response_address});
  if (!command.ok()) {
    std::fprintf(stderr, "command: %s\n", std::string(command.status().message()).c_str());
    ++g_failures;
    return 0;
  }
  int done = 0;
  const auto t0 = Clock::now();
  for (; done < n; ++done) {
    auto reply = (*session)->Transact(*command, Clock::now() + std::chrono::milliseconds(500));
    if (!reply.ok() || !reply->has_value()) {
      std::fprintf(stderr, "transact %d: %s\n", done,
                   reply.ok() ? "no reply" : std::string(reply.status().message()).c_str());
      ++g_failures;
      return 0;
    }
  }
  return n / std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(1, std::atoi(argv[1])) : 500;
  drivegw::sim::trinamic::ServerOptions server_options;
  server_options.pty_path = "/tmp/trinamic_bench_" + std::to_string(::getpid());
  auto server = drivegw::sim::trinamic::TrinamicServer::Start(server_options,
                                                              drivegw::SteadyClock::Instance());
  if (!server.ok()) {
    std::fprintf(stderr, "server: %s\n", std::string(server.status().message()).c_str());
    return 1;
  }
  const std::string device = (*server)->slave_path();

  SessionOptions defaults;  // command_gap 2 ms, duplicate_window 2 ms
  SessionOptions no_wait = defaults;
  no_wait.command_gap = std::chrono::microseconds(0);
  no_wait.duplicate_window = std::chrono::microseconds(0);

  std::printf("trinamic_bench: %d position queries per scenario and round, %d rounds, medians\n", n,
              kRounds);
  std::printf("(a pty ignores the baud: measured = host + pty + simulator; limit = wire)\n\n");
  std::printf("%-7s %-30s %10s %12s %12s %9s\n", "baud", "scenario", "pairs/s", "pty base/s",
              "wire lim/s", "meas/lim");
  for (int baud : {19200, 115200}) {
    std::vector<double> base, sess, bare;
    size_t reply_bytes = drivegw::trinamic::ReplySize(ReplyFraming::kR8);
    for (int r = 0; r < kRounds; ++r) {
      base.push_back(MeasurePtyPingPong(baud, reply_bytes, n));
      sess.push_back(MeasureSession(device, baud, defaults, n, &reply_bytes));
      bare.push_back(MeasureSession(device, baud, no_wait, n, &reply_bytes));
    }
    const double limit = WireLimit(baud, reply_bytes);
    const double b = Median(base);
    const double s = Median(sess);
    const double z = Median(bare);
    const std::string label = "pty ping-pong 9/" + std::to_string(reply_bytes) + " B";
    std::printf("%-7d %-30s %10.0f %12.0f %12.1f %9.2f\n", baud, label.c_str(), b, b, limit,
                b / limit);
    std::printf("%-7d %-30s %10.0f %12.0f %12.1f %9.2f\n", baud, "session, defaults (gap+window)",
                s, b, limit, s / limit);
    std::printf("%-7d %-30s %10.0f %12.0f %12.1f %9.2f\n", baud, "session, gap=window=0", z, b,
                limit, z / limit);
    std::printf("%-7s %-30s session/base: defaults %.3f, gap=window=0 %.3f\n\n", "", "", s / b,
                z / b);
  }
  auto counters = (*server)->counters();
  std::printf("simulator: %llu words, %llu replies\n",
              static_cast<unsigned long long>(counters.words),
              static_cast<unsigned long long>(counters.replies));
  (*server)->Stop();
  if (g_failures > 0) {
    std::fprintf(stderr, "trinamic_bench: %d failures\n", g_failures);
    return 1;
  }
  return 0;
}
