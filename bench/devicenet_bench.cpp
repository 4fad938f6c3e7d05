// LinMot DeviceNet on the user-space CAN bus (UDP multicast): frames on the bus per poll cycle
// against the protocol minimum (linmot-devicenet.md §5.8: one frame per direction up to 8 bytes,
// ceil(n/7) fragments above), and achieved poll cycles per second against a bare frame
// ping-pong between two channels on the same bus, both measured in the same run.
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
#include "adapters/transport/can_channel.h"
#include "sim/linmot_devicenet/server.h"

namespace {

using namespace std::chrono_literals;
using SteadyTime = std::chrono::steady_clock;
namespace dn = drivegw::linmot::devicenet;

constexpr char kGroup[] = "239.74.163.97";

uint16_t Port(int n) { return static_cast<uint16_t>(20000 + (::getpid() * 8 + n) % 40000); }

drivegw::CanBusConfig Bus(uint16_t port) {
  drivegw::CanBusConfig bus;
  bus.kind = drivegw::CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = port;
  return bus;
}

std::unique_ptr<drivegw::transport::CanChannel> Open(uint16_t port) {
  auto ch = drivegw::transport::OpenCanChannel(Bus(port));
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
    cv_.notify_all();
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
};

struct Result {
  double cycles_per_s = 0;
  double frames_per_cycle = 0;
  size_t minimum = 0;
  uint64_t fragment_errors = 0;
  uint64_t timeouts = 0;
};

// One drive (simulated, `layout`) polled for `seconds`.
Result RunPolls(int port_index, const dn::IoLayout& layout, size_t motors, bool urgent,
                drivegw::Duration period, double seconds) {
  const uint16_t port = Port(port_index);
  drivegw::sim::linmot_devicenet::DnSimOptions o;
  o.can = Bus(port);
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
  auto session = dn::Session::Open(Open(port), so, drivegw::SteadyClock::Instance());
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
  const auto end =
      t0 + std::chrono::duration_cast<SteadyTime::duration>(std::chrono::duration<double>(seconds));
  peer.WaitUntil(end);
  const double dt = std::chrono::duration<double>(SteadyTime::now() - t0).count();
  const uint64_t cycles = peer.responses() - r0;
  const dn::PeerCounters c1 = *(*session)->peer_counters(*id);
  const uint64_t frames =
      (c1.frames_sent - c0.frames_sent) + ((*sim)->Snapshot().server.frames_sent - d0);
  Result r;
  r.cycles_per_s = static_cast<double>(cycles) / dt;
  r.frames_per_cycle = cycles == 0 ? 0 : static_cast<double>(frames) / static_cast<double>(cycles);
  r.minimum = FramesFor(po.consumed_size) + FramesFor(po.produced_size);
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
double PingPong(int port_index, size_t out, size_t back, double seconds) {
  const uint16_t port = Port(port_index);
  auto a = Open(port);
  auto b = Open(port);
  auto frame = [](uint32_t id, bool last) {
    std::vector<uint8_t> payload(8, 0);
    payload[0] = last ? 0x80 : 0x00;
    return drivegw::transport::MakeCanFrame(id, payload);
  };
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
  return 0;
}
