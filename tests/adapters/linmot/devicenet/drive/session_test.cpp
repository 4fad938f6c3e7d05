// DeviceNet session tests on the user-space CAN bus: registration checks, the gateway's own
// duplicate MAC ID check, malformed / foreign / second-master frames (counted, dropped, the
// session survives), gateway bus-off through an injected channel, one session per bus.
// Every test declares its peers before the session: the session's I/O thread calls a registered
// peer until the session stops (session.h), so the peer must outlive it (a peer destroyed first
// was called after its end: UBSan vptr report in CI, stop 17).
#include "adapters/linmot/devicenet/session.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/codec_can.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/transport/udp_multicast_channel.h"
#include "sim/linmot_devicenet/server.h"

namespace drivegw::linmot::devicenet {
namespace {

using namespace std::chrono_literals;
using sim::linmot_devicenet::DnSimOptions;
using sim::linmot_devicenet::LinMotDnServer;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;
constexpr char kGroup[] = "239.74.163.94";

uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + 3 + next++) % 40000);
}

CanBusConfig Bus(uint16_t port) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = kGroup;
  bus.port = port;
  return bus;
}

std::unique_ptr<transport::CanChannel> OpenBus(uint16_t port) {
  auto ch = transport::OpenCanChannel(Bus(port));
  EXPECT_TRUE(ch.ok()) << ch.status();
  return ch.ok() ? *std::move(ch) : nullptr;
}

transport::CanFrame Frame(uint32_t id, std::initializer_list<uint8_t> bytes) {
  const std::vector<uint8_t> v(bytes);
  return transport::MakeCanFrame(id, v);
}

// A channel whose bus-off state a test switches (vcan and the UDP bus have none, §5.12).
class BusOffChannel final : public transport::CanChannel {
 public:
  explicit BusOffChannel(std::unique_ptr<transport::CanChannel> inner) : inner_(std::move(inner)) {}
  void SetBusOff(bool off) {
    off_ = off;
    inner_->Wake();
  }
  absl::Status Send(const transport::CanFrame& frame) override {
    if (off_) return absl::UnavailableError("test: bus-off");
    return inner_->Send(frame);
  }
  absl::StatusOr<std::optional<transport::CanFrame>> Receive(
      std::chrono::nanoseconds timeout) override {
    auto got = inner_->Receive(timeout);
    if (got.ok() && got->has_value() && off_) return std::optional<transport::CanFrame>();
    return got;
  }
  void Wake() override { inner_->Wake(); }
  absl::Status SetFilters(std::span<const transport::CanFilter> f) override {
    return inner_->SetFilters(f);
  }
  transport::CanBusState state() const override {
    return off_ ? transport::CanBusState::kBusOff : inner_->state();
  }
  transport::CanCounters counters() const override { return inner_->counters(); }
  std::string name() const override { return inner_->name(); }

 private:
  std::unique_ptr<transport::CanChannel> inner_;
  std::atomic<bool> off_{false};
};

// A peer with a fixed image that records its link; every callback wakes Eventually().
class RecordingPeer final : public SessionPeer {
 public:
  explicit RecordingPeer(size_t consumed) : image_(consumed, 0) {}
  std::vector<uint8_t> BuildPollCommand() noexcept override { return image_; }
  void OnPollResponse(std::span<const uint8_t>, TimePoint) noexcept override {
    std::lock_guard lock(mu_);
    ++responses_;
    cv_.notify_all();
  }
  void OnPollTimeout() noexcept override {
    std::lock_guard lock(mu_);
    cv_.notify_all();
  }
  void OnLinkChange(LinkState state, const std::string& reason) noexcept override {
    std::lock_guard lock(mu_);
    link_ = state;
    reason_ = reason;
    cv_.notify_all();
  }
  // Waits on the callbacks (a condition with a deadline, STYLE §6) until `pred` holds.
  bool Eventually(const std::function<bool()>& pred, std::chrono::nanoseconds timeout = kWait) {
    std::unique_lock lock(mu_);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      lock.unlock();
      const bool ok = pred();
      lock.lock();
      if (ok) return true;
      if (cv_.wait_until(lock, deadline) == std::cv_status::timeout) {
        lock.unlock();
        return pred();
      }
    }
  }
  LinkState link() const {
    std::lock_guard lock(mu_);
    return link_;
  }
  std::string reason() const {
    std::lock_guard lock(mu_);
    return reason_;
  }
  int responses() const {
    std::lock_guard lock(mu_);
    return responses_;
  }

 private:
  std::vector<uint8_t> image_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  int responses_ = 0;
  LinkState link_ = LinkState::kUnknown;
  std::string reason_;
};

SessionOptions FastSession() {
  SessionOptions o;
  o.duplicate_check_wait = 30ms;
  o.bus_retry_max = 300ms;
  return o;
}

PeerOptions Peer(uint8_t mac) {
  PeerOptions p;
  p.name = absl::StrCat("d", mac);
  p.mac_id = mac;
  p.restart_wait = 100ms;
  p.retry_max = 300ms;
  return p;
}

std::unique_ptr<LinMotDnServer> StartSim(uint16_t port, uint8_t mac = 5) {
  DnSimOptions o;
  o.can = Bus(port);
  o.mac_id = mac;
  o.duplicate_check_wait = 30ms;
  auto server = LinMotDnServer::Start(o, SteadyClock::Instance());
  EXPECT_TRUE(server.ok()) << server.status();
  return server.ok() ? *std::move(server) : nullptr;
}

TEST(DnSession, Register_ChecksNameTheField) {
  RecordingPeer peer(6);
  auto session = Session::Open(OpenBus(UniquePort()), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok()) << session.status();
  PeerOptions p = Peer(5);
  ASSERT_TRUE((*session)->Register(p, &peer).ok());
  auto again = (*session)->Register(p, &peer);
  EXPECT_EQ(again.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(again.status().message(), HasSubstr("mac_id: 5 is also the MAC ID of drive 'd5'"));
  p.mac_id = 0;
  EXPECT_THAT((*session)->Register(p, &peer).status().message(),
              HasSubstr("is the gateway's own MAC ID"));
  p.mac_id = 64;
  EXPECT_EQ((*session)->Register(p, &peer).status().code(), absl::StatusCode::kInvalidArgument);
  p = Peer(6);
  p.expected_packet_rate_ms = 10;
  EXPECT_THAT((*session)->Register(p, &peer).status().message(),
              HasSubstr("expected_packet_rate_ms: 10 must exceed the poll period"));
  p = Peer(6);
  p.produced_size = 0;
  EXPECT_EQ((*session)->Register(p, &peer).status().code(), absl::StatusCode::kInvalidArgument);
  (*session)->Stop();
  EXPECT_EQ((*session)->Register(Peer(7), &peer).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

// §5.7: our duplicate MAC ID requests (0x407 for MAC 0) twice, then online; an answer from a
// node with our MAC ID keeps the gateway off the bus and is logged.
TEST(DnSession, DuplicateMacCheck_TwoRequestsThenOnline_AnsweredMeansDuplicate) {
  RecordingPeer peer(6);
  const uint16_t port = UniquePort();
  auto rival = OpenBus(port);
  auto session = Session::Open(OpenBus(port), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok());
  // The rival answers the first request: duplicate.
  auto got = rival->Receive(kWait);
  ASSERT_TRUE(got.ok() && got->has_value());
  EXPECT_EQ((*got)->id, 0x407u);
  EXPECT_EQ((*got)->dlc, 7);
  EXPECT_EQ((*got)->data[0], 0x00);  // request, port 0
  ASSERT_TRUE(rival->Send(Frame(0x407, {0x80, 0x00, 0x00, 0x11, 0x22, 0x33, 0x44})).ok());
  // A registered drive makes "online" visible: its Allocate (42E) follows the passed check.
  ASSERT_TRUE((*session)->Register(Peer(5), &peer).ok());
  bool allocate_seen = false;
  int checks_after = 0;
  const auto until = std::chrono::steady_clock::now() + kWait;
  while (!allocate_seen && std::chrono::steady_clock::now() < until) {
    auto f = rival->Receive(100ms);
    if (!f.ok() || !f->has_value()) continue;
    if ((*f)->id == 0x407) ++checks_after;
    if ((*f)->id == 0x42E) allocate_seen = true;
  }
  EXPECT_EQ((*session)->counters().duplicate_mac_detected, 1u);
  EXPECT_GE(checks_after, 2);  // after the back-off: two requests, unanswered, then online
  EXPECT_TRUE(allocate_seen);
  EXPECT_TRUE((*session)->bus_online());
  // Online, we answer another node's check of our MAC ID (§5.7).
  ASSERT_TRUE(rival->Send(Frame(0x407, {0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00})).ok());
  bool answered = false;
  const auto deadline = std::chrono::steady_clock::now() + kWait;
  while (!answered && std::chrono::steady_clock::now() < deadline) {
    auto f = rival->Receive(100ms);
    if (f.ok() && f->has_value() && (*f)->id == 0x407 && ((*f)->data[0] & 0x80)) answered = true;
  }
  EXPECT_TRUE(answered);
  EXPECT_EQ((*session)->counters().duplicate_mac_answered, 1u);
}

// STYLE §6 / issue 3: malformed frames, unexpected MAC IDs, a second master's traffic: counted,
// dropped; the session and the drive's link survive.
TEST(DnSession, BadAndForeignFrames_CountedDroppedSessionSurvives) {
  RecordingPeer peer(6);
  const uint16_t port = UniquePort();
  auto sim = StartSim(port);
  ASSERT_TRUE(sim);
  auto session = Session::Open(OpenBus(port), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok());
  auto id = (*session)->Register(Peer(5), &peer);
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(peer.Eventually([&] { return peer.link() == LinkState::kOnline; }));

  auto other = OpenBus(port);
  transport::CanFrame extended = Frame(0x42D, {1, 2});
  extended.extended = true;
  ASSERT_TRUE(other->Send(extended).ok());                                // not DeviceNet
  ASSERT_TRUE(other->Send(transport::MakeCanRtrFrame(0x3C5, 8)).ok());    // no remote frames
  ASSERT_TRUE(other->Send(Frame(0x7F5, {0})).ok());                       // invalid range
  ASSERT_TRUE(other->Send(Frame(0x3C9, {0, 0, 0, 0, 0, 0, 0, 0})).ok());  // MAC 9: unknown
  ASSERT_TRUE(other->Send(Frame(0x42E, {0x01, 0x4B, 0x03, 0x01, 0x01, 0x01})).ok());  // master 1
  ASSERT_TRUE(other->Send(Frame(0x42D, {0, 0, 0, 0, 0, 0})).ok());  // foreign poll
  ASSERT_TRUE(other->Send(Frame(0x42B, {0x40, 0x8E, 0x00})).ok());  // wrong XID/no req
  ASSERT_TRUE(other->Send(Frame(0x3C5, {0, 0, 0})).ok());           // short response
  ASSERT_TRUE(peer.Eventually([&] {
    const SessionCounters c = (*session)->counters();
    const PeerCounters p = *(*session)->peer_counters(*id);
    return c.malformed >= 3 && c.unexpected_mac >= 1 && p.foreign_master >= 3;
  }));
  const PeerCounters p = *(*session)->peer_counters(*id);
  // The drive refused master 1 (line 142; D-14 0C/01): that answer, addressed to MAC 1, is also
  // another master's traffic.
  EXPECT_GE(p.foreign_master, 3u);
  EXPECT_EQ(peer.link(), LinkState::kOnline);
  const int before = peer.responses();
  EXPECT_TRUE(peer.Eventually([&] { return peer.responses() > before + 5; }));
  EXPECT_EQ(*sim->Snapshot().stack.owner, 0);  // still ours
}

// §10.2 "bus-off in the gateway": every drive offline; after the controller recovers, our own
// duplicate MAC ID check and a full set-up (Release first: the drive may still hold the set).
TEST(DnSession, GatewayBusOff_AllOfflineThenFullSetup) {
  RecordingPeer peer(6);
  const uint16_t port = UniquePort();
  auto sim = StartSim(port);
  ASSERT_TRUE(sim);
  auto channel = std::make_unique<BusOffChannel>(OpenBus(port));
  BusOffChannel* bus = channel.get();
  auto session = Session::Open(std::move(channel), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok());
  auto id = (*session)->Register(Peer(5), &peer);
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(peer.Eventually([&] { return peer.link() == LinkState::kOnline; }));
  bus->SetBusOff(true);
  ASSERT_TRUE(peer.Eventually([&] { return peer.link() == LinkState::kOffline; }));
  EXPECT_THAT(peer.reason(), HasSubstr("bus-off"));
  EXPECT_EQ((*session)->counters().bus_off_events, 1u);
  EXPECT_FALSE((*session)->bus_online());
  bus->SetBusOff(false);
  ASSERT_TRUE(peer.Eventually([&] { return peer.link() == LinkState::kOnline; }));
  EXPECT_GE((*session)->peer_counters(*id)->connects, 2u);
}

// One channel and one I/O thread per bus: two drives with their own MAC IDs share a session.
TEST(DnSession, Pool_TwoDrivesOneBus_OneSession) {
  RecordingPeer p5(6), p6(6);
  const uint16_t port = UniquePort();
  auto sim5 = StartSim(port, 5);
  auto sim6 = StartSim(port, 6);
  ASSERT_TRUE(sim5 && sim6);
  auto a = SessionPool::Instance().Acquire(Bus(port), FastSession(), SteadyClock::Instance());
  auto b = SessionPool::Instance().Acquire(Bus(port), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->get(), b->get());
  SessionOptions other = FastSession();
  other.master_mac = 1;
  EXPECT_EQ(
      SessionPool::Instance().Acquire(Bus(port), other, SteadyClock::Instance()).status().code(),
      absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE((*a)->Register(Peer(5), &p5).ok());
  ASSERT_TRUE((*b)->Register(Peer(6), &p6).ok());
  EXPECT_TRUE(p5.Eventually(
      [&] { return p5.link() == LinkState::kOnline && p6.link() == LinkState::kOnline; }));
  EXPECT_EQ((*a)->peer_count(), 2u);
  EXPECT_EQ(*sim5->Snapshot().stack.owner, 0);
  EXPECT_EQ(*sim6->Snapshot().stack.owner, 0);
}

// §11.9: unregistering releases the set, so another master may allocate it (TC-02's second
// half, seen from the gateway).
TEST(DnSession, Unregister_ReleasesTheConnectionSet) {
  RecordingPeer peer(6);
  const uint16_t port = UniquePort();
  auto sim = StartSim(port);
  ASSERT_TRUE(sim);
  auto session = Session::Open(OpenBus(port), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok());
  auto id = (*session)->Register(Peer(5), &peer);
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(peer.Eventually([&] { return peer.link() == LinkState::kOnline; }));
  (*session)->Unregister(*id);
  EXPECT_EQ(peer.link(), LinkState::kOffline);
  // The release frame left before Unregister returned; the simulator's answer lands shortly.
  auto watcher = OpenBus(port);
  const auto until = std::chrono::steady_clock::now() + kWait;
  while (sim->Snapshot().stack.owner.has_value() && std::chrono::steady_clock::now() < until) {
    (void)watcher->Receive(20ms);  // wakes on bus traffic (the release answer) or the time-out
  }
  EXPECT_FALSE(sim->Snapshot().stack.owner.has_value());
}

}  // namespace
}  // namespace drivegw::linmot::devicenet

namespace drivegw::linmot::devicenet {
namespace {

// Counts per drive on one bus (issue 11 "Device health", decision 1431).
struct HealthPeer final : SessionPeer {
  explicit HealthPeer(size_t consumed) : image(consumed, 0) {}
  std::vector<uint8_t> BuildPollCommand() noexcept override { return image; }
  void OnPollResponse(std::span<const uint8_t>, TimePoint) noexcept override {
    std::lock_guard lock(mu);
    ++responses;
    cv.notify_all();
  }
  void OnLinkChange(LinkState, const std::string&) noexcept override {}
  void OnHealthChange(const HealthInfo& h) noexcept override {
    std::lock_guard lock(mu);
    health = h;
    cv.notify_all();
  }
  bool WaitHealth(HealthState s) {
    std::unique_lock lock(mu);
    return cv.wait_for(lock, kWait, [&] { return health.state == s; });
  }
  HealthInfo Health() {
    std::lock_guard lock(mu);
    return health;
  }
  int Responses() {
    std::lock_guard lock(mu);
    return responses;
  }
  std::vector<uint8_t> image;
  std::mutex mu;
  std::condition_variable cv;
  int responses = 0;
  HealthInfo health;
};

// Replies of each live drive in the best of three windows of `w` (a count; the window only
// bounds it). The best of three: a loaded machine (ctest -j2 beside other suites) steals CPU in
// some windows, a dead drive slowing the bus would lower all three.
std::vector<int> RepliesIn(std::vector<HealthPeer*> peers, std::chrono::milliseconds w) {
  std::vector<int> best(peers.size(), 0);
  for (int round = 0; round < 3; ++round) {
    std::vector<int> start;
    for (HealthPeer* p : peers) start.push_back(p->Responses());
    std::this_thread::sleep_for(w);  // the measurement window itself, not a wait for a condition
    for (size_t i = 0; i < peers.size(); ++i) {
      best[i] = std::max(best[i], peers[i]->Responses() - start[i]);
    }
  }
  return best;
}

// Three drives on one CAN bus, one session; the third dies. It goes DOWN and is probed only at
// the set-up back-off, and the two live ones keep their exchange rate (>= 80 % of their replies
// in an equal window before the loss).
TEST(DnSession, SharedBus_DeadDriveDownProbedAtBackoff_OthersKeepTheirRate) {
  HealthPeer p5(6), p6(6), p7(6);
  const uint16_t port = UniquePort();
  auto sim5 = StartSim(port, 5);
  auto sim6 = StartSim(port, 6);
  auto sim7 = StartSim(port, 7);
  ASSERT_TRUE(sim5 && sim6 && sim7);
  auto session = Session::Open(Bus(port), FastSession(), SteadyClock::Instance());
  ASSERT_TRUE(session.ok()) << session.status();
  PeerOptions o7 = Peer(7);
  o7.retry_min = 100ms;
  o7.retry_max = 400ms;
  auto id5 = (*session)->Register(Peer(5), &p5);
  auto id6 = (*session)->Register(Peer(6), &p6);
  auto id7 = (*session)->Register(o7, &p7);
  ASSERT_TRUE(id5.ok() && id6.ok() && id7.ok());
  for (HealthPeer* p : {&p5, &p6, &p7}) ASSERT_TRUE(p->WaitHealth(HealthState::kUp));

  const std::vector<int> before = RepliesIn({&p5, &p6}, 500ms);
  ASSERT_GT(before[0], 10);  // polls every 10 ms: far more than 10 in half a second, even loaded
  ASSERT_GT(before[1], 10);

  sim7->Stop();
  ASSERT_TRUE(p7.WaitHealth(HealthState::kDown));
  EXPECT_FALSE(p7.Health().reason.empty());
  const uint64_t probes_before = (*session)->peer_counters(*id7)->explicit_requests;
  const std::vector<int> after = RepliesIn({&p5, &p6}, 500ms);
  const uint64_t probes = (*session)->peer_counters(*id7)->explicit_requests - probes_before;

  for (size_t i = 0; i < 2; ++i) {
    EXPECT_GE(after[i] * 10, before[i] * 8)
        << "drive " << (i + 5) << ": " << after[i] << " replies after, " << before[i] << " before";
  }
  // Set-up attempts of the dead drive over the three windows (1.5 s): at most one per back-off
  // (>= 100 ms, doubling to 400 ms), each a Release and an Allocate at most: <= 2 x (1500 / 100
  // + 1), where polling it like a live drive would be 150 requests.
  EXPECT_LE(probes, 32u) << probes << " set-up requests to the dead drive in the window";
  EXPECT_EQ(p7.Health().state, HealthState::kDown);
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
