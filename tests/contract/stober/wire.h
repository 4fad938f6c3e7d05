// Test helpers for the STOBER adapter contract cases (stober-motion.md §10.10) and the wire-level
// AXIS smoke: a sniffer CanChannel on the same UDP multicast bus that records every frame with
// its receive time, the decoders of the default PDO layout (object_map.h, decision 1175), and a
// fixture with the simulated axis (sim/stober AxisServer) and the drive from CreateStoberDrive.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/stober/drive.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "adapters/transport/can_channel.h"
#include "sim/stober/server.h"

namespace drivegw::stober::wire {

using namespace std::chrono_literals;
namespace ss = drivegw::sim::stober;
namespace co = drivegw::canopen;
using SteadyTime = std::chrono::steady_clock::time_point;

inline constexpr uint8_t kNode = 21;
inline constexpr double kCycleMs = 4;  // A150 of the simulated axis in these tests

// Predefined-connection-set COB-IDs (CiA 301 §7.3.5) of the node.
inline constexpr uint32_t kTpdo1 = 0x180 + kNode;
inline constexpr uint32_t kTpdo2 = 0x280 + kNode;
inline constexpr uint32_t kRpdo1 = 0x200 + kNode;
inline constexpr uint32_t kRpdo2 = 0x300 + kNode;
inline constexpr uint32_t kRpdo3 = 0x400 + kNode;
inline constexpr uint32_t kRpdo4 = 0x500 + kNode;
inline constexpr uint32_t kSdoRx = 0x600 + kNode;  // master → node

struct Seen {
  SteadyTime at;
  transport::CanFrame frame;
};

// Frames the master sends to the node (RPDO1-4, SDO requests): what "touching the drive" means.
inline bool ToNode(const transport::CanFrame& f) {
  return f.id == kRpdo1 || f.id == kRpdo2 || f.id == kRpdo3 || f.id == kRpdo4 || f.id == kSdoRx;
}

// RPDO1 = 6040h · I401 · I403 · I402 (decision 1175).
struct Rpdo1 {
  uint16_t control_word = 0;
  int command = 0;
  double position = 0;
  bool execute = false;
};
// TPDO1 = 6041h · I89 · I90 · 4000h packed flags.
struct Tpdo1 {
  uint16_t status_word = 0;
  int plc_state = 0;
  int cause = 0;
  uint32_t flags = 0;
  bool done() const { return (flags & status_bit::kDone) != 0; }
  bool error() const { return (flags & status_bit::kError) != 0; }
};

inline std::vector<double> Unpack(co::PdoKind kind, uint16_t number, const transport::CanFrame& f) {
  const PdoLayout* layout = FindDefaultPdo(kind, number);
  EXPECT_NE(layout, nullptr);
  if (layout == nullptr) return {};
  auto v = UnpackLayout(*layout, f.payload());
  EXPECT_TRUE(v.ok()) << v.status();
  return v.ok() ? *v : std::vector<double>{};
}
inline Rpdo1 DecodeRpdo1(const transport::CanFrame& f) {
  const std::vector<double> v = Unpack(co::PdoKind::kRpdo, 1, f);
  if (v.size() != 4) return {};
  return {static_cast<uint16_t>(v[0]), static_cast<int>(v[1]), v[2], v[3] != 0};
}
inline Tpdo1 DecodeTpdo1(const transport::CanFrame& f) {
  const std::vector<double> v = Unpack(co::PdoKind::kTpdo, 1, f);
  if (v.size() != 4) return {};
  return {static_cast<uint16_t>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]),
          static_cast<uint32_t>(v[3])};
}
// {position actual, velocity actual} in user units.
inline std::vector<double> DecodeTpdo2(const transport::CanFrame& f) {
  return Unpack(co::PdoKind::kTpdo, 2, f);
}

// "+1.234ms 215#1F00050000000001" per frame from index `from` on: the wire in failure messages.
inline std::string Trace(const std::vector<Seen>& all, size_t from = 0) {
  std::string out;
  for (size_t i = from; i < all.size(); ++i) {
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(all[i].at - all[from].at);
    out += "\n  +" + std::to_string(us.count()) + "us " + transport::FormatCanFrame(all[i].frame);
  }
  return out;
}

// A listener on the bus: records every frame (a UDP multicast socket of its own receives what
// the master and the node send, decision 802).
class Sniffer {
 public:
  explicit Sniffer(const CanBusConfig& bus) {
    auto ch = transport::OpenCanChannel(bus);
    EXPECT_TRUE(ch.ok()) << ch.status();
    if (!ch.ok()) return;
    channel_ = std::move(*ch);
    thread_ = std::thread([this] { Run(); });
  }
  ~Sniffer() {
    stop_ = true;
    if (channel_) channel_->Wake();
    if (thread_.joinable()) thread_.join();
  }
  Sniffer(const Sniffer&) = delete;
  Sniffer& operator=(const Sniffer&) = delete;

  std::vector<Seen> frames() const {
    std::lock_guard lock(mu_);
    return frames_;
  }
  size_t size() const {
    std::lock_guard lock(mu_);
    return frames_.size();
  }
  // Frames from index `from` on with this COB-ID.
  std::vector<Seen> With(uint32_t id, size_t from = 0) const {
    std::vector<Seen> out;
    const std::vector<Seen> all = frames();
    for (size_t i = from; i < all.size(); ++i) {
      if (all[i].frame.id == id) out.push_back(all[i]);
    }
    return out;
  }
  // The frames once `pred` holds for them (bounded wait: the sniffer's socket may lag the
  // drive's on a loaded machine); a failure names `what`.
  std::vector<Seen> Until(const std::function<bool(const std::vector<Seen>&)>& pred,
                          const std::string& what) const {
    EXPECT_TRUE(WaitFor(pred)) << "never on the bus: " << what;
    return frames();
  }
  // Some frame at index >= from with this COB-ID satisfies `pred`.
  static bool Any(const std::vector<Seen>& f, size_t from, uint32_t id,
                  const std::function<bool(const transport::CanFrame&)>& pred) {
    for (size_t i = from; i < f.size(); ++i) {
      if (f[i].frame.id == id && pred(f[i].frame)) return true;
    }
    return false;
  }
  // Waits (bounded) until `pred` holds for the recorded frames.
  bool WaitFor(const std::function<bool(const std::vector<Seen>&)>& pred,
               std::chrono::milliseconds timeout = 3000ms) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::unique_lock lock(mu_);
    while (!pred(frames_)) {
      if (cv_.wait_until(lock, deadline) == std::cv_status::timeout) return pred(frames_);
    }
    return true;
  }

 private:
  void Run() {
    while (!stop_) {
      auto r = channel_->Receive(20ms);
      if (!r.ok() || !r->has_value()) continue;
      const SteadyTime at = std::chrono::steady_clock::now();
      {
        std::lock_guard lock(mu_);
        frames_.push_back({at, **r});
      }
      cv_.notify_all();
    }
  }

  std::unique_ptr<transport::CanChannel> channel_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;
  mutable std::condition_variable_any cv_;
  std::vector<Seen> frames_;
};

inline uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

inline uint32_t Id(const char* param) {
  const CanOpenAddress a = *ToCanOpen(P(param));
  return static_cast<uint32_t>(a.index) << 8 | a.sub_index;
}

// Simulated axis + sniffer + drive on a bus of their own (group 239.74.163.99, random port).
class WireTest : public ::testing::Test {
 protected:
  void Start(ss::AxisServerOptions o = {}, double max_mm = 200, double min_mm = -200) {
    bus_.kind = CanBusConfig::Kind::kUdpMulticast;
    bus_.group = "239.74.163.99";
    bus_.port = RandomPort();
    sniffer_ = std::make_unique<Sniffer>(bus_);
    o.node_id = kNode;
    o.can = bus_;
    // A150 = 4 ms unless the case sets it: the adapter then holds Execute low for 8 ms (decision
    // 1197), so a simulator thread descheduled for a few ms on a loaded machine still sees the
    // low level in a cycle of its own (decision 1226).
    if (!o.axis.cycle_ms) o.axis.cycle_ms = kCycleMs;
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    if (before_drive_) before_drive_(*server_);
    DriveConfig c;
    c.name = "st-ct";
    c.family = kFamilyName;
    c.can = bus_;
    c.node_id = kNode;
    c.axis.min_mm = min_mm;
    c.axis.max_mm = max_mm;
    c.axis.max_velocity_mm_s = 1000;
    c.axis.max_acceleration_mm_s2 = 10000;
    c.canopen.heartbeat = 50ms;
    c.canopen.heartbeat_timeout = 200ms;
    c.canopen.sdo_timeout = 300ms;
    c.timeouts.homing = 5000ms;
    auto drive = CreateStoberDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_.reset(static_cast<StoberDrive*>(drive->release()));
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus s =
        WaitUntil([](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    ASSERT_NE(s.state, DriveState::kOffline) << s.native.text;
    if (drive_->GetStatus().state != DriveState::kEnabled) {
      auto e = drive_->Enable();
      ASSERT_TRUE(e.ok()) << e.status();
    }
    ASSERT_EQ(drive_->GetStatus().state, DriveState::kEnabled);
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
    sniffer_.reset();
  }

  DriveStatus WaitUntil(const std::function<bool(const DriveStatus&)>& pred,
                        std::chrono::steady_clock::duration timeout = 5s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    DriveStatus s = drive_->GetStatus();
    while (!pred(s) && std::chrono::steady_clock::now() < deadline) {
      s = drive_->WaitForStatus(s.sequence, deadline);
    }
    return s;
  }
  CommandInfo WaitFinal(uint64_t id) {
    WaitUntil([&](const DriveStatus&) { return IsFinal(drive_->GetCommand(id)->state); });
    return *drive_->GetCommand(id);
  }
  CommandInfo Move(const MotionCommand& cmd) {
    auto r = drive_->Move(cmd);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : CommandInfo{};
  }
  uint64_t Native(const StoberMcRequest& req) {
    auto r = drive_->SendNative(req);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? r->command_id : 0;
  }
  DriveStatus AtRest(double target) {
    return WaitUntil([&](const DriveStatus& s) {
      return std::abs(s.position_mm - target) < 1e-6 && s.state == DriveState::kEnabled;
    });
  }
  double Sim(const char* param) {
    double v = 0;
    server_->WithAxis([&](ss::MotionCore& c) { v = *c.Read(P(param)); });
    return v;
  }
  // A point in the sniffer's record after every frame the master sent so far: an SDO upload of
  // `param` whose request the sniffer must see, and the master's socket delivers in order.
  // Returns the index just after that request.
  size_t SyncedMark(const char* param = "I10") {
    const size_t before = sniffer_->size();
    EXPECT_TRUE(drive_->ReadParameter(ParameterRef{Id(param), false}).ok());
    const CanOpenAddress a = *ToCanOpen(P(param));
    size_t mark = 0;
    EXPECT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
      for (size_t i = before; i < f.size(); ++i) {
        const transport::CanFrame& x = f[i].frame;
        if (x.id == kSdoRx && x.dlc == 8 && x.data[0] == 0x40 && x.data[1] == (a.index & 0xFF) &&
            x.data[2] == (a.index >> 8) && x.data[3] == a.sub_index) {
          mark = i + 1;
          return true;
        }
      }
      return false;
    })) << "SDO upload request of "
        << param << " never on the bus";
    return mark;
  }
  // An SDO download of a bound parameter in user units (a raw CanOpenSdoRequest on the wire).
  void SdoWrite(const char* param, double value) {
    auto bytes = Encode(P(param), value);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    const CanOpenAddress a = *ToCanOpen(P(param));
    CanOpenSdoRequest w;
    w.index = a.index;
    w.sub_index = a.sub_index;
    w.write = true;
    w.data = *bytes;
    auto r = drive_->SendNative(w);
    ASSERT_TRUE(r.ok()) << r.status();
  }

  CanBusConfig bus_;
  std::function<void(ss::AxisServer&)> before_drive_;
  std::unique_ptr<Sniffer> sniffer_;
  std::unique_ptr<ss::AxisServer> server_;
  std::unique_ptr<StoberDrive> drive_;
};

}  // namespace drivegw::stober::wire
