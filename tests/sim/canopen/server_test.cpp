// Tests for sim/canopen/server: the simulated slave on the UDP multicast CAN bus with the
// protocol library's SdoClientTransfer as the master and a ManualClock: boot-up on start, SDO
// over the bus, PDO configuration with the library's MappingWrites, SYNC → TPDO, heartbeat
// on the manual clock, EMCY, and the faults (reboot, injected abort, silent, heartbeat loss).
#include "sim/canopen/server.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/canopen/emcy.h"
#include "adapters/canopen/nmt.h"
#include "adapters/canopen/sync.h"
#include "tests/sim/canopen/test_model.h"

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;
using ::testing::ElementsAre;
using transport::CanFrame;
using Bytes = std::vector<uint8_t>;
using namespace std::chrono_literals;
using testing::TestModel;

constexpr char kGroup[] = "239.74.163.78";
constexpr uint8_t kNode = 9;

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

Bytes Data(const CanFrame& f) { return Bytes(f.payload().begin(), f.payload().end()); }

struct Fixture {
  explicit Fixture(SlaveNodeOptions node = {}) {
    const uint16_t port = RandomPort();
    auto m = transport::OpenCanChannel(Bus(port));
    EXPECT_TRUE(m.ok()) << m.status();
    if (m.ok()) master = *std::move(m);
    SlaveServerOptions options;
    options.node = node;
    options.node.node_id = kNode;
    options.can = Bus(port);
    auto s = SlaveServer::Start(options, clock, &model);
    EXPECT_TRUE(s.ok()) << s.status();
    if (s.ok()) server = *std::move(s);
  }
  bool ok() const { return master != nullptr && server != nullptr; }

  void Send(const CanFrame& f) { ASSERT_TRUE(master->Send(f).ok()); }
  // Waits (real-time deadline, never a fixed sleep) until the server reports `state`.
  bool WaitState(NmtState state) {
    const auto deadline = std::chrono::steady_clock::now() + 3s;
    while (server->state() != state && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    return server->state() == state;
  }
  // The next frame (any id) within the real-time timeout, nullopt if none.
  std::optional<CanFrame> Next(std::chrono::milliseconds timeout = 3000ms) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= std::chrono::nanoseconds(0)) return std::nullopt;
      auto f = master->Receive(left);
      if (f.ok() && f->has_value()) return **f;
    }
  }
  // The next frame with identifier `id`; the others are kept in `skipped`.
  std::optional<CanFrame> NextWithId(uint32_t id, std::chrono::milliseconds timeout = 3000ms) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      auto f = Next(std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now()));
      if (!f) return std::nullopt;
      if (f->id == id) return f;
      skipped.push_back(*f);
    }
    return std::nullopt;
  }
  // One SDO transfer over the bus; a server that does not answer within 1 s real time ends it.
  co::SdoStep Run(co::SdoClientTransfer client) {
    CanFrame request = client.Start();
    for (int guard = 0; guard < 1000; ++guard) {
      Send(request);
      auto response = NextWithId(0x580 + kNode, 1000ms);
      if (!response) return client.Timeout();
      co::SdoStep step = client.OnFrame(*response);
      if (step.kind != co::SdoStep::Kind::kSend) return step;
      request = *step.frame;
    }
    return {};
  }
  absl::StatusOr<Bytes> Upload(uint16_t index, uint8_t sub) {
    co::SdoStep step = Run(co::SdoClientTransfer::Upload(channel, index, sub));
    if (step.kind == co::SdoStep::Kind::kDone) return step.data;
    return step.status;
  }
  absl::Status Download(uint16_t index, uint8_t sub, Bytes data) {
    co::SdoStep step = Run(co::SdoClientTransfer::Download(channel, index, sub, std::move(data)));
    return step.kind == co::SdoStep::Kind::kDone ? absl::OkStatus() : step.status;
  }

  ManualClock clock{TimePoint{std::chrono::seconds(50)}};
  TestModel model;
  std::unique_ptr<transport::CanChannel> master;
  std::unique_ptr<SlaveServer> server;
  co::SdoChannel channel = co::DefaultSdoChannel(kNode).value();
  std::vector<CanFrame> skipped;
};

TEST(SlaveServer, BootUpOnStart_SdoExpeditedAndSegmentedOverTheBus) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  auto boot = f.NextWithId(0x709);
  ASSERT_TRUE(boot);
  EXPECT_THAT(Data(*boot), ElementsAre(0x00));
  EXPECT_EQ(f.server->state(), NmtState::kPreOperational);
  auto name = f.Upload(0x1008, 0);
  ASSERT_TRUE(name.ok()) << name.status();
  EXPECT_EQ(std::string(name->begin(), name->end()), "drivegw CANopen slave");
  ASSERT_TRUE(f.Download(0x2000, 0, {0x58, 0x02}).ok());
  EXPECT_THAT(*f.Upload(0x2000, 0), ElementsAre(0x58, 0x02));
  const std::string label = "written in five segments..";
  ASSERT_TRUE(f.Download(0x2003, 0, Bytes(label.begin(), label.end())).ok());
  auto back = f.Upload(0x2003, 0);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(std::string(back->begin(), back->end()), label);
  auto missing = f.Upload(0x5000, 0);
  EXPECT_EQ(co::AbortCodeOf(missing.status()), co::SdoAbortCode::kNoObject);
  EXPECT_GE(f.server->counters().node.sdo_requests, 10u);
}

TEST(SlaveServer, HeartbeatFollowsTheManualClock) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f.NextWithId(0x709));
  ASSERT_TRUE(f.Download(0x1017, 0, {100, 0}).ok());
  f.clock.Advance(100ms);
  auto hb = f.NextWithId(0x709);
  ASSERT_TRUE(hb);
  EXPECT_THAT(Data(*hb), ElementsAre(0x7F));
  f.Send(*co::EncodeNmt({co::NmtCommand::kStart, kNode}));
  ASSERT_TRUE(f.WaitState(NmtState::kOperational));
  f.clock.Advance(100ms);
  hb = f.NextWithId(0x709);
  ASSERT_TRUE(hb);
  EXPECT_THAT(Data(*hb), ElementsAre(0x05));
  EXPECT_EQ(f.server->counters().node.heartbeats_sent, 2u);
}

TEST(SlaveServer, PdoConfiguredWithMappingWrites_SyncTpdoAndRpdo) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  auto tpdo = co::MappingWrites(co::PdoKind::kTpdo, 1, kNode, {0, true, 1, 0, 0},
                                std::vector<co::PdoMappingEntry>{{0x6041, 0, 16}, {0x6064, 0, 32}});
  auto rpdo = co::MappingWrites(co::PdoKind::kRpdo, 1, kNode, {0, true, 1, 0, 0},
                                std::vector<co::PdoMappingEntry>{{0x6040, 0, 16}});
  ASSERT_TRUE(tpdo.ok() && rpdo.ok());
  for (const auto* writes : {&*tpdo, &*rpdo}) {
    for (const co::SdoWrite& w : *writes) ASSERT_TRUE(f.Download(w.index, w.sub, w.data).ok());
  }
  f.Send(*co::EncodeNmt({co::NmtCommand::kStart, 0}));
  ASSERT_TRUE(f.WaitState(NmtState::kOperational));
  f.Send(transport::MakeCanFrame(0x209, Bytes{0x06, 0x00}));
  f.server->WithNode([&](SlaveNode&) { f.model.position = 0x01020304; });
  f.Send(*co::EncodeSync({}));
  auto t = f.NextWithId(0x189);
  ASSERT_TRUE(t);
  EXPECT_THAT(Data(*t), ElementsAre(0x50, 0x02, 0x04, 0x03, 0x02, 0x01));
  std::vector<uint16_t> rpdos;
  std::vector<uint16_t> cws;
  f.server->WithNode([&](SlaveNode&) {
    rpdos = f.model.rpdos;
    cws = f.model.controlwords;
  });
  EXPECT_THAT(rpdos, ElementsAre(1));
  EXPECT_THAT(cws, ElementsAre(0x06));
}

TEST(SlaveServer, EmcyAndRebootFault) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f.NextWithId(0x709));
  f.server->RaiseEmcy(0x8611, co::error_register::kDeviceProfile);
  auto e = f.NextWithId(0x89);
  ASSERT_TRUE(e);
  EXPECT_THAT(Data(*e), ElementsAre(0x11, 0x86, 0x21, 0, 0, 0, 0, 0));
  ASSERT_TRUE(f.Download(0x2000, 0, {0xF4, 0x01}).ok());
  f.Send(*co::EncodeNmt({co::NmtCommand::kStart, kNode}));
  ASSERT_TRUE(f.WaitState(NmtState::kOperational));
  f.server->Reboot();
  auto boot = f.NextWithId(0x709);
  ASSERT_TRUE(boot);
  EXPECT_THAT(Data(*boot), ElementsAre(0x00));
  EXPECT_EQ(f.server->state(), NmtState::kPreOperational);
  EXPECT_THAT(*f.Upload(0x2000, 0), ElementsAre(100, 0));
  EXPECT_THAT(*f.Upload(0x1003, 0), ElementsAre(0));  // history is communication area
}

TEST(SlaveServer, InjectedAbort_Silent_HeartbeatLoss) {
  Fixture f;
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f.NextWithId(0x709));
  f.server->InjectSdoAbort(0x1018, 1, co::SdoAbortCode::kResourceUnavailable);
  EXPECT_EQ(co::AbortCodeOf(f.Upload(0x1018, 1).status()), co::SdoAbortCode::kResourceUnavailable);
  f.server->ClearSdoAborts();
  EXPECT_TRUE(f.Upload(0x1018, 1).ok());

  ASSERT_TRUE(f.Download(0x1017, 0, {50, 0}).ok());
  f.server->SetSilent(true);
  const uint64_t in = f.server->counters().node.frames_in;
  f.Send(transport::MakeCanFrame(0x609, Bytes{0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  // Wait until the server has taken the request (its answer would be sent in the same step).
  const auto deadline = std::chrono::steady_clock::now() + 3s;
  while (f.server->counters().node.frames_in == in && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::yield();
  }
  ASSERT_GT(f.server->counters().node.frames_in, in);
  f.clock.Advance(200ms);
  f.server->WithNode([](SlaveNode&) {});  // timers at the new time: heartbeats suppressed
  f.server->SetSilent(false);
  // The first frame after the silence is the answer to a new request: nothing came out before.
  f.skipped.clear();
  auto dt = f.Upload(0x1000, 0);
  ASSERT_TRUE(dt.ok()) << dt.status();
  EXPECT_TRUE(f.skipped.empty()) << transport::FormatCanFrame(f.skipped.front());
  EXPECT_GE(f.server->counters().node.suppressed, 1u);

  f.server->SetHeartbeatLoss(true);
  f.clock.Advance(200ms);
  f.server->WithNode([](SlaveNode&) {});
  EXPECT_TRUE(f.Upload(0x1000, 0).ok());  // SDO still answered
  EXPECT_TRUE(f.skipped.empty());
  f.server->SetHeartbeatLoss(false);
  f.clock.Advance(50ms);
  EXPECT_TRUE(f.NextWithId(0x709));
}

TEST(SlaveServer, StartRefusesBadNodeId) {
  ManualClock clock;
  SlaveServerOptions options;
  options.node.node_id = 200;
  options.can = Bus(RandomPort());
  auto s = SlaveServer::Start(options, clock);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace drivegw::sim::canopen
