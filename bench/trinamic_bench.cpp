// Trinamic SIXpack/QUADpack query rate: request/reply pairs per second through ControllerSession
// over a pseudo-terminal to the simulated controller (sim/trinamic), against the wire limit at
// 19200 and 115200 baud computed from the datagram sizes and the $40 switchover delay
// (trinamic-sixpack.md §2.3-2.5), and against a bare pty ping-pong of the same byte counts
// measured in the same run. A pty ignores the baud rate (§2.7): the measured rates are the
// host + pty + simulator rates; only the wire limit depends on the baud.
// Issue 10 P3, the CAN variant: the same position queries through ControllerSession::OpenCan to
// the simulated controller on the user-space CAN bus (decision 1038), paced at 250 kbit/s (no
// jumpers, decision 1099) per decision 805, against bit rate / bits per query (command + reply
// frame at their exact lengths), and frames per query against the minimum of 2 (§3.1).
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
#include "adapters/core/log.h"
#include "adapters/transport/can_bit_timing.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/pty.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/session.h"
#include "bench/report.h"
#include "sim/trinamic/can_server.h"
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

// ---------------------------------------------------------------------------------------------
// CAN: SIXpack on the user-space bus (issue 10 P3)

// No jumpers set: 250 kbit/s (decision 1099, trinamic-sixpack.md §3.2).
constexpr uint32_t kCanBitrate = 250000;
constexpr char kCanGroup[] = "239.74.163.96";  // this bench's own group (ctest runs in parallel)

uint16_t CanPort(int n) { return static_cast<uint16_t>(20000 + (::getpid() * 32 + n) % 40000); }

drivegw::CanBusConfig CanBus(uint16_t port, uint32_t bitrate) {
  drivegw::CanBusConfig bus;
  bus.kind = drivegw::CanBusConfig::Kind::kUdpMulticast;
  bus.group = kCanGroup;
  bus.port = port;
  bus.bitrate = bitrate;
  return bus;
}

drivegw::transport::CanFrame ToTransport(const drivegw::trinamic::CanFrame& f) {
  return drivegw::transport::MakeCanFrame(f.id, std::span<const uint8_t>(f.data.data(), f.dlc));
}

struct CanRun {
  double per_s = 0;
  double frames_per_query = 0;  // frames the controller received + sent, per query
  double bits_per_query = 0;    // exact lengths of the command and reply frames
  double p50_us = 0;            // median query time
};

// `n` position queries through ControllerSession::OpenCan (gap = window = 0: only the bus and
// the turnaround count) to a TrinamicCanServer on the bus at `bitrate` (0 = unpaced).
CanRun MeasureCanSession(uint16_t port, uint32_t bitrate, int n) {
  CanRun run;
  drivegw::sim::trinamic::CanServerOptions so;
  so.can = CanBus(port, bitrate);
  auto server =
      drivegw::sim::trinamic::TrinamicCanServer::Start(so, drivegw::SteadyClock::Instance());
  if (!server.ok()) {
    std::fprintf(stderr, "can server: %s\n", std::string(server.status().message()).c_str());
    ++g_failures;
    return run;
  }
  SessionOptions options;
  options.command_gap = std::chrono::microseconds(0);
  options.duplicate_window = std::chrono::microseconds(0);
  auto session = ControllerSession::OpenCan(CanBus(port, bitrate), options);
  if (!session.ok() || !(*session)->Probe().ok()) {
    std::fprintf(stderr, "can session: %s\n",
                 session.ok() ? "probe failed" : std::string(session.status().message()).c_str());
    ++g_failures;
    return run;
  }
  auto command = drivegw::trinamic::MakeCommand(options.address, Opcode::kQueryPosition,
                                                {0, options.response_address});
  auto first = command.ok()
                   ? (*session)->Transact(*command, Clock::now() + std::chrono::seconds(1))
                   : absl::StatusOr<std::optional<drivegw::trinamic::Reply>>(command.status());
  if (!first.ok() || !first->has_value()) {
    std::fprintf(stderr, "can transact: no reply\n");
    ++g_failures;
    return run;
  }
  auto command_frame = drivegw::trinamic::EncodeCommandCan(*command);
  drivegw::trinamic::Reply reply = **first;
  reply.response_address = options.response_address;
  auto reply_frame = drivegw::trinamic::EncodeReplyCan(reply);
  if (command_frame.ok() && reply_frame.ok()) {
    run.bits_per_query = drivegw::transport::CanFrameBits(ToTransport(*command_frame)) +
                         drivegw::transport::CanFrameBits(ToTransport(*reply_frame));
  }
  const auto c0 = (*server)->counters();
  int done = 0;
  std::vector<double> each_us;
  const auto t0 = Clock::now();
  for (; done < n; ++done) {
    const auto q0 = Clock::now();
    auto r = (*session)->Transact(*command, Clock::now() + std::chrono::milliseconds(500));
    each_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - q0).count());
    if (!r.ok() || !r->has_value()) {
      std::fprintf(stderr, "can transact %d: %s\n", done,
                   r.ok() ? "no reply" : std::string(r.status().message()).c_str());
      ++g_failures;
      return run;
    }
  }
  run.per_s = n / std::chrono::duration<double>(Clock::now() - t0).count();
  run.p50_us = Median(each_us);
  const auto c1 = (*server)->counters();
  run.frames_per_query =
      static_cast<double>((c1.frames_in - c0.frames_in) + (c1.replies - c0.replies)) / n;
  (*server)->Stop();
  return run;
}

// Bare baseline: the same two frames ping-ponged between two channels at `bitrate`.
double MeasureCanPingPong(uint16_t port, uint32_t bitrate, int n, double* bits) {
  auto a = drivegw::transport::OpenCanChannel(CanBus(port, bitrate));
  auto b = drivegw::transport::OpenCanChannel(CanBus(port, bitrate));
  if (!a.ok() || !b.ok()) {
    ++g_failures;
    return 0;
  }
  const std::vector<uint8_t> body = {0x08, 0, 0, 0, 0, 0, 0, 0};
  const auto request = drivegw::transport::MakeCanFrame(0x008, body);
  const auto answer = drivegw::transport::MakeCanFrame(0x780, body);
  *bits = drivegw::transport::CanFrameBits(request) + drivegw::transport::CanFrameBits(answer);
  std::atomic<bool> echo_failed{false};
  std::thread echo([&] {
    for (int i = 0; i < n; ++i) {
      auto f = (*b)->Receive(std::chrono::seconds(2));
      if (!f.ok() || !f->has_value() || !(*b)->Send(answer).ok()) {
        echo_failed = true;
        return;
      }
    }
  });
  int done = 0;
  const auto t0 = Clock::now();
  for (; done < n; ++done) {
    if (!(*a)->Send(request).ok()) break;
    auto f = (*a)->Receive(std::chrono::seconds(2));
    if (!f.ok() || !f->has_value()) break;
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  echo.join();
  if (done != n || echo_failed) {
    std::fprintf(stderr, "can ping-pong: %d of %d pairs\n", done, n);
    ++g_failures;
    return 0;
  }
  return n / s;
}

double LoadAverage() {
  double l[1] = {0};
  return ::getloadavg(l, 1) == 1 ? l[0] : -1;
}

void BenchCan(int n) {
  std::printf("CAN (user-space bus, decision 805): position queries, %d per round, %d rounds\n", n,
              kRounds);
  std::printf("%-34s %10s %10s %8s %12s\n", "scenario", "queries/s", "theory/s", "ratio",
              "frames/query");
  int port = 0;
  std::vector<double> paced, unpaced, frames, bits, bare, bare_unpaced, p50;
  double bare_bits = 0;
  for (int r = 0; r < kRounds; ++r) {
    const CanRun p = MeasureCanSession(CanPort(++port), kCanBitrate, n);
    paced.push_back(p.per_s);
    frames.push_back(p.frames_per_query);
    bits.push_back(p.bits_per_query);
    p50.push_back(p.p50_us);
    unpaced.push_back(MeasureCanSession(CanPort(++port), 0, n).per_s);
    bare.push_back(MeasureCanPingPong(CanPort(++port), kCanBitrate, n, &bare_bits));
    bare_unpaced.push_back(MeasureCanPingPong(CanPort(++port), 0, n, &bare_bits));
  }
  const double q = Median(paced), b = Median(bits);
  const double theory = b > 0 ? kCanBitrate / b : 0;
  const double ratio = theory > 0 ? q / theory : 0;
  const double bare_theory = kCanBitrate / bare_bits;
  const double turnaround_us = Median(unpaced) > 0 ? 1e6 / Median(unpaced) : 0;
  // Typical query: theoretical time / the median query time, which host stalls do not move.
  const double ratio_p50 = Median(p50) > 0 ? (1e6 / theory) / Median(p50) : 0;
  std::printf("%-34s %10.0f %10.0f %8.3f %12.2f  (p50: %.0f us, ratio %.3f)\n",
              "session, paced 250 kbit/s", q, theory, ratio, Median(frames), Median(p50),
              ratio_p50);
  std::printf("%-34s %10.0f %10s %8s\n", "session, unpaced", Median(unpaced), "-", "-");
  std::printf("%-34s %10.0f %10.0f %8.3f\n", "bare ping-pong, paced 250 kbit/s", Median(bare),
              bare_theory, Median(bare) / bare_theory);
  std::printf("%-34s %10.0f %10s %8s\n", "bare ping-pong, unpaced", Median(bare_unpaced), "-", "-");
  std::printf(
      "theory/s = bit rate / (command + reply frame bits, exact stuffing); minimum 2 frames per\n"
      "query (one 8-byte command, one 8-byte reply, §3.1). The unpaced session's query time\n"
      "(%.0f us) is the turnaround the theory leaves out.\n\n",
      turnaround_us);
  drivegw::bench::Report({"P3",
                          "trinamic_frames_per_op",
                          Median(frames),
                          "frames",
                          "=2",
                          "protocol minimum: one command + one reply frame per query",
                          {{"minimum", 2},
                           {"citation",
                            "trinamic-sixpack.md §3.1 (L289-291): 8-byte command to "
                            "ID A<<3, 8-byte reply to ID RA<<3"},
                           {"operation", "position query $20 (QueryPosition) over CAN"}}});
  drivegw::bench::Report(
      {"P3",
       "trinamic_ops_per_s_ratio",
       ratio,
       "ratio",
       ">=0.95",
       "theoretical queries/s = 250000 bit/s / bits per query (decision 805, 1099)",
       {{"queries_per_s", q},
        {"ratio_p50", ratio_p50},
        {"p50_query_us", Median(p50)},
        {"theory_per_s", theory},
        {"bits_per_query", b},
        {"bitrate", kCanBitrate},
        {"unpaced_queries_per_s", Median(unpaced)},
        {"unpaced_query_us", turnaround_us},
        {"theory_with_turnaround_ratio", q * (b / kCanBitrate + turnaround_us * 1e-6)},
        {"bare_pingpong_per_s", Median(bare)},
        {"bare_pingpong_ratio", Median(bare) / bare_theory},
        {"bare_pingpong_unpaced_per_s", Median(bare_unpaced)},
        {"loadavg", LoadAverage()},
        {"n", n}}});
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(1, std::atoi(argv[1])) : 500;
  drivegw::log::SetLevel(drivegw::log::Level::kWarn);
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
  BenchCan(n);
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
