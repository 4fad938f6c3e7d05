// TrinamicDrive against the simulated SIXpack on a real pty (and on the UDP multicast CAN bus),
// real time. Positions are asserted exactly in microsteps (microsteps_per_unit = 1: 1 mm = 1
// microstep); waits are bounded conditions, never sleeps. CT-nn = trinamic-sixpack.md §8.
#include "adapters/trinamic/drive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/trinamic/factory.h"
#include "adapters/trinamic/parameters.h"
#include "sim/trinamic/can_server.h"
#include "sim/trinamic/server.h"
#include "tests/support/wait_status.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;
using sim::trinamic::Controller;
using sim::trinamic::ServerOptions;
using sim::trinamic::TrinamicCanServer;
using sim::trinamic::TrinamicServer;
using ::testing::HasSubstr;
using Bytes = std::vector<uint8_t>;

std::string TempLink() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("dgw-trdrive-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

CanBusConfig Bus(uint16_t port) {
  CanBusConfig c;
  c.kind = CanBusConfig::Kind::kUdpMulticast;
  c.group = "239.74.163.91";
  c.port = port;
  return c;
}

// 1 mm = 1 microstep; limits fit the PACK defaults (vmax 511 = 25991 µsteps/s, amax <= 320 =
// 127 kµsteps/s², §5.1, §5.3).
DriveConfig BaseConfig(const std::string& name, uint8_t axis) {
  DriveConfig c;
  c.name = name;
  c.family = kFamilyName;
  c.axis.min_mm = -20000;
  c.axis.max_mm = 20000;
  c.axis.max_velocity_mm_s = 26000;
  c.axis.max_acceleration_mm_s2 = 120000;
  c.timeouts.request = 2000ms;
  c.timeouts.accept = 100ms;
  c.timeouts.homing = 8000ms;
  TrinamicConfig t;
  t.address = 1;
  t.axis = axis;
  t.axes = 6;
  t.microsteps_per_unit = 1;
  t.poll_period = 5ms;
  t.reply_timeout = 60ms;
  t.offline_after_misses = 2;
  c.trinamic = t;
  return c;
}

bool IsQuery(const Bytes& w) {
  return w.size() == 9 && (w[1] == 0x20 || w[1] == 0x21 || w[1] == 0x43 || w[1] == 0x28);
}
std::vector<Bytes> NonQueries(const std::vector<Bytes>& words) {
  std::vector<Bytes> out;
  for (const Bytes& w : words) {
    if (!IsQuery(w)) out.push_back(w);
  }
  return out;
}

DriveStatus WaitStatus(Drive* d, const std::function<bool(const DriveStatus&)>& pred,
                       std::chrono::milliseconds timeout = 5000ms) {
  return test_support::WaitStatus(*d, pred, timeout);
}

class TrinamicDriveTest : public ::testing::Test {
 protected:
  void StartSim(ServerOptions options = {}) {
    options.pty_path = TempLink();
    auto s = TrinamicServer::Start(options, SteadyClock::Instance());
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
  }
  void TearDown() override {
    for (auto& d : drives_) d->Deactivate();
    drives_.clear();
    if (server_) server_->Stop();
  }
  DriveConfig Config(const std::string& name = "feeder-x", uint8_t axis = 0) {
    DriveConfig c = BaseConfig(name, axis);
    c.trinamic->serial = SerialLineConfig{server_->slave_path(), 19200, false, 6000us};
    return c;
  }
  Drive* Make(const DriveConfig& c) {
    auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
    EXPECT_TRUE(d.ok()) << d.status();
    if (!d.ok()) return nullptr;
    drives_.push_back(std::move(*d));
    return drives_.back().get();
  }
  Drive* Activate(const DriveConfig& c) {
    Drive* d = Make(c);
    if (d == nullptr) return nullptr;
    EXPECT_TRUE(d->Activate().ok());
    WaitUntil(d, [](const DriveStatus& s) { return s.state != DriveState::kOffline; });
    return d;
  }
  static DriveStatus WaitUntil(Drive* d, const std::function<bool(const DriveStatus&)>& pred,
                               std::chrono::milliseconds timeout = 5000ms) {
    return WaitStatus(d, pred, timeout);
  }
  static CommandInfo WaitFinal(Drive* d, uint64_t id, std::chrono::milliseconds timeout = 5000ms) {
    return test_support::WaitCommandFinal(*d, id, timeout);
  }
  static void Enable(Drive* d) {
    auto r = d->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }
  static CommandInfo MoveDone(Drive* d, const MotionCommand& cmd) {
    auto r = d->Move(cmd);
    EXPECT_TRUE(r.ok()) << r.status();
    if (!r.ok()) return {};
    return WaitFinal(d, r->id);
  }
  template <typename T>
  T Sim(const std::function<T(Controller&)>& fn) {
    T out{};
    server_->WithController([&](Controller& c) { out = fn(c); });
    return out;
  }
  // The server executes words on its own thread: wait (bounded) until the simulated PACK shows
  // the expected value.
  template <typename T>
  T SimEventually(const std::function<T(Controller&)>& fn, const T& expected) {
    const auto deadline = std::chrono::steady_clock::now() + 2s;
    T v = Sim<T>(fn);
    while (v != expected && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
      v = Sim<T>(fn);
    }
    return v;
  }
  // Returns once the simulator executed every word written so far: a reply it sends later
  // answers a query the session sent after them (no interleaving, L357). Needs a polling drive.
  void Settle() {
    const uint64_t n = server_->counters().replies;
    const auto deadline = std::chrono::steady_clock::now() + 2s;
    while (server_->counters().replies <= n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    EXPECT_GT(server_->counters().replies, n);
  }
  int32_t SimPosition(int motor) {
    return Sim<int32_t>([&](Controller& c) { return c.state(motor).position; });
  }

  std::unique_ptr<TrinamicServer> server_;
  std::vector<std::unique_ptr<Drive>> drives_;
};

TEST_F(TrinamicDriveTest, Activate_PollsPosition_StartsDisabledWithCurrentOff) {
  StartSim();
  server_->WithController([](Controller& c) {
    (void)c.Handle(*MakeCommand(1, Opcode::kSetPosition, {0, 1234}));  // `$27`
  });
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  const DriveStatus s =
      WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kDisabled; });
  EXPECT_EQ(s.state, DriveState::kDisabled);
  EXPECT_DOUBLE_EQ(s.position_mm, 1234);
  EXPECT_EQ(s.native.text, "inactive");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];  // the power-up reset flag is no warning
  const std::array<uint8_t, 4> off{8, 8, 8, 8};
  EXPECT_EQ((SimEventually<std::array<uint8_t, 4>>(
                [](Controller& c) { return c.registers(0).current_index; }, off)),
            off);
}

TEST_F(TrinamicDriveTest, EnableMoveAbsolute_DoneAtExactTarget_CurrentsConfigured) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->Move(MoveAbsolute{100, 1000, 10000, 0}).status().code(),
            absl::StatusCode::kFailedPrecondition);  // DISABLED
  Enable(d);
  EXPECT_EQ(d->GetStatus().state, DriveState::kEnabled);
  const std::array<uint8_t, 4> on{8, 2, 1, 0};  // shadow = §5.12 defaults
  EXPECT_EQ((SimEventually<std::array<uint8_t, 4>>(
                [](Controller& c) { return c.registers(0).current_index; }, on)),
            on);
  auto r = d->Move(MoveAbsolute{3001, 20000, 100000, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->state, CommandState::kActive);
  EXPECT_EQ(WaitFinal(d, r->id).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 3001);
  const DriveStatus s = d->GetStatus();
  EXPECT_DOUBLE_EQ(s.position_mm, 3001) << ::testing::PrintToString(NonQueries(server_->words()));
  EXPECT_TRUE(s.in_target);
  EXPECT_EQ(s.state, DriveState::kEnabled);
  // vmax/amax of the move went out as `$14` (20000 µsteps/s = 393, 100000 µsteps/s² = 252).
  EXPECT_EQ(Sim<int>([](Controller& c) { return c.registers(0).vmax; }), 393);
  EXPECT_EQ(Sim<int>([](Controller& c) { return c.registers(0).amax; }), 252);
}

TEST_F(TrinamicDriveTest, MoveRelativeVelocityStop_ExactPositions) {
  StartSim();
  DriveConfig c = Config();
  c.axis.min_mm = -3000;
  c.axis.max_mm = 3000;
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  Enable(d);
  EXPECT_EQ(MoveDone(d, MoveAbsolute{1000, 20000, 100000, 0}).state, CommandState::kDone);
  EXPECT_EQ(MoveDone(d, MoveRelative{-250, 20000, 100000, 0}).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 750);
  // MoveVelocity on a linear axis: a ramp to the axis end (decision 005).
  EXPECT_EQ(MoveDone(d, MoveVelocity{-20000, 100000, 0}).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), -3000);
  // Stop while moving: DONE at standstill, the move ABORTED, short of its end.
  auto move = d->Move(MoveVelocity{2000, 20000, 0});
  ASSERT_TRUE(move.ok()) << move.status();
  WaitUntil(d, [](const DriveStatus& s) { return s.position_mm > -2500; });
  auto stop = d->Move(StopMotion{100000});
  ASSERT_TRUE(stop.ok()) << stop.status();
  EXPECT_EQ(WaitFinal(d, stop->id).state, CommandState::kDone);
  EXPECT_EQ(d->GetCommand(move->id)->state, CommandState::kAborted);
  const DriveStatus s = WaitUntil(d, [](const DriveStatus& s) { return !s.motion_active; });
  EXPECT_LT(s.position_mm, 0);
  EXPECT_EQ(s.state, DriveState::kEnabled);
  EXPECT_EQ(static_cast<int32_t>(s.position_mm), SimPosition(0));
}

TEST_F(TrinamicDriveTest, MoveAbsolute_WhileRamping_RetargetsOnTheFly) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto first = d->Move(MoveAbsolute{15000, 3000, 30000, 0});
  ASSERT_TRUE(first.ok()) << first.status();
  WaitUntil(d, [](const DriveStatus& s) { return s.position_mm > 200; });
  server_->ClearWords();
  auto second = d->Move(MoveAbsolute{1500, 3000, 30000, 0});
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(d->GetCommand(first->id)->state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(d, second->id).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 1500);
  // L722: `$26` changed the running ramp (then `$23`, ignored while active, CT-23).
  const auto words = NonQueries(server_->words());
  ASSERT_FALSE(words.empty());
  EXPECT_EQ(words[0], (Bytes{0x01, 0x26, 0x00, 0xDC, 0x05, 0x00, 0x00, 0x00, 0x00}));
}

TEST_F(TrinamicDriveTest, Home_HomingThenDoneHomed) {
  ServerOptions o;
  // A switch active from 800 on, ahead of the motor (not NullLeft: the search ascends, L565).
  o.controller.world[0].switch_low = 800;
  o.controller.world[0].switch_high = 1'000'000'000;
  StartSim(o);
  DriveConfig c = Config();
  // FilterSwitch without NullCenter (the edge is the zero point), FastRef + DelayTestNull.
  c.trinamic->parameters = {{"$15.motor_type_low", 0x80}};
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->Home().status().code(), absl::StatusCode::kFailedPrecondition);  // DISABLED
  Enable(d);
  auto r = d->Home();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->state, CommandState::kActive);
  const DriveStatus homing =
      WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kHoming; });
  EXPECT_EQ(homing.state, DriveState::kHoming);
  EXPECT_THAT(homing.native.text, HasSubstr("reference search"));
  EXPECT_EQ(WaitFinal(d, r->id, 8000ms).state, CommandState::kDone);
  const DriveStatus s = d->GetStatus();
  EXPECT_TRUE(s.homed);
  EXPECT_EQ(s.state, DriveState::kEnabled);
}

TEST_F(TrinamicDriveTest, Home_Timeout_AbortedWithRotationZeroAndError) {
  StartSim();  // no switch within reach: the search repeats forever (CT-41)
  DriveConfig c = Config();
  c.timeouts.homing = 300ms;
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto r = d->Home();
  ASSERT_TRUE(r.ok()) << r.status();
  const CommandInfo done = WaitFinal(d, r->id);
  EXPECT_EQ(done.state, CommandState::kError);
  EXPECT_THAT(done.message, HasSubstr("reference search did not finish within 300 ms"));
  const DriveStatus s = WaitUntil(d, [](const DriveStatus& s) { return s.native.main_state == 0; });
  EXPECT_EQ(s.native.main_state, 0u);  // `$25 0` ended the search (G-13)
  EXPECT_FALSE(s.homed);
}

TEST_F(TrinamicDriveTest, MoveCoordinated_TwoAxes_EndTogetherAtTargets) {
  StartSim();
  Drive* x = Activate(Config("x", 0));
  Drive* y = Activate(Config("y", 1));
  ASSERT_NE(x, nullptr);
  ASSERT_NE(y, nullptr);
  Enable(x);
  Enable(y);
  std::array<Drive*, 2> group{x, y};
  auto r = x->MoveCoordinated(CoordinatedMove{{1000, 2000}, 10000, 60000}, group);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->size(), 2u);
  // CT-31 through introspection: both motors share one action and pos1 = 2 x pos0 (±2) at every
  // observation until both stand.
  bool together = true;
  bool on_line = true;
  const auto until = std::chrono::steady_clock::now() + 3s;
  for (bool moving = true; moving && std::chrono::steady_clock::now() < until;) {
    server_->WithController([&](Controller& c) {
      together = together && c.state(0).action == c.state(1).action;
      on_line = on_line && std::abs(c.state(1).position - 2 * c.state(0).position) <= 2;
      moving = c.state(0).action != sim::trinamic::Action::kInactive ||
               c.state(1).action != sim::trinamic::Action::kInactive;
    });
    std::this_thread::yield();
  }
  EXPECT_TRUE(together);
  EXPECT_TRUE(on_line);
  EXPECT_EQ(WaitFinal(x, (*r)[0].id).state, CommandState::kDone);
  EXPECT_EQ(WaitFinal(y, (*r)[1].id).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 1000);
  EXPECT_EQ(SimPosition(1), 2000);
  // Not a group of this controller's axes.
  std::array<Drive*, 2> twice{x, x};
  EXPECT_EQ(x->MoveCoordinated(CoordinatedMove{{0, 0}, 1000, 10000}, twice).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST_F(TrinamicDriveTest, Parameters_WriteReadValidate_NoWireTrafficOnRefusal) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  const ParameterRef vmax{ParameterId(Opcode::kSetRamp, 3), false};
  ASSERT_TRUE(d->WriteParameter(vmax, 300).ok());
  EXPECT_EQ(*d->ReadParameter(vmax), 300);
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(0).vmax; }, 300), 300);
  EXPECT_EQ(d->WriteParameter(ParameterRef{vmax.id, true}, 300).code(),
            absl::StatusCode::kInvalidArgument);  // no stored values (G-24)
  EXPECT_EQ(d->ReadParameter(ParameterRef{0x7777, false}).status().code(),
            absl::StatusCode::kNotFound);
  // CT-55: refused before transmission.
  const uint64_t before = server_->counters().words;
  server_->ClearWords();
  const std::vector<std::pair<uint32_t, int64_t>> bad = {
      {ParameterId(Opcode::kVelocitySetting, 0), 32},       // clkdiv 32
      {ParameterId(Opcode::kStartingVelocity, 5), 4},       // div 4
      {ParameterId(Opcode::kSetRamp, 3), 512},              // vmax 512
      {ParameterId(Opcode::kSetRamp, 1), 0},                // amax 0
      {ParameterId(Opcode::kSetRamp, 1), 321},              // amax > vstart 5 x 64
      {ParameterId(Opcode::kStartingVelocity, 1), 6},       // vmin > vstart
      {ParameterId(Opcode::kReferenceParameters, 1), 301},  // vrefmax > vmax 300
      {ParameterId(Opcode::kSetBaudRate, 2), 0},            // switchover 0
      {ParameterId(Opcode::kSetPacketTimeout, 0), 2},       // shorter than a word at 19200
  };
  for (const auto& [id, value] : bad) {
    EXPECT_EQ(d->WriteParameter(ParameterRef{id, false}, value).code(),
              absl::StatusCode::kInvalidArgument)
        << std::hex << id << " = " << std::dec << value;
  }
  EXPECT_TRUE(NonQueries(server_->words()).empty());
  // Only polls went out meanwhile: every word since `before` is a query.
  EXPECT_GE(server_->counters().words, before);
  EXPECT_EQ(*d->ReadParameter(vmax), 300);
}

// Decisions 1072/1073/1098: every configuration word the Pack sends reaches every axis's shadow
// (controller-wide values, the `$10` pair), and `$12.clkdiv` is checked against every axis.
TEST_F(TrinamicDriveTest, SharedShadows_ControllerAndPairWordsReachEveryAxis) {
  StartSim();
  Drive* x = Activate(Config("x", 0));
  DriveConfig cy = Config("y", 1);
  cy.trinamic->parameters = {{"$13.div", 0}};  // vmax 511 at div 0: 125 kHz at clkdiv 4
  Drive* y = Activate(cy);
  Drive* z = Activate(Config("z", 2));
  ASSERT_NE(x, nullptr);
  ASSERT_NE(y, nullptr);
  ASSERT_NE(z, nullptr);
  const ParameterRef clkdiv{ParameterId(Opcode::kVelocitySetting, 0), false};
  const ParameterRef peak{ParameterId(Opcode::kPeakCurrent, 1), false};
  const ParameterRef active_mask{ParameterId(Opcode::kReadyOutput, 0), false};
  // API write on x: the controller value in every shadow.
  ASSERT_TRUE(x->WriteParameter(clkdiv, 4).ok());
  EXPECT_EQ(*y->ReadParameter(clkdiv), 4);
  EXPECT_EQ(*z->ReadParameter(clkdiv), 4);
  // `$10` of x (motnr 0) is the pair 0+1: y follows, z (pair 2+3) does not (L505-512).
  ASSERT_TRUE(x->WriteParameter(peak, 200).ok());
  EXPECT_EQ(*y->ReadParameter(peak), 200);
  EXPECT_EQ(*z->ReadParameter(peak), 128);
  // Native pass-through on z: `$33` masks reach x too.
  ASSERT_TRUE(z->SendNative(TrinamicRequest{0x33, {0x07, 0x03, 0, 0, 0, 0, 0}}).ok());
  EXPECT_EQ(*x->ReadParameter(active_mask), 7);
  // clkdiv 0: fine for x and z (div 2: 156 kHz), not for y (div 0: 624 kHz, L497); refused from
  // x naming y, nothing sent.
  Settle();
  server_->ClearWords();
  const absl::Status refused = x->WriteParameter(clkdiv, 0);
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.message(), HasSubstr("drive 'y' (motor 1) would break: $12.clkdiv: 0"));
  EXPECT_THAT(refused.message(), HasSubstr("above 200000 Hz (L497)"));
  EXPECT_TRUE(NonQueries(server_->words()).empty());
  EXPECT_EQ(*z->ReadParameter(clkdiv), 4);
  // After a reset the controller words go out once, from the shadows that agree.
  server_->WithController([](Controller& c) { c.Reset(); });
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.globals().clkdiv; }, 4), 4);
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(1).peak_current; }, 200),
            200);
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.globals().ready_active_mask; }, 7), 7);
}

// G-40: when the PACK does not answer at the new rate the gateway returns to the old one and
// reports; non-standard divisors are refused before anything is sent (§2.1 table).
TEST_F(TrinamicDriveTest, BaudChange_NoAnswerAtNewRate_ReturnsAndReports) {
  StartSim();  // no peer-speed check: the `$40` is executed whatever the timing
  // The background polls also go unanswered while the simulator is silent: with the fixture's two
  // misses a loaded machine could take the link OFFLINE before the `$40` is even sent. This case
  // is about the baud fallback, not about link loss (tested elsewhere).
  DriveConfig config = Config();
  config.trinamic->offline_after_misses = 50;
  Drive* d = Activate(config);
  ASSERT_NE(d, nullptr);
  Settle();
  server_->ClearWords();
  auto odd = d->SendNative(TrinamicRequest{0x40, {100, 0, 3, 0, 0, 0, 0}});
  EXPECT_EQ(odd.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(odd.status().message(), HasSubstr("$40.divisor: 100"));
  EXPECT_TRUE(NonQueries(server_->words()).empty());

  server_->SetSilent(true);  // executes the `$40`, answers nothing
  const ParameterRef divisor{ParameterId(Opcode::kSetBaudRate, 0), false};
  const absl::Status s = d->WriteParameter(divisor, 130);
  server_->SetSilent(false);
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(s.message(), HasSubstr("no unit_information ($43) answer at 9600 baud"));
  EXPECT_THAT(s.message(), HasSubstr("returned to 19200 baud (G-40)"));
  EXPECT_EQ(*d->ReadParameter(divisor), 65);  // not absorbed: the switch was not confirmed
  EXPECT_EQ(Sim<int>([](Controller& c) { return c.globals().baud_divisor; }), 130);
}

TEST_F(TrinamicDriveTest, CT56_StoppedOnlyParameters_RefusedWhileActive) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto move = d->Move(MoveAbsolute{15000, 3000, 30000, 0});
  ASSERT_TRUE(move.ok()) << move.status();
  WaitUntil(d, [](const DriveStatus& s) { return s.motion_active; });
  server_->ClearWords();
  const absl::Status vstart = d->WriteParameter({ParameterId(Opcode::kStartingVelocity, 3)}, 8);
  EXPECT_EQ(vstart.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(vstart.message(), HasSubstr("$13.vstart"));
  const absl::Status clkdiv = d->WriteParameter({ParameterId(Opcode::kVelocitySetting, 0)}, 4);
  EXPECT_EQ(clkdiv.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(clkdiv.message(), HasSubstr("motor 0"));
  EXPECT_EQ(d->WriteParameter({ParameterId(Opcode::kReferenceParameters, 1)}, 50).code(),
            absl::StatusCode::kFailedPrecondition);
  for (const Bytes& w : server_->words()) {
    EXPECT_NE(w[1], 0x12);
    EXPECT_NE(w[1], 0x13);
    EXPECT_NE(w[1], 0x16);
  }
  ASSERT_TRUE(d->Move(StopMotion{100000}).ok());
}

TEST_F(TrinamicDriveTest, CT57_ResetReappliesParametersBeforeMotion) {
  StartSim();
  DriveConfig c = Config();
  c.trinamic->parameters = {{"$14.vmax", 300}};
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  ASSERT_TRUE(WaitUntil(d, [&](const DriveStatus&) {
                return Sim<int>([](Controller& c) { return c.registers(0).vmax; }) == 300;
              }).state != DriveState::kOffline);
  EXPECT_EQ(Sim<int>([](Controller& c) { return c.registers(0).vmax; }), 300);
  Enable(d);
  EXPECT_EQ(MoveDone(d, MoveAbsolute{500, 5000, 50000, 0}).state, CommandState::kDone);
  server_->WithController([](Controller& c) { c.Reset(); });
  server_->ClearWords();
  const DriveStatus s = WaitUntil(d, [](const DriveStatus& s) { return !s.warnings.empty(); });
  ASSERT_THAT(s.warnings, ::testing::Contains(HasSubstr("controller reset")));
  EXPECT_EQ(s.state, DriveState::kDisabled);
  EXPECT_FALSE(s.homed);
  // The shadow (with the last move's $14) went out again before anything else but queries.
  const int shadow_vmax =
      static_cast<int>(d->ReadParameter({ParameterId(Opcode::kSetRamp, 3)}).value());
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(0).vmax; }, shadow_vmax),
            shadow_vmax);
  const auto words = NonQueries(server_->words());
  ASSERT_FALSE(words.empty());
  for (const Bytes& w : words) {
    EXPECT_FALSE(w[1] >= 0x22 && w[1] <= 0x29) << "motion word before the re-apply";
  }
  // Re-enable and move: vmax 300 applies again when the move asks for it.
  Enable(d);
  EXPECT_TRUE(d->GetStatus().warnings.empty());
  EXPECT_EQ(MoveDone(d, MoveAbsolute{100, 300 * 50.86, 50000, 0}).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 100);
}

TEST_F(TrinamicDriveTest, CT57_ConfiguredVmaxOnTheWireAfterReset) {
  StartSim();
  DriveConfig c = Config();
  c.trinamic->parameters = {{"$14.vmax", 300}};
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  WaitUntil(d, [&](const DriveStatus&) {
    return Sim<int>([](Controller& c) { return c.registers(0).vmax; }) == 300;
  });
  server_->WithController([](Controller& c) { c.Reset(); });
  server_->ClearWords();
  WaitUntil(d, [](const DriveStatus& s) { return !s.warnings.empty(); });
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(0).vmax; }, 300), 300);
  const auto words = server_->words();
  EXPECT_THAT(words,
              ::testing::Contains(Bytes{0x01, 0x14, 0x00, 0x80, 0x00, 0x2C, 0x01, 0x00, 0x00}));
}

// CT-57, strict: a move right after a reset (before the periodic `$43`) is not executed with the
// PACK's defaults: the drive probes `$43` first, re-applies and refuses the move.
TEST_F(TrinamicDriveTest, CT57_MoveRightAfterReset_ReappliedAndNotSent) {
  StartSim();
  DriveConfig c = Config();
  c.trinamic->parameters = {{"$14.vmax", 300}};
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  Enable(d);
  const double v300 = 300 * 20e6 / (6 * 65536.0);  // keeps vmax 300: no `$14` before the move
  server_->WithController([](Controller& c) { c.Reset(); });
  server_->ClearWords();
  auto r = d->Move(MoveAbsolute{2000, v300, 20000, 0});
  ASSERT_FALSE(r.ok()) << ::testing::PrintToString(server_->words());
  EXPECT_THAT(r.status().message(), HasSubstr("reset"));
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(0).vmax; }, 300), 300);
  EXPECT_EQ(SimPosition(0), 0);
  const auto words = server_->words();
  // The re-applied `$14` carries vmax 300 (P3/P4 = 2C 01); its amax is the move's, absorbed.
  EXPECT_TRUE(std::any_of(words.begin(), words.end(), [](const Bytes& w) {
    return w[1] == 0x14 && w[2] == 0 && w[5] == 0x2C && w[6] == 0x01;
  })) << ::testing::PrintToString(words);
  for (const Bytes& w : words) EXPECT_NE(w[1], 0x23) << "motion word after a reset";
  const DriveStatus s = WaitUntil(d, [](const DriveStatus& s) { return !s.warnings.empty(); });
  EXPECT_EQ(s.state, DriveState::kDisabled);
}

TEST_F(TrinamicDriveTest, CT01_CT02_MoveWordsAreByteExact) {
  StartSim();
  DriveConfig c0 = Config("m0", 0);
  DriveConfig c5 = Config("m5", 5);
  Drive* m0 = Activate(c0);
  Drive* m5 = Activate(c5);
  ASSERT_NE(m0, nullptr);
  ASSERT_NE(m5, nullptr);
  Enable(m0);
  Enable(m5);
  // Default ramp (amax 128, vmax 511) so that no `$14` precedes the move.
  const double v511 = 511 * 20e6 / (6 * 65536.0);
  const double a128 = 7.8125 * 128 * 20e6 / (6 * 65536.0);
  const std::array<uint8_t, 4> on{8, 2, 1, 0};  // Enable's `$11` executed before the trace starts
  ASSERT_EQ((SimEventually<std::array<uint8_t, 4>>(
                [](Controller& c) { return c.registers(5).current_index; }, on)),
            on);
  server_->ClearWords();
  EXPECT_EQ(MoveDone(m0, MoveAbsolute{10000, v511, a128, 0}).state, CommandState::kDone);
  auto words = NonQueries(server_->words());
  ASSERT_EQ(words.size(), 1u) << ::testing::PrintToString(words);
  EXPECT_EQ(words[0], (Bytes{0x01, 0x23, 0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00}));  // CT-01
  server_->ClearWords();
  EXPECT_EQ(MoveDone(m5, MoveAbsolute{-6400, v511, a128, 0}).state, CommandState::kDone);
  words = NonQueries(server_->words());
  ASSERT_EQ(words.size(), 1u);
  EXPECT_EQ(words[0], (Bytes{0x01, 0x23, 0x05, 0x00, 0xE7, 0xFF, 0xFF, 0x00, 0x00}));  // CT-02
  auto reply = m5->SendNative(TrinamicRequest{0x20, {5, 0, 0, 0, 0, 0, 0}});
  ASSERT_TRUE(reply.ok()) << reply.status();
  EXPECT_EQ(reply->data, (Bytes{0x20, 0x05, 0x00, 0xE7, 0xFF, 0xFF, 0x00, 0x00}));
}

TEST_F(TrinamicDriveTest, SilentController_OfflineNamingDriveAndOpcode_ThenRecovers) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto running = d->Move(MoveAbsolute{1500, 3000, 30000, 0});
  ASSERT_TRUE(running.ok()) << running.status();
  server_->SetSilent(true);
  const CommandInfo lost = WaitFinal(d, running->id);
  EXPECT_EQ(lost.state, CommandState::kError);
  EXPECT_THAT(lost.message, HasSubstr("drive 'feeder-x': link lost"));
  EXPECT_THAT(lost.message, HasSubstr("query_"));
  const DriveStatus off =
      WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kOffline; });
  ASSERT_EQ(off.state, DriveState::kOffline);
  ASSERT_FALSE(off.warnings.empty());
  EXPECT_THAT(off.warnings.back(), HasSubstr("feeder-x"));
  EXPECT_THAT(off.warnings.back(), HasSubstr("query_"));
  const auto move = d->Move(MoveAbsolute{10, 1000, 10000, 0});
  EXPECT_EQ(move.status().code(), absl::StatusCode::kUnavailable);
  server_->SetSilent(false);
  const DriveStatus back = WaitUntil(
      d, [](const DriveStatus& s) { return s.state == DriveState::kEnabled; }, 8000ms);
  EXPECT_EQ(back.state, DriveState::kEnabled);  // not reset: still enabled
}

TEST_F(TrinamicDriveTest, StopCondition_FaultLatchedThenAcknowledged) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  // StopNoRef (P6 bit 5, G-10) keeps the PACK from starting a reference search after the stop.
  ASSERT_TRUE(d->WriteParameter({ParameterId(Opcode::kMotorParameters, 6)}, 0x2A).ok());
  ASSERT_TRUE(d->WriteParameter({ParameterId(Opcode::kAnalogStopLimits, 3)}, 900).ok());
  Enable(d);
  auto move = d->Move(MoveAbsolute{15000, 3000, 30000, 0});
  ASSERT_TRUE(move.ok()) << move.status();
  server_->WithController([](Controller& c) { c.world(0).analog = 901; });
  const DriveStatus f =
      WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kFault; });
  ASSERT_EQ(f.state, DriveState::kFault);
  EXPECT_EQ(f.fault.code, kFaultStopCondition);
  EXPECT_THAT(f.fault.text, HasSubstr("$20 P6"));
  EXPECT_FALSE(f.fault.fatal);
  EXPECT_EQ(WaitFinal(d, move->id).state, CommandState::kError);
  EXPECT_EQ(d->Enable().status().code(), absl::StatusCode::kFailedPrecondition);
  server_->WithController([](Controller& c) { c.world(0).analog = 512; });
  auto ack = d->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_NE(d->GetStatus().state, DriveState::kFault);
  Enable(d);
}

TEST_F(TrinamicDriveTest, Native_UnitInformationBodyAndServiceRefusal) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  auto r = d->SendNative(TrinamicRequest{0x43, {0x55, 0, 0, 0, 0, 0, 0}});  // RA forced to F0
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->data.size(), 8u);
  EXPECT_EQ(r->data[0], 0x43);
  EXPECT_EQ(r->data[1], 148);  // firmware V1.4.8
  EXPECT_EQ(d->SendNative(TrinamicRequest{0xF4, {}}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(d->SendNative(TrinamicTunnelRequest{{1, 2}}).status().code(),
            absl::StatusCode::kFailedPrecondition);  // tunnel needs CAN
  // A configuration opcode is absorbed into the shadow (re-sent after a reset).
  ASSERT_TRUE(d->SendNative(TrinamicRequest{0x14, {0, 0x40, 0, 0x2C, 0x01, 0, 0}}).ok());
  EXPECT_EQ(*d->ReadParameter({ParameterId(Opcode::kSetRamp, 3)}), 300);
  EXPECT_EQ(*d->ReadParameter({ParameterId(Opcode::kSetRamp, 1)}), 64);
}

TEST_F(TrinamicDriveTest, MoveVelocity_RotaryAxis_RotationUntilStop) {
  StartSim();
  DriveConfig c = Config();
  c.axis.kind = AxisKind::kRotary;
  c.axis.min_mm = 0;
  c.axis.max_mm = 6400;
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto r = d->Move(MoveVelocity{-2000, 50000, 0});  // `$25` with a negative register (L711)
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->state, CommandState::kActive);
  const DriveStatus s = WaitUntil(d, [](const DriveStatus& s) { return s.velocity_mm_s < -1000; });
  EXPECT_EQ(s.state, DriveState::kMoving);
  EXPECT_EQ(s.native.text, "rotation");
  EXPECT_EQ(Sim<int>([](Controller& c) { return c.state(0).rotation_velocity; }), -39);
  auto stop = d->Move(StopMotion{0});
  ASSERT_TRUE(stop.ok()) << stop.status();
  EXPECT_EQ(WaitFinal(d, stop->id).state, CommandState::kDone);
  EXPECT_EQ(d->GetCommand(r->id)->state, CommandState::kAborted);
  EXPECT_EQ(d->GetStatus().state, DriveState::kEnabled);
}

// `$CC` through SendNative (allowed, §4.2 L895-902): the PACK boots ~1 s, the session comes back
// with the reset flag and the drive re-applies its parameters (decisions 1086, 1093).
TEST_F(TrinamicDriveTest, NativeHardwareReset_ReappliedAfterBoot) {
  StartSim();
  DriveConfig c = Config();
  c.trinamic->parameters = {{"$14.vmax", 300}};
  Drive* d = Activate(c);
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto r = d->SendNative(TrinamicRequest{0xCC, {}});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_TRUE(r->data.empty());  // no reply (L899)
  const DriveStatus s = WaitUntil(
      d,
      [](const DriveStatus& s) {
        return s.state != DriveState::kOffline &&
               std::find(s.warnings.begin(), s.warnings.end(),
                         "controller reset: parameters re-applied, re-enable and re-home") !=
                   s.warnings.end();
      },
      6000ms);
  EXPECT_EQ(s.state, DriveState::kDisabled);
  EXPECT_EQ(SimEventually<int>([](Controller& c) { return c.registers(0).vmax; }, 300), 300);
}

// Decision 1081: drives of one controller share a Pack; conflicting transport settings and a
// second drive on the same motor are refused at activation.
TEST_F(TrinamicDriveTest, SharedPack_ConflictingSettingsAndSameMotorRefused) {
  StartSim();
  Drive* x = Activate(Config("x", 0));
  ASSERT_NE(x, nullptr);
  DriveConfig other_baud = Config("y", 1);
  other_baud.trinamic->serial->baud = 9600;
  Drive* y = Make(other_baud);
  ASSERT_NE(y, nullptr);
  const absl::Status conflict = y->Activate();
  EXPECT_EQ(conflict.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(conflict.message(), HasSubstr("trinamic.serial.baud"));
  Drive* twin = Make(Config("x-twin", 0));
  ASSERT_NE(twin, nullptr);
  EXPECT_EQ(twin->Activate().code(), absl::StatusCode::kAlreadyExists);
  // The first drive is unaffected.
  Enable(x);
  EXPECT_EQ(MoveDone(x, MoveAbsolute{321, 20000, 100000, 0}).state, CommandState::kDone);
  EXPECT_EQ(SimPosition(0), 321);
}

TEST(TrinamicFactoryTest, ConfigErrors_NameTheField) {
  DriveConfig c = BaseConfig("feeder-x", 6);
  c.trinamic->serial = SerialLineConfig{"/dev/null", 19200, false, 6000us};
  auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().message(),
            "drive 'feeder-x'.trinamic.axis: 6 exceeds 5 (SIXpack motors 0..5)");
  c.trinamic->axis = 0;
  c.trinamic->response_address = 1;
  EXPECT_THAT(CreateTrinamicDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("trinamic.response_address"));
  c.trinamic->response_address = 0xF0;
  c.trinamic->parameters = {{"$14.amax", 321}};
  EXPECT_THAT(CreateTrinamicDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("parameters[0] '$14.amax'"));
  c.trinamic->parameters = {{"$99.nothing", 1}};
  EXPECT_EQ(CreateTrinamicDrive(c, SteadyClock::Instance()).status().code(),
            absl::StatusCode::kInvalidArgument);
  c.trinamic->parameters = {};
  c.trinamic->can = Bus(30000);
  EXPECT_THAT(CreateTrinamicDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("exactly one of serial and can"));
  c.trinamic->can.reset();
  c.trinamic->serial->baud = 12345;
  EXPECT_THAT(CreateTrinamicDrive(c, SteadyClock::Instance()).status().message(),
              HasSubstr("serial.baud"));
}

// ---- CAN ----

class TrinamicCanDriveTest : public ::testing::Test {
 protected:
  std::unique_ptr<TrinamicCanServer> StartSim(const CanBusConfig& bus) {
    sim::trinamic::CanServerOptions o;
    o.can = bus;
    auto s = TrinamicCanServer::Start(o, SteadyClock::Instance());
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *std::move(s) : nullptr;
  }
};

TEST_F(TrinamicCanDriveTest, MoveOverCan_DoneAtTarget) {
  const CanBusConfig bus = Bus(RandomPort());
  auto sim = StartSim(bus);
  ASSERT_NE(sim, nullptr);
  DriveConfig c = BaseConfig("can-x", 2);
  c.trinamic->can = bus;
  auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(d.ok()) << d.status();
  ASSERT_TRUE((*d)->Activate().ok());
  const DriveStatus s =
      WaitStatus(d->get(), [](const DriveStatus& s) { return s.state != DriveState::kOffline; });
  ASSERT_EQ(s.state, DriveState::kDisabled);
  ASSERT_TRUE((*d)->Enable().ok());
  auto r = (*d)->Move(MoveAbsolute{-777, 10000, 60000, 0});
  ASSERT_TRUE(r.ok()) << r.status();
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!IsFinal((*d)->GetCommand(r->id)->state) && std::chrono::steady_clock::now() < deadline) {
    (*d)->WaitForStatus((*d)->GetStatus().sequence, deadline);
  }
  EXPECT_EQ((*d)->GetCommand(r->id)->state, CommandState::kDone);
  int32_t pos = 0;
  sim->WithController([&](Controller& c) { pos = c.state(2).position; });
  EXPECT_EQ(pos, -777);
  // The tunnel goes out on CAN (CT-53's host side).
  EXPECT_TRUE((*d)->SendNative(TrinamicTunnelRequest{{0x41, 0x42, 0x43}}).ok());
  (*d)->Deactivate();
  sim->Stop();
}

TEST_F(TrinamicCanDriveTest, DuplicateAddress_ReportedAsFault) {
  const CanBusConfig bus = Bus(RandomPort());
  auto a = StartSim(bus);
  auto b = StartSim(bus);  // a second PACK with the same address 1 on the bus
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  DriveConfig c = BaseConfig("dup", 0);
  c.trinamic->can = bus;
  auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(d.ok()) << d.status();
  ASSERT_TRUE((*d)->Activate().ok());
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  DriveStatus s = (*d)->GetStatus();
  while (s.state != DriveState::kFault && std::chrono::steady_clock::now() < deadline) {
    s = (*d)->WaitForStatus(s.sequence, deadline);
  }
  ASSERT_EQ(s.state, DriveState::kFault);
  EXPECT_EQ(s.fault.code, kFaultDuplicateAddress);
  EXPECT_THAT(s.fault.text, HasSubstr("another controller answers at address 1"));
  EXPECT_EQ((*d)->AcknowledgeFault().status().code(), absl::StatusCode::kFailedPrecondition);
  (*d)->Deactivate();
  a->Stop();
  b->Stop();
}

// ---- Safe recovery (issue 11, decision 1451) ---------------------------------------------------
// The PACK executes every word it receives and stores nothing across a reset (trinamic-sixpack.md
// §2.8, G-24: after `$CC`/power loss the registers and posact are at their reset values): a word
// that starts or redirects motion or rewrites posact after a link loss, a reset or a fault
// acknowledge would move the axis (or its idea of where it is) without a new command. The server's
// word trace from the loss to the re-enable must hold none of them.

class TrinamicRecoveryTest : public TrinamicDriveTest {
 protected:
  // `$22` reference search, `$23` ramp, `$24` PI, `$25` rotation, `$26` set target, `$27` set
  // position, `$29` parallel ramp, `$50` interpolate (§4.1).
  static bool IsMotionWord(const Bytes& w) {
    switch (w[1]) {
      case 0x22:
      case 0x23:
      case 0x24:
      case 0x25:
      case 0x26:
      case 0x27:
      case 0x29:
      case 0x50:
        return true;
      default:
        return false;
    }
  }
  size_t MotionWords() {
    const auto words = server_->words();
    return static_cast<size_t>(std::count_if(words.begin(), words.end(), IsMotionWord));
  }
  bool SimMoving() {
    return Sim<bool>(
        [](Controller& c) { return c.state(0).action != sim::trinamic::Action::kInactive; });
  }
  void WaitSimStill() {
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (SimMoving() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(2ms);
    }
    ASSERT_FALSE(SimMoving());
  }
  // Re-enable after the recovery, let 20 polls go both ways: no motion word on the wire, the
  // axis where the drive left it; a new command then moves it (and shows up in the trace).
  void ReEnableAndExpectNothingResent(Drive* d, int32_t position) {
    if (d->GetStatus().state == DriveState::kFault) {
      auto ack = d->AcknowledgeFault();
      ASSERT_TRUE(ack.ok()) << ack.status();
    }
    Enable(d);
    for (int i = 0; i < 20; ++i) Settle();
    EXPECT_EQ(MotionWords(), 0u) << ::testing::PrintToString(server_->words());
    EXPECT_FALSE(SimMoving());
    EXPECT_EQ(SimPosition(0), position);
    EXPECT_EQ(MoveDone(d, MoveAbsolute{position + 500.0, 3000, 30000, 0}).state,
              CommandState::kDone);
    EXPECT_GT(MotionWords(), 0u);
  }
};

TEST_F(TrinamicRecoveryTest, SilentMidMove_ReEnableSendsNoStaleTarget) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  Enable(d);
  auto running = d->Move(MoveAbsolute{3000, 3000, 30000, 0});
  ASSERT_TRUE(running.ok()) << running.status();
  server_->SetSilent(true);
  ASSERT_EQ(
      WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kOffline; }).state,
      DriveState::kOffline);
  WaitSimStill();  // the PACK finishes the ramp on its own
  const int32_t rest = SimPosition(0);
  server_->ClearWords();
  server_->SetSilent(false);
  ASSERT_NE(WaitUntil(
                d, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, 8000ms)
                .state,
            DriveState::kOffline);
  ReEnableAndExpectNothingResent(d, rest);
}

TEST_F(TrinamicRecoveryTest, ControllerResetAfterMove_ReEnableSendsNoStaleTarget) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  Enable(d);
  ASSERT_EQ(MoveDone(d, MoveAbsolute{1200, 3000, 30000, 0}).state, CommandState::kDone);
  server_->WithController([](Controller& c) { c.Reset(); });  // power loss: posact 0 (G-24)
  server_->ClearWords();
  // The drive notices the reset flag and re-applies its parameters (CT-57), then stands.
  WaitUntil(d, [](const DriveStatus& s) { return !s.warnings.empty(); });
  for (int i = 0; i < 5; ++i) Settle();
  ReEnableAndExpectNothingResent(d, SimPosition(0));
}

TEST_F(TrinamicRecoveryTest, StopConditionFaultThenAcknowledge_ReEnableSendsNoStaleTarget) {
  StartSim();
  Drive* d = Activate(Config());
  ASSERT_NE(d, nullptr);
  ASSERT_TRUE(d->WriteParameter({ParameterId(Opcode::kMotorParameters, 6)}, 0x2A).ok());
  ASSERT_TRUE(d->WriteParameter({ParameterId(Opcode::kAnalogStopLimits, 3)}, 900).ok());
  Enable(d);
  auto move = d->Move(MoveAbsolute{15000, 3000, 30000, 0});
  ASSERT_TRUE(move.ok()) << move.status();
  server_->WithController([](Controller& c) { c.world(0).analog = 901; });
  ASSERT_EQ(WaitUntil(d, [](const DriveStatus& s) { return s.state == DriveState::kFault; }).state,
            DriveState::kFault);
  WaitSimStill();
  const int32_t rest = SimPosition(0);
  EXPECT_LT(rest, 15000);
  server_->ClearWords();
  server_->WithController([](Controller& c) { c.world(0).analog = 512; });
  ReEnableAndExpectNothingResent(d, rest);
}

}  // namespace
}  // namespace drivegw::trinamic
