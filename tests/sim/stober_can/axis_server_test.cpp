// The simulated STOBER axis (sim/stober/server.h) on the UDP multicast CAN bus, with the
// CANopen master runtime as the master (steady clock, bounded waits) and a ManualClock driving
// the axis: boot-up, NMT, SDO reads of CiA 402 objects and STOBER parameters through the shared
// object map, SDO refusals with their abort codes, default PDO layout configured by the master,
// MoveAbsolute via RPDOs with the status from TPDOs, heartbeat, EMCY on faults, reset node.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <condition_variable>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "adapters/stober/object_map.h"
#include "sim/stober/server.h"

namespace drivegw::sim::stober {
namespace {

namespace co = drivegw::canopen;
namespace so = drivegw::stober;
using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr char kGroup[] = "239.74.163.81";
constexpr uint8_t kNode = 12;

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

// Everything the master tells about the node, with waits bounded in real time.
class Recorder : public co::NodeObserver {
 public:
  void OnHeartbeat(uint8_t, co::NmtState, TimePoint) noexcept override {
    Update([&] { ++heartbeats; });
  }
  void OnBootUp(const co::NodeEventInfo&) noexcept override {
    Update([&] { ++bootups; });
  }
  void OnEmcy(const co::EmcyEvent& e) noexcept override {
    Update([&] { emcy.push_back(e.emcy); });
  }
  void OnTpdo(const co::TpdoEvent& e) noexcept override {
    Update([&] {
      if (e.number == 1) {
        if (auto s = so::DecodeStatusTpdo(e.payload()); s.ok()) statuses.push_back(*s);
      } else if (e.number == 2) {
        if (auto a = so::DecodeActualTpdo(e.payload()); a.ok()) actual = *a;
      }
    });
  }

  template <typename Pred>
  bool WaitFor(Pred pred, std::chrono::milliseconds timeout = 3000ms) {
    std::unique_lock lock(mu);
    return cv.wait_for(lock, timeout, [&] { return pred(); });
  }
  template <typename Fn>
  void Update(Fn fn) {
    {
      std::lock_guard lock(mu);
      fn();
    }
    cv.notify_all();
  }

  std::mutex mu;
  std::condition_variable cv;
  int heartbeats = 0;
  int bootups = 0;
  std::vector<co::Emcy> emcy;
  std::vector<so::MotionStatus> statuses;
  std::optional<so::ActualValues> actual;
};

AxisServerOptions EnabledAxis() {
  AxisServerOptions o;
  o.node_id = kNode;
  o.axis.core.start_operation_enabled = true;  // §10.1 fixtures: at rest, I89 = 2
  return o;
}

class StoberCanTest : public ::testing::Test {
 protected:
  void Start(AxisServerOptions options = EnabledAxis()) {
    CanBusConfig bus;
    bus.kind = CanBusConfig::Kind::kUdpMulticast;
    bus.group = kGroup;
    bus.port = RandomPort();
    auto m = co::CanopenMaster::Open(bus);
    ASSERT_TRUE(m.ok()) << m.status();
    master_ = *std::move(m);
    ASSERT_TRUE(master_->AddNodeObserver(kNode, &rec_).ok());
    options.node_id = kNode;
    options.can = bus;
    auto s = AxisServer::Start(options, clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
    ASSERT_TRUE(rec_.WaitFor([&] { return rec_.bootups >= 1; })) << "no boot-up message";
  }
  void TearDown() override {
    if (server_) server_->Stop();
    if (master_) master_->Stop();
  }

  static TimePoint Deadline() { return SteadyClock::Instance().Now() + 2s; }
  // Moves the axis's time: synchronous (WithAxis advances the node to the clock and sends what
  // the node produced).
  void Step(Duration d) {
    clock_.Advance(d);
    server_->WithAxis([](MotionCore&) {});
  }
  absl::StatusOr<double> ReadParam(const char* id) {
    auto b = so::FindBinding(so::P(id));
    if (!b.ok()) return b.status();
    auto bytes = master_->Upload(kNode, b->address.index, b->address.sub_index, Deadline());
    if (!bytes.ok()) return bytes.status();
    return so::Decode(*b, *bytes);
  }
  absl::Status WriteParam(const char* id, double value) {
    auto b = so::FindBinding(so::P(id));
    if (!b.ok()) return b.status();
    auto bytes = so::Encode(*b, value);
    if (!bytes.ok()) return bytes.status();
    return master_->Download(kNode, b->address.index, b->address.sub_index, *bytes, Deadline());
  }
  void StartNode() {
    ASSERT_TRUE(master_->SendNmt(co::NmtCommand::kStart, kNode).ok());
    const auto deadline = std::chrono::steady_clock::now() + 3s;
    while (server_->state() != co::NmtState::kOperational &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    ASSERT_EQ(server_->state(), co::NmtState::kOperational);
  }
  bool WaitRpdosApplied(uint64_t n) {
    const auto deadline = std::chrono::steady_clock::now() + 3s;
    while (server_->counters().node.rpdos_applied < n &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    return server_->counters().node.rpdos_applied >= n;
  }
  absl::Status SendRpdo(uint16_t number, std::vector<double> values) {
    const so::PdoLayout* layout = so::FindDefaultPdo(co::PdoKind::kRpdo, number);
    auto payload = so::PackLayout(*layout, values);
    if (!payload.ok()) return payload.status();
    return master_->SendRpdo(kNode, number, *payload);
  }
  // Advances the axis in 10 ms steps (at most `limit`) until `pred` holds on what the master saw.
  template <typename Pred>
  bool RunUntil(Pred pred, Duration limit = 3s) {
    for (Duration t{}; t < limit; t += 10ms) {
      Step(10ms);
      if (rec_.WaitFor(pred, 20ms)) return true;
    }
    return rec_.WaitFor(pred, 500ms);
  }

  ManualClock clock_;
  Recorder rec_;
  std::shared_ptr<co::CanopenMaster> master_;
  std::unique_ptr<AxisServer> server_;
};

TEST_F(StoberCanTest, BootsPreOperationalAndStartsOnNmt) {
  Start();
  EXPECT_EQ(server_->state(), co::NmtState::kPreOperational);
  StartNode();
  ASSERT_TRUE(master_->SendNmt(co::NmtCommand::kEnterPreOperational, kNode).ok());
  // The SDO answer proves the NMT frame before it was handled.
  ASSERT_TRUE(master_->ReadU32(kNode, 0x1000, 0, Deadline()).ok());
  EXPECT_EQ(server_->state(), co::NmtState::kPreOperational);
  EXPECT_EQ(*master_->ReadU32(kNode, 0x1000, 0, Deadline()), kDeviceTypeServo);
}

TEST_F(StoberCanTest, SdoReadsCia402ObjectsAndStoberParameters) {
  Start();
  absl::StatusOr<uint16_t> sw = master_->ReadU16(kNode, 0x6041, 0, Deadline());
  ASSERT_TRUE(sw.ok()) << sw.status();
  EXPECT_EQ(*sw & 0x6F, 0x27) << "operation enabled";
  // §7.2: I89 → 3059h; the PLCopen state at rest is 2 (Standstill).
  EXPECT_EQ(*master_->ReadU8(kNode, 0x3059, 0, Deadline()), 2);
  EXPECT_EQ(*ReadParam("I89"), 2);
  EXPECT_DOUBLE_EQ(*ReadParam("I404"), 500);  // F-LIN default move
  EXPECT_DOUBLE_EQ(*ReadParam("A150"), 1);
  EXPECT_DOUBLE_EQ(*ReadParam("I50"), 10000);
  ASSERT_TRUE(WriteParam("I403", -12.345).ok());
  EXPECT_DOUBLE_EQ(*ReadParam("I403"), -12.345);
  ASSERT_TRUE(WriteParam("A567", 77.5).ok());  // 607Ah feeds I403 (CiA 402 source write-through)
  EXPECT_DOUBLE_EQ(*ReadParam("I403"), 77.5);
}

TEST_F(StoberCanTest, EveryMappedObjectIsServedAndEveryCatalogueParameterMapped) {
  Start();
  for (const ParamInfo& info : Catalogue()) {
    EXPECT_TRUE(so::FindBinding(info.id).ok()) << ToString(info.id);
  }
  MotionCore reference(MotionCoreOptions{.start_operation_enabled = true});
  for (const so::ObjectBinding& b : so::ObjectMap()) {
    SCOPED_TRACE(ToString(b.param));
    auto bytes = master_->Upload(kNode, b.address.index, b.address.sub_index, Deadline());
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    absl::StatusOr<double> v = so::Decode(b, *bytes);
    ASSERT_TRUE(v.ok()) << v.status();
    // Power-on values equal a fresh motion core's (the axis has not moved).
    const double want = *reference.Read(b.param);
    EXPECT_NEAR(*v, want, b.scale / 2 + 1e-9);
  }
  EXPECT_TRUE(master_->ReadU32(kNode, so::kStatusFlagsIndex, 0, Deadline()).ok());
}

co::SdoAbortCode AbortOf(const absl::Status& s) {
  return co::AbortCodeOf(s).value_or(co::SdoAbortCode::kGeneral);
}

TEST_F(StoberCanTest, SdoWriteRefusalsCarryTheirAbortCodes) {
  Start();
  // I401 (3191h) command 12: above the catalogue maximum 11.
  absl::Status s = master_->WriteU8(kNode, 0x3191, 0, 12, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kValueTooHigh) << s;
  // A150 0.100 ms (100 µs): below the minimum 0.125 ms.
  s = master_->WriteU32(kNode, 0x2096, 0, 100, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kValueTooLow) << s;
  // Execute I402 (3192h) is a boolean: 2 is above 1.
  s = master_->WriteU8(kNode, 0x3192, 0, 2, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kValueTooHigh) << s;
  // Status word 6041h and PLCopen state I89 are read-only.
  s = master_->WriteU16(kNode, 0x6041, 0, 0, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kReadOnly) << s;
  s = master_->WriteU8(kNode, 0x3059, 0, 2, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kReadOnly) << s;
  // Wrong length: I401 is UNSIGNED8.
  s = master_->WriteU32(kNode, 0x3191, 0, 1, Deadline());
  EXPECT_EQ(AbortOf(s), co::SdoAbortCode::kLengthTooHigh) << s;
  // No such object / sub-index.
  EXPECT_EQ(AbortOf(master_->ReadU32(kNode, 0x3FFF, 0, Deadline()).status()),
            co::SdoAbortCode::kNoObject);
  EXPECT_EQ(AbortOf(master_->ReadU32(kNode, 0x6040, 1, Deadline()).status()),
            co::SdoAbortCode::kNoSubIndex);
  // Injected abort for one object (fault injection), then cleared.
  server_->InjectSdoAbort(0x6041, 0, co::SdoAbortCode::kHardwareError);
  EXPECT_EQ(AbortOf(master_->ReadU16(kNode, 0x6041, 0, Deadline()).status()),
            co::SdoAbortCode::kHardwareError);
  server_->ClearSdoAborts();
  EXPECT_TRUE(master_->ReadU16(kNode, 0x6041, 0, Deadline()).ok());
  // Nothing was changed by the refused writes.
  EXPECT_EQ(*ReadParam("I401"), 0);
  EXPECT_EQ(*ReadParam("A150"), 1);
}

TEST_F(StoberCanTest, PdosOnlyInOperational) {
  Start();
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 50, 1}).ok());
  // The SDO answer comes after the RPDO frame was handled (one ordered bus, one node thread).
  ASSERT_TRUE(master_->ReadU16(kNode, 0x6041, 0, Deadline()).ok());
  EXPECT_EQ(server_->counters().node.rpdos_applied, 0u);
  EXPECT_EQ(*ReadParam("I403"), 0);
}

TEST_F(StoberCanTest, MoveAbsoluteThroughTheDefaultPdoLayout) {
  Start();
  // The gateway's configuration: every default PDO through the CiA 301 mapping procedure.
  for (const so::PdoLayout& l : so::DefaultPdoLayout()) {
    const co::PdoMapping mapping = l.Mapping();
    absl::Status s = master_->ConfigurePdo(kNode, l.kind, l.number, l.comm, mapping, Deadline());
    ASSERT_TRUE(s.ok()) << s;
  }
  StartNode();
  // Set values first (RPDO2/3: default move), then command + position + Execute edge in RPDO1.
  ASSERT_TRUE(SendRpdo(2, {500, 5000}).ok());
  ASSERT_TRUE(SendRpdo(3, {5000, 50000}).ok());
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 100, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(3));
  auto at = [&](double target) {
    return [&, target] {
      return !rec_.statuses.empty() && rec_.statuses.back().done() &&
             rec_.statuses.back().plc_state == 2 && rec_.actual &&
             std::abs(rec_.actual->position - target) < 1e-3;
    };
  };
  ASSERT_TRUE(RunUntil(at(100))) << "no Done at 100";
  {
    std::lock_guard lock(rec_.mu);
    // The status TPDO showed the motion (I89 = 3) and no error on the way.
    bool moving = false;
    for (const so::MotionStatus& s : rec_.statuses) {
      moving |= s.plc_state == 3;
      EXPECT_FALSE(s.error());
    }
    EXPECT_TRUE(moving);
    EXPECT_EQ(rec_.statuses.back().status_word & 0x6F, 0x27);
  }
  EXPECT_DOUBLE_EQ(*ReadParam("A545"), 100);
  // A second MoveAbsolute with unchanged dynamics: 2 RPDO frames (Execute low, then the edge
  // with the new position), decision 1175. The low level must last at least one A150 cycle to
  // be seen (G-05, decision 1179).
  const uint64_t before = master_->counters().rpdo_sent;
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 100, 0}).ok());
  ASSERT_TRUE(WaitRpdosApplied(4));
  Step(1ms);
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, -40, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(5));
  EXPECT_EQ(master_->counters().rpdo_sent - before, 2u);
  ASSERT_TRUE(RunUntil(at(-40))) << "no Done at -40";
}

// Decision 1182: Execute low and high read by the slave in one burst (no A150 cycle between)
// still give one rising edge when they came by RPDO (input latch); a level that never went low
// gives none, and SDO writes are sampled without the latch (decision 1179).
TEST_F(StoberCanTest, ExecuteLowAndHighInOneCycleAreLatchedForRpdos) {
  Start();
  for (const so::PdoLayout& l : so::DefaultPdoLayout()) {
    const co::PdoMapping mapping = l.Mapping();
    ASSERT_TRUE(master_->ConfigurePdo(kNode, l.kind, l.number, l.comm, mapping, Deadline()).ok());
  }
  StartNode();
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 100, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(1));
  ASSERT_TRUE(
      RunUntil([&] { return rec_.actual && std::abs(rec_.actual->position - 100) < 1e-3; }));
  Step(10ms);
  // SDO: low and high within one cycle are sampled as high, high → no edge.
  ASSERT_TRUE(WriteParam("I403", 50).ok());
  ASSERT_TRUE(WriteParam("I402", 0).ok());
  ASSERT_TRUE(WriteParam("I402", 1).ok());
  Step(50ms);
  EXPECT_EQ(*ReadParam("I89"), 2);
  EXPECT_DOUBLE_EQ(*ReadParam("A545"), 100);
  // RPDO with Execute still high: the level never went low, no edge.
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 60, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(2));
  Step(50ms);
  EXPECT_EQ(*ReadParam("I89"), 2);
  EXPECT_DOUBLE_EQ(*ReadParam("A545"), 100);
  // RPDO low then high with no cycle between (the clock does not move): one edge.
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 60, 0}).ok());
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, -40, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(4));
  ASSERT_TRUE(RunUntil([&] { return rec_.actual && std::abs(rec_.actual->position + 40) < 1e-3; }))
      << "the latched low gave no edge";
}

// Fault injection for the gateway's acceptance deadline (decision 1182): a dropped edge leaves
// the axis at rest with Execute low in the core; the next edge is taken again.
TEST_F(StoberCanTest, DroppedAndIgnoredExecuteEdges) {
  Start();
  for (const so::PdoLayout& l : so::DefaultPdoLayout()) {
    const co::PdoMapping mapping = l.Mapping();
    ASSERT_TRUE(master_->ConfigurePdo(kNode, l.kind, l.number, l.comm, mapping, Deadline()).ok());
  }
  StartNode();
  server_->DropNextExecuteEdge();
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 30, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(1));
  Step(50ms);
  EXPECT_EQ(server_->dropped_execute_edges(), 1u);
  EXPECT_EQ(*ReadParam("I89"), 2);
  EXPECT_DOUBLE_EQ(*ReadParam("A545"), 0);
  server_->SetIgnoreExecute(true);
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 30, 0}).ok());
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 30, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(3));
  Step(50ms);
  EXPECT_EQ(server_->dropped_execute_edges(), 2u);
  EXPECT_DOUBLE_EQ(*ReadParam("A545"), 0);
  server_->SetIgnoreExecute(false);
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 30, 0}).ok());
  ASSERT_TRUE(SendRpdo(1, {0x0F, 1, 30, 1}).ok());
  ASSERT_TRUE(WaitRpdosApplied(5));
  ASSERT_TRUE(RunUntil([&] { return rec_.actual && std::abs(rec_.actual->position - 30) < 1e-3; }));
  EXPECT_EQ(server_->dropped_execute_edges(), 2u);
}

TEST_F(StoberCanTest, HeartbeatFromProducerTimeAndInjectedLoss) {
  Start();
  ASSERT_TRUE(master_->ConfigureHeartbeatProducer(kNode, 100, Deadline()).ok());
  for (int i = 0; i < 3; ++i) Step(100ms);
  ASSERT_TRUE(rec_.WaitFor([&] { return rec_.heartbeats >= 3; }));
  server_->SetHeartbeatLoss(true);
  const uint64_t suppressed = server_->counters().node.suppressed;
  for (int i = 0; i < 3; ++i) Step(100ms);
  EXPECT_GE(server_->counters().node.suppressed, suppressed + 3);
  server_->SetHeartbeatLoss(false);
  int seen = 0;
  {
    std::lock_guard lock(rec_.mu);
    seen = rec_.heartbeats;
  }
  Step(100ms);
  EXPECT_TRUE(rec_.WaitFor([&] { return rec_.heartbeats > seen; }));
}

bool HasEmcy(const Recorder& r, uint16_t code) {
  for (const co::Emcy& e : r.emcy) {
    if (e.error_code == code) return true;
  }
  return false;
}

TEST_F(StoberCanTest, EmcyOnInjectedLimitSwitchAndErrorResetWhenReleased) {
  Start();
  server_->ForceLimitSwitch(true, true);
  Step(5ms);
  ASSERT_TRUE(rec_.WaitFor([&] { return HasEmcy(rec_, kEmcyLimitSwitch); }));
  {
    std::lock_guard lock(rec_.mu);
    for (const co::Emcy& e : rec_.emcy) {
      if (e.error_code == kEmcyLimitSwitch) {
        EXPECT_EQ(e.manufacturer[0], 1) << "positive switch";
        EXPECT_NE(e.error_register & kErrorRegisterProfile, 0);
      }
    }
  }
  EXPECT_EQ(*ReadParam("I441"), 1);
  EXPECT_NE(*master_->ReadU8(kNode, 0x1001, 0, Deadline()), 0);
  server_->ForceLimitSwitch(true, std::nullopt);
  Step(5ms);
  ASSERT_TRUE(rec_.WaitFor([&] { return HasEmcy(rec_, 0x0000); })) << "no error reset EMCY";
  EXPECT_EQ(*master_->ReadU8(kNode, 0x1001, 0, Deadline()), 0);
}

TEST_F(StoberCanTest, EmcyForMotionCoreErrorNamesTheCause) {
  Start();
  // MoveAbsolute to 20000, beyond the software limit I50 = 10000: denied, I91 = 1, I90 = 1.
  ASSERT_TRUE(WriteParam("I401", 1).ok());
  ASSERT_TRUE(WriteParam("I403", 20000).ok());
  ASSERT_TRUE(WriteParam("I402", 1).ok());
  Step(5ms);
  const uint16_t code = kEmcyMotionCoreBase + static_cast<int>(Cause::kSoftwareLimit);
  ASSERT_TRUE(rec_.WaitFor([&] { return HasEmcy(rec_, code); }));
  EXPECT_EQ(*ReadParam("I91"), 1);
  EXPECT_EQ(*ReadParam("I90"), static_cast<int>(Cause::kSoftwareLimit));
}

TEST_F(StoberCanTest, FollowingErrorFaultsTheDriveWithEmcy8611) {
  Start();
  server_->InjectFollowingError();
  ASSERT_TRUE(rec_.WaitFor([&] { return HasEmcy(rec_, kEmcyFollowingError); }));
  Step(20ms);
  EXPECT_NE(*master_->ReadU16(kNode, 0x6041, 0, Deadline()) & 0x08, 0) << "fault bit";
}

TEST_F(StoberCanTest, ResetNodeRestoresThePowerOnAxis) {
  Start();
  ASSERT_TRUE(WriteParam("I403", 5).ok());
  ASSERT_TRUE(WriteParam("I230", 50).ok());
  ASSERT_TRUE(master_->SendNmt(co::NmtCommand::kResetNode, kNode).ok());
  ASSERT_TRUE(rec_.WaitFor([&] { return rec_.bootups >= 2; }));
  EXPECT_EQ(*ReadParam("I403"), 0);
  EXPECT_EQ(*ReadParam("I230"), 100);
  EXPECT_EQ(*ReadParam("I89"), 2);
  server_->Reboot();  // injected power cycle: another boot-up
  EXPECT_TRUE(rec_.WaitFor([&] { return rec_.bootups >= 3; }));
}

TEST_F(StoberCanTest, EndlessAxisAndCycleTimeOptions) {
  AxisServerOptions o = EnabledAxis();
  o.axis.endless = true;
  o.axis.revolution = 90;
  o.axis.cycle_ms = 0.5;
  Start(o);
  EXPECT_EQ(*ReadParam("I00"), 1);
  EXPECT_DOUBLE_EQ(*ReadParam("I01"), 90);
  EXPECT_DOUBLE_EQ(*ReadParam("A150"), 0.5);
}

// The power-on extrapolation time (drivegw-sim stober --extrapolation-ms, the demo's 100 ms,
// decision 413) is I423 over SDO, and a reset node brings it back as a commissioned value would.
TEST_F(StoberCanTest, ExtrapolationTimeOptionIsI423AtPowerOnAndAfterResetNode) {
  AxisServerOptions o = EnabledAxis();
  o.axis.extrapolation_ms = 100;
  Start(o);
  EXPECT_DOUBLE_EQ(*ReadParam("I423"), 100);
  ASSERT_TRUE(WriteParam("I423", 7).ok());
  EXPECT_DOUBLE_EQ(*ReadParam("I423"), 7);
  ASSERT_TRUE(master_->SendNmt(co::NmtCommand::kResetNode, kNode).ok());
  ASSERT_TRUE(rec_.WaitFor([&] { return rec_.bootups >= 2; }));
  EXPECT_DOUBLE_EQ(*ReadParam("I423"), 100);
}

TEST(AxisServerOptionsTest, InvalidOptionsNameTheParameter) {
  ManualClock clock;
  AxisServerOptions o;
  o.node_id = 0;
  EXPECT_THAT(AxisServer::Start(o, clock).status().message(), HasSubstr("node id"));
  o.node_id = 1;
  o.axis.cycle_ms = 100;
  absl::Status s = AxisServer::Start(o, clock).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("A150"));
  o.axis.cycle_ms.reset();
  o.axis.extrapolation_ms = 60001;  // I423's catalogue range is 0..60000 ms
  s = AxisServer::Start(o, clock).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("I423"));
}

}  // namespace
}  // namespace drivegw::sim::stober
