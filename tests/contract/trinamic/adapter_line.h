// Helpers of the Trinamic ADAPTER contract cases (trinamic-sixpack.md §8, target ADAPTER): the real
// TrinamicDrive from the factory against the simulated SIXpack on a real pty (wire trace
// `words()` / `wire()`) or on the UDP multicast CAN bus (a sniffer channel sees every frame).
// Real time (SteadyClock); waits are bounded conditions, never sleeps used as assertions.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/transport/can_channel.h"
#include "adapters/trinamic/drive.h"
#include "adapters/trinamic/factory.h"
#include "sim/trinamic/can_server.h"
#include "sim/trinamic/server.h"
#include "tests/support/wait_status.h"

namespace drivegw::trinamic::adapter_contract {

using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;

// 1 mm = 1 microstep at the PACK defaults (clkdiv 5, div 2, §5.1/§5.3): the default ramp
// (vmax 511, amax 128) in mm/s and mm/s², so a move sends no `$14` before its `$23`.
inline constexpr double kV511 = 511 * 20e6 / (6 * 65536.0);
inline constexpr double kA128 = 7.8125 * 128 * 20e6 / (6 * 65536.0);

inline std::string TempLink() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("dgw-trct-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

inline uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

inline CanBusConfig UdpBus(uint16_t port) {
  CanBusConfig c;
  c.kind = CanBusConfig::Kind::kUdpMulticast;
  c.group = "239.74.163.92";
  c.port = port;
  return c;
}

// §8 common setup: A = 01, RA = F0, SIXpack; 1 mm = 1 microstep.
inline DriveConfig AxisConfig(const std::string& name, uint8_t axis) {
  DriveConfig c;
  c.name = name;
  c.family = kFamilyName;
  c.axis.min_mm = -20000;
  c.axis.max_mm = 20000;
  c.axis.max_velocity_mm_s = 26000;
  c.axis.max_acceleration_mm_s2 = 120000;
  c.timeouts.request = 2000ms;
  c.timeouts.accept = 1000ms;  // generous: CI shares two cores; nothing here measures timing
  TrinamicConfig t;
  t.address = 1;
  t.axis = axis;
  t.axes = 6;
  t.microsteps_per_unit = 1;
  t.poll_period = 5ms;
  t.reply_timeout = 200ms;
  t.offline_after_misses = 3;
  c.trinamic = t;
  return c;
}

// The Pack's own queries (`$20`, `$21`, `$43`, `$28` mask 0, `$30`): everything else in a trace
// was sent on behalf of an API call.
inline bool IsPoll(const Bytes& w) {
  return w.size() == 9 &&
         (w[1] == 0x20 || w[1] == 0x21 || w[1] == 0x43 || w[1] == 0x28 || w[1] == 0x30);
}
inline std::vector<Bytes> Commands(const std::vector<Bytes>& words) {
  std::vector<Bytes> out;
  for (const Bytes& w : words) {
    if (!IsPoll(w)) out.push_back(w);
  }
  return out;
}
inline std::optional<size_t> IndexOf(const std::vector<Bytes>& words, const Bytes& word,
                                     size_t from = 0) {
  for (size_t i = from; i < words.size(); ++i) {
    if (words[i] == word) return i;
  }
  return std::nullopt;
}

inline DriveStatus WaitStatus(Drive* d, const std::function<bool(const DriveStatus&)>& pred,
                              std::chrono::milliseconds timeout = 5000ms) {
  return test_support::WaitStatus(*d, pred, timeout);
}

inline CommandInfo WaitFinal(Drive* d, uint64_t id, std::chrono::milliseconds timeout = 5000ms) {
  return test_support::WaitCommandFinal(*d, id, timeout);
}

// Waits (bounded, real time) until `pred` holds; returns its last value.
inline bool Eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout = 5s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return pred();
    std::this_thread::sleep_for(1ms);  // polling interval of a bounded wait, not an assertion
  }
  return true;
}

// Drives owned by a test; deactivated before the simulator stops.
class Drives {
 public:
  ~Drives() { Clear(); }
  void Clear() {
    for (auto& d : drives_) d->Deactivate();
    drives_.clear();
  }
  // Factory + Activate; waits until the drive left OFFLINE. nullptr (with a test failure) on error.
  Drive* Activate(const DriveConfig& c) {
    auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
    if (!d.ok()) {
      ADD_FAILURE() << d.status();
      return nullptr;
    }
    if (auto s = (*d)->Activate(); !s.ok()) {
      ADD_FAILURE() << s;
      return nullptr;
    }
    drives_.push_back(std::move(*d));
    Drive* out = drives_.back().get();
    WaitStatus(out, [](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    return out;
  }
  static TrinamicDrive* Trinamic(Drive* d) { return dynamic_cast<TrinamicDrive*>(d); }

 private:
  std::vector<std::unique_ptr<Drive>> drives_;
};

// The simulated SIXpack on a real pty (real time) and the drives on it.
class PtyPack {
 public:
  explicit PtyPack(sim::trinamic::ServerOptions options = {}) {
    options.pty_path = TempLink();
    auto s = sim::trinamic::TrinamicServer::Start(options, SteadyClock::Instance());
    if (!s.ok()) {
      ADD_FAILURE() << s.status();
      return;
    }
    server = *std::move(s);
  }
  ~PtyPack() {
    drives.Clear();
    if (server) server->Stop();
  }
  bool ok() const { return server != nullptr; }
  DriveConfig Config(const std::string& name, uint8_t axis) const {
    DriveConfig c = AxisConfig(name, axis);
    c.trinamic->serial = SerialLineConfig{server->slave_path(), 19200, false, 6000us};
    return c;
  }
  // Activated and enabled, its `$11` executed by the PACK (so it is not part of a later trace).
  Drive* Enabled(const DriveConfig& c) {
    Drive* d = drives.Activate(c);
    if (d == nullptr) return nullptr;
    auto r = d->Enable();
    EXPECT_TRUE(r.ok()) << r.status();
    const uint8_t m = c.trinamic->axis;
    EXPECT_TRUE(Eventually(
        [&] { return Sim<int>([&](auto& p) { return p.registers(m).current_index[1]; }) == 2; }));
    return d;
  }
  // Returns once the simulator executed every word the gateway wrote so far: a reply sent later
  // answers a query the session sent after them (it never interleaves, L357). Needs a drive.
  void Settle() {
    const uint64_t n = server->counters().replies;
    EXPECT_TRUE(Eventually([&] { return server->counters().replies > n; }));
  }
  // Settle, then empty the trace: it holds only what the test causes next.
  void ClearWords() {
    Settle();
    server->ClearWords();
  }
  template <typename T>
  T Sim(const std::function<T(sim::trinamic::Controller&)>& fn) {
    T out{};
    server->WithController([&](sim::trinamic::Controller& c) { out = fn(c); });
    return out;
  }

  std::unique_ptr<sim::trinamic::TrinamicServer> server;
  Drives drives;
};

// Every frame on a UDP multicast CAN bus, collected by a thread (CT-20, CT-50 wire checks).
class CanSniffer {
 public:
  explicit CanSniffer(const CanBusConfig& bus) {
    auto c = transport::OpenCanChannel(bus);
    if (!c.ok()) {
      ADD_FAILURE() << c.status();
      return;
    }
    channel_ = *std::move(c);
    thread_ = std::thread([this] {
      while (!stop_) {
        auto f = channel_->Receive(5ms);
        if (!f.ok() || !f->has_value()) continue;
        std::lock_guard lock(mu_);
        frames_.push_back(**f);
      }
    });
  }
  ~CanSniffer() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::vector<transport::CanFrame> frames() const {
    std::lock_guard lock(mu_);
    return frames_;
  }
  // The data bytes of every frame with `id`.
  std::vector<Bytes> DataOn(uint32_t id) const {
    std::vector<Bytes> out;
    for (const auto& f : frames()) {
      if (f.id == id) out.emplace_back(f.data.begin(), f.data.begin() + f.dlc);
    }
    return out;
  }

 private:
  std::unique_ptr<transport::CanChannel> channel_;
  mutable std::mutex mu_;
  std::vector<transport::CanFrame> frames_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The simulated SIXpack on the UDP multicast CAN bus (real time).
inline std::unique_ptr<sim::trinamic::TrinamicCanServer> StartCanPack(
    const CanBusConfig& bus, const std::function<void(sim::trinamic::CanServerOptions&)>& adjust =
                                 [](sim::trinamic::CanServerOptions&) {}) {
  sim::trinamic::CanServerOptions o;
  o.can = bus;
  adjust(o);
  auto s = sim::trinamic::TrinamicCanServer::Start(o, SteadyClock::Instance());
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *std::move(s) : nullptr;
}

}  // namespace drivegw::trinamic::adapter_contract
