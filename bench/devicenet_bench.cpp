// LinMot DeviceNet on the user-space CAN bus (UDP multicast): frames on the bus per poll cycle
// against the protocol minimum (linmot-devicenet.md §5.8: one frame per direction up to 8 bytes,
// ceil(n/7) fragments above), and achieved poll cycles per second against a bare frame
// ping-pong between two channels on the same bus, both measured in the same run. Issue 10 P3:
// the same polls on the bus paced at 125 kbit/s (decision 805) against the theoretical rate,
// bit rate / bits per poll cycle (exact frame lengths of the frames seen on the bus).
// Run: build/bench/devicenet_bench [seconds per scenario, default 2]
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/core/log.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/codec_can.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/session.h"
#include "adapters/transport/can_bit_timing.h"
#include "adapters/transport/can_channel.h"
#include "bench/report.h"
#include "sim/linmot_devicenet/server.h"

namespace {

using namespace std::chrono_literals;
using SteadyTime = std::chrono::steady_clock;
namespace dn = drivegw::linmot::devicenet;

constexpr char kGroup[] = "239.74.163.97";

uint16_t Port(int n) { return static_cast<uint16_t>(20000 + (::getpid() * 8 + n) % 40000); }

// DeviceNet's lowest bit rate (ODVA Vol. 3 §9: 125, 250, 500 kbit/s); the longest frames.
constexpr uint32_t kPacedBitrate = 125000;

// `bitrate` 0: unpaced; otherwise every node paces its own frames (decision 805).
drivegw::CanBusConfig Bus(uint16_t port, uint32_t bitrate = 0) {
  drivegw::CanBusConfig bus;
  bus.kind = drivegw::CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = port;
  bus.bitrate = bitrate;
  return bus;
}

std::unique_ptr<drivegw::transport::CanChannel> Open(uint16_t port, uint32_t bitrate = 0) {
  auto ch = drivegw::transport::OpenCanChannel(Bus(port, bitrate));
  if (!ch.ok()) {
    std::fprintf(stderr, "open bus: %s\n", std::string(ch.status().message()).c_str());
    std::exit(1);
  }
  return *std::move(ch);
}

// §5.8: frames one I/O message of `size` bytes takes on the bus.
size_t FramesFor(size_t size) {
  return size <= dn::kMaxFrameData ? 1 : (size + dn::kIoFragmentData - 1) / dn::kIoFragmentData;
}

// A session peer with a fixed image; `urgent` makes every poll leave as soon as the previous
// one is answered (the bus-limited rate), otherwise the poll period paces it.
class BenchPeer final : public dn::SessionPeer {
 public:
  BenchPeer(std::vector<uint8_t> image, bool urgent) : image_(std::move(image)), urgent_(urgent) {}
  std::vector<uint8_t> BuildPollCommand() noexcept override { return image_; }
  void OnPollResponse(std::span<const uint8_t>, drivegw::TimePoint) noexcept override {
    std::lock_guard lock(mu_);
    ++responses_;
    if (recording_) times_.push_back(SteadyTime::now());
    cv_.notify_all();
  }
  void Record(bool on) {
    std::lock_guard lock(mu_);
    recording_ = on;
  }
  // Median time between consecutive poll responses while recording, in µs.
  double MedianCycleUs() {
    std::lock_guard lock(mu_);
    std::vector<double> d;
    for (size_t i = 1; i < times_.size(); ++i) {
      d.push_back(std::chrono::duration<double, std::micro>(times_[i] - times_[i - 1]).count());
    }
    if (d.empty()) return 0;
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2];
  }
  bool HasUrgentRequest() noexcept override { return urgent_; }
  void OnLinkChange(dn::LinkState state, const std::string&) noexcept override {
    std::lock_guard lock(mu_);
    online_ = state == dn::LinkState::kOnline;
    cv_.notify_all();
  }
  bool WaitOnline(SteadyTime::duration timeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return online_; });
  }
  // Blocks until `t` (woken by responses, which re-check the time).
  void WaitUntil(SteadyTime::time_point t) {
    std::unique_lock lock(mu_);
    cv_.wait_until(lock, t, [&] { return SteadyTime::now() >= t; });
  }
  uint64_t responses() {
    std::lock_guard lock(mu_);
    return responses_;
  }

 private:
  std::vector<uint8_t> image_;
  bool urgent_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool online_ = false;
  uint64_t responses_ = 0;
  bool recording_ = false;
  std::vector<SteadyTime::time_point> times_;
};

// Bits on the wire of every frame a passive (unpaced) listener sees while counting: the exact
// lengths of the frames the gateway and the drive sent (decision 805). A listener on a loaded
// host may miss a frame; the mean length per frame does not depend on that.
class BitCounter {
 public:
  explicit BitCounter(uint16_t port) : channel_(Open(port)), thread_([this] { Run(); }) {}
  ~BitCounter() {
    running_ = false;
    channel_->Wake();
    thread_.join();
  }
  void Count(bool on) { counting_ = on; }
  double MeanBitsPerFrame() const {
    return frames_ == 0 ? 0 : static_cast<double>(bits_) / static_cast<double>(frames_);
  }

 private:
  void Run() {
    while (running_) {
      auto f = channel_->Receive(50ms);
      if (!f.ok() || !f->has_value() || !counting_) continue;
      bits_ += drivegw::transport::CanFrameBits(**f);
      ++frames_;
    }
  }
  std::unique_ptr<drivegw::transport::CanChannel> channel_;
  std::atomic<bool> running_{true}, counting_{false};
  std::atomic<uint64_t> bits_{0}, frames_{0};
  std::thread thread_;
};

struct Result {
  double cycles_per_s = 0;
  double frames_per_cycle = 0;
  size_t minimum = 0;
  double bits_per_cycle = 0;  // minimum frames x mean frame length seen on the bus
  double p50_cycle_us = 0;    // median time between consecutive responses
  uint64_t fragment_errors = 0;
  uint64_t timeouts = 0;
};

// One drive (simulated, `layout`) polled for `seconds`; `bitrate` 0 = unpaced bus.
Result RunPolls(int port_index, const dn::IoLayout& layout, size_t motors, bool urgent,
                drivegw::Duration period, double seconds, uint32_t bitrate = 0) {
  const uint16_t port = Port(port_index);
  BitCounter bits(port);
  drivegw::sim::linmot_devicenet::DnSimOptions o;
  o.can = Bus(port, bitrate);
  o.duplicate_check_wait = 20ms;
  o.motor_count = motors;
  o.poll_modules = layout.modules;
  auto sim =
      drivegw::sim::linmot_devicenet::LinMotDnServer::Start(o, drivegw::SteadyClock::Instance());
  if (!sim.ok()) {
    std::fprintf(stderr, "sim: %s\n", std::string(sim.status().message()).c_str());
    std::exit(1);
  }
  dn::SessionOptions so;
  so.duplicate_check_wait = 20ms;
  auto session = dn::Session::Open(Open(port, bitrate), so, drivegw::SteadyClock::Instance());
  if (!session.ok()) std::exit(1);
  auto image = dn::EncodeConsumed(layout, dn::EmptyConsumed(layout));
  BenchPeer peer(*image, urgent);
  dn::PeerOptions po;
  po.name = "bench";
  po.mac_id = 5;
  po.consumed_size = dn::ConsumedSize(layout);
  po.produced_size = dn::ProducedSize(layout);
  po.poll_period = period;
  po.expected_packet_rate_ms = 200;
  auto id = (*session)->Register(po, &peer);
  if (!id.ok() || !peer.WaitOnline(10s)) {
    std::fprintf(stderr, "the simulated drive did not come online\n");
    std::exit(1);
  }
  // Warm-up, then the measured window. Frames on the bus = what the gateway sent for this drive
  // plus what the drive sent: both sides count exactly (a listener on a loaded host drops some).
  peer.WaitUntil(SteadyTime::now() + 200ms);
  const uint64_t r0 = peer.responses();
  const dn::PeerCounters c0 = *(*session)->peer_counters(*id);
  const uint64_t d0 = (*sim)->Snapshot().server.frames_sent;
  const auto t0 = SteadyTime::now();
  bits.Count(true);
  peer.Record(true);
  const auto end =
      t0 + std::chrono::duration_cast<SteadyTime::duration>(std::chrono::duration<double>(seconds));
  peer.WaitUntil(end);
  bits.Count(false);
  peer.Record(false);
  const double dt = std::chrono::duration<double>(SteadyTime::now() - t0).count();
  const uint64_t cycles = peer.responses() - r0;
  const dn::PeerCounters c1 = *(*session)->peer_counters(*id);
  const uint64_t frames =
      (c1.frames_sent - c0.frames_sent) + ((*sim)->Snapshot().server.frames_sent - d0);
  Result r;
  r.cycles_per_s = static_cast<double>(cycles) / dt;
  r.frames_per_cycle = cycles == 0 ? 0 : static_cast<double>(frames) / static_cast<double>(cycles);
  r.minimum = FramesFor(po.consumed_size) + FramesFor(po.produced_size);
  r.bits_per_cycle = bits.MeanBitsPerFrame() * static_cast<double>(r.minimum);
  r.p50_cycle_us = peer.MedianCycleUs();
  r.fragment_errors = c1.fragment_errors - c0.fragment_errors;
  r.timeouts = c1.poll_timeouts - c0.poll_timeouts;
  (*session)->Unregister(*id);
  (*session)->Stop();
  (*sim)->Stop();
  return r;
}

// Baseline: a bare request/answer of `out` + `back` frames between two channels on the bus
// (no DeviceNet stack, no simulated drive): round trips per second. Byte 0 = 0x80 marks the last
// frame of a burst, so that a frame the host drops costs one time-out, not the count.
drivegw::transport::CanFrame PingFrame(uint32_t id, bool last) {
  std::vector<uint8_t> payload(8, 0);
  payload[0] = last ? 0x80 : 0x00;
  return drivegw::transport::MakeCanFrame(id, payload);
}

// Bits one ping-pong round trip puts on the wire (the frames PingPong sends).
double PingPongBits(size_t out, size_t back) {
  double bits = 0;
  for (size_t i = 0; i < out; ++i)
    bits += drivegw::transport::CanFrameBits(PingFrame(0x42D, i + 1 == out));
  for (size_t i = 0; i < back; ++i)
    bits += drivegw::transport::CanFrameBits(PingFrame(0x3C5, i + 1 == back));
  return bits;
}

double PingPong(int port_index, size_t out, size_t back, double seconds, uint32_t bitrate = 0) {
  const uint16_t port = Port(port_index);
  auto a = Open(port, bitrate);
  auto b = Open(port, bitrate);
  const auto frame = PingFrame;
  std::atomic<bool> running{true};
  std::thread echo([&] {
    while (running) {
      auto f = b->Receive(50ms);
      if (!f.ok() || !f->has_value() || ((*f)->data[0] & 0x80) == 0) continue;
      for (size_t i = 0; i < back; ++i) (void)b->Send(frame(0x3C5, i + 1 == back));
    }
  });
  uint64_t trips = 0;
  const auto t0 = SteadyTime::now();
  const auto end =
      t0 + std::chrono::duration_cast<SteadyTime::duration>(std::chrono::duration<double>(seconds));
  while (SteadyTime::now() < end) {
    for (size_t i = 0; i < out; ++i) (void)a->Send(frame(0x42D, i + 1 == out));
    for (;;) {
      auto f = a->Receive(50ms);
      if (!f.ok() || !f->has_value()) break;  // lost: next round
      if ((*f)->data[0] & 0x80) {
        ++trips;
        break;
      }
    }
  }
  const double dt = std::chrono::duration<double>(SteadyTime::now() - t0).count();
  running = false;
  b->Wake();
  echo.join();
  return static_cast<double>(trips) / dt;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double LoadAverage() {
  double l[1] = {0};
  return ::getloadavg(l, 1) == 1 ? l[0] : -1;
}

// Issue 10 P3: back-to-back polls on the bus paced at kPacedBitrate (decision 805) against the
// theoretical rate bitrate / bits per cycle; a bare ping-pong of the same frame counts, paced
// alike, shows what the bus itself reaches; its unpaced twin gives the turnaround (two UDP hops
// and wake-ups) that the theory leaves out.
void BenchPaced(double seconds, int& port) {
  struct Case {
    const char* name;
    const char* id;
    dn::IoLayout layout;
    size_t motors;
  };
  const Case cases[] = {{"layout P 6/8 B", "layout_p", dn::DefaultLayoutP(), 1},
                        {"example 1 22/24 B", "example1", dn::Example1Layout(), 4}};
  constexpr int kRounds = 3;
  std::printf("\nPaced at %u bit/s (decision 805), back-to-back polls, %d rounds, medians\n",
              kPacedBitrate, kRounds);
  std::printf("%-20s %9s %9s %7s %7s %11s %9s %7s %8s %7s %8s\n", "layout", "cycles/s", "theory/s",
              "ratio", "p50", "bits/cycle", "bare pp/s", "bare", "turn us", "frames", "minimum");
  nlohmann::json detail = nlohmann::json::object();
  double layout_p_ratio = 0, layout_p_frames = 0;
  size_t layout_p_minimum = 0;
  for (const Case& c : cases) {
    const size_t out = FramesFor(dn::ConsumedSize(c.layout));
    const size_t back = FramesFor(dn::ProducedSize(c.layout));
    std::vector<double> cycles, frames, bits, bare, unpaced, p50;
    Result r;
    for (int round = 0; round < kRounds; ++round) {
      r = RunPolls(++port, c.layout, c.motors, true, 10ms, seconds / kRounds, kPacedBitrate);
      cycles.push_back(r.cycles_per_s);
      frames.push_back(r.frames_per_cycle);
      bits.push_back(r.bits_per_cycle);
      p50.push_back(r.p50_cycle_us);
      bare.push_back(PingPong(++port, out, back, seconds / kRounds, kPacedBitrate));
      unpaced.push_back(PingPong(++port, out, back, seconds / kRounds));
    }
    const double cps = Median(cycles), bpc = Median(bits);
    const double theory = bpc > 0 ? kPacedBitrate / bpc : 0;
    const double ratio = theory > 0 ? cps / theory : 0;
    const double bare_theory = kPacedBitrate / PingPongBits(out, back);
    const double bare_ratio = Median(bare) / bare_theory;
    // Round trip of the same frames without pacing: what an operation costs besides bit time.
    const double turnaround_us = Median(unpaced) > 0 ? 1e6 / Median(unpaced) : 0;
    // Typical cycle: the median interval, which host stalls (load) do not move.
    const double ratio_p50 = Median(p50) > 0 ? (1e6 / Median(p50)) / theory : 0;
    std::printf("%-20s %9.1f %9.1f %7.3f %7.3f %11.1f %9.1f %7.3f %8.1f %7.2f %8zu\n", c.name, cps,
                theory, ratio, ratio_p50, bpc, Median(bare), bare_ratio, turnaround_us,
                Median(frames), r.minimum);
    detail[c.id] = {
        {"cycles_per_s", cps},
        {"theory_per_s", theory},
        {"ratio", ratio},
        {"ratio_p50", ratio_p50},
        {"p50_cycle_us", Median(p50)},
        {"bits_per_cycle", bpc},
        {"frames_per_cycle", Median(frames)},
        {"minimum_frames", r.minimum},
        {"bare_pingpong_per_s", Median(bare)},
        {"bare_pingpong_ratio", bare_ratio},
        {"unpaced_round_trip_us", turnaround_us},
        {"theory_with_turnaround_ratio", cps * (bpc / kPacedBitrate + turnaround_us * 1e-6)}};
    if (std::string(c.id) == "layout_p") {
      layout_p_ratio = ratio;
      layout_p_frames = Median(frames);
      layout_p_minimum = r.minimum;
    }
  }
  std::printf(
      "theory/s = bit rate / bits per cycle (the minimum frames at the exact lengths seen on the\n"
      "bus); p50 = theoretical / median cycle time (host stalls do not move it); bare pp = a\n"
      "paced ping-pong of the same frame counts between two channels; turn us =\n"
      "the unpaced round trip of those frames (UDP hops + wake-ups: the turnaround theory "
      "omits).\n");
  const double load = LoadAverage();
  detail["bitrate"] = kPacedBitrate;
  detail["loadavg"] = load;
  drivegw::bench::Report({"P3",
                          "devicenet_frames_per_op",
                          layout_p_frames,
                          "frames",
                          "=" + std::to_string(layout_p_minimum),
                          "protocol minimum: one poll command + one poll response frame "
                          "(linmot-devicenet.md §5.8)",
                          {{"scenario", "layout P 6/8 B, back-to-back, paced"},
                           {"minimum", layout_p_minimum},
                           {"citation",
                            "linmot-devicenet.md §5.8: one frame per direction up to "
                            "8 bytes, ceil(n/7) fragments above"},
                           {"example1_frames_per_cycle", detail["example1"]["frames_per_cycle"]},
                           {"example1_minimum", detail["example1"]["minimum_frames"]}}});
  drivegw::bench::Report(
      {"P3", "devicenet_ops_per_s_ratio", layout_p_ratio, "ratio", ">=0.95",
       "theoretical poll cycles/s = 125000 bit/s / bits per cycle (decision 805)", detail});
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 2.0;
  drivegw::log::SetLevel(drivegw::log::Level::kWarn);
  std::printf("LinMot DeviceNet on the user-space CAN bus (%s), %.1f s per scenario\n\n", kGroup,
              seconds);
  std::printf("%-34s %12s %12s %10s %12s %8s\n", "scenario", "cycles/s", "baseline/s", "ratio",
              "frames/cycle", "minimum");
  struct Scenario {
    const char* name;
    dn::IoLayout layout;
    size_t motors;
    bool urgent;
    drivegw::Duration period;
  };
  const Scenario scenarios[] = {
      {"layout P 6/8 B, back-to-back", dn::DefaultLayoutP(), 1, true, 10ms},
      {"example 1 22/24 B, back-to-back", dn::Example1Layout(), 4, true, 10ms},
      {"layout P 6/8 B, 10 ms period", dn::DefaultLayoutP(), 1, false, 10ms},
  };
  // Rounds interleave measurement and baseline, so that the host's load hits both alike
  // (2 shared cores); medians are printed.
  constexpr int kRounds = 3;
  int port = 0;
  for (const Scenario& s : scenarios) {
    const size_t out = FramesFor(dn::ConsumedSize(s.layout));
    const size_t back = FramesFor(dn::ProducedSize(s.layout));
    std::vector<double> cycles, baselines, frames;
    Result r;
    for (int round = 0; round < kRounds; ++round) {
      r = RunPolls(++port, s.layout, s.motors, s.urgent, s.period, seconds / kRounds);
      cycles.push_back(r.cycles_per_s);
      frames.push_back(r.frames_per_cycle);
      // Baseline in the same run: bare frames (back-to-back) or the nominal rate (paced).
      baselines.push_back(s.urgent ? PingPong(++port, out, back, seconds / kRounds)
                                   : 1.0 / std::chrono::duration<double>(s.period).count());
    }
    const double c = Median(cycles), b = Median(baselines);
    std::printf("%-34s %12.0f %12.0f %10.2f %12.2f %8zu", s.name, c, b, b > 0 ? c / b : 0.0,
                Median(frames), r.minimum);
    if (r.fragment_errors || r.timeouts) {
      std::printf("  (last round: fragment errors %llu, time-outs %llu)",
                  static_cast<unsigned long long>(r.fragment_errors),
                  static_cast<unsigned long long>(r.timeouts));
    }
    std::printf("\n");
  }
  std::printf(
      "\nframes/cycle: every frame the gateway and the drive sent (polls, responses, fragments,\n"
      "keep-alives) per answered poll; minimum = one poll command + one poll response (§5.8).\n"
      "baseline/s: back-to-back rows, a bare ping-pong of the same frame counts between two\n"
      "channels on the same bus; paced rows, the nominal rate 1/period.\n");
  BenchPaced(seconds, port);
  return 0;
}
