// Safe recovery across a gateway restart (issue 11, docs/reliability.md "Safe recovery", gap 11;
// decision 1451): the simulated drive lives OUTSIDE the gateway and survives it. A gateway moves
// the axis to A, starts a slow move to B and is stopped mid-move; a new gateway starts and enables
// the drive. The simulator's own record (commands it executed, Execute edges, words it received)
// must show that nothing was re-sent on start-up or on enable — neither B nor A — the axis stays
// where the drive left it, and only a new command moves it. One test per family.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/stober/param_id.h"
#include "adapters/trinamic/codec.h"
#include "server/config/config.h"
#include "server/gateway.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/server.h"
#include "sim/stober/motion_core.h"
#include "sim/stober/server.h"
#include "sim/trinamic/server.h"
#include "tests/support/wait_status.h"

namespace drivegw {
namespace {

using std::chrono::seconds;
using test_support::WaitCommandFinal;
using test_support::WaitStatus;

constexpr auto kLong = seconds(30);  // generous: the host runs at load 6-10

// The family-independent view of one simulated drive: its own record, read without the gateway.
struct SimView {
  // Motion commands the drive received and interpreted since power-up (its own counter).
  std::function<uint64_t()> motion_commands;
  std::function<double()> position_mm;  // actual position, from the simulator
  std::function<bool()> moving;
  // Called once the drive stands, before the second gateway starts: a simulator whose record is
  // a bounded trace empties it here so the count after the restart cannot roll over.
  std::function<void()> mark = [] {};
};

// One family's scenario: the drive's configuration and the moves (A fast, B slow so the stop
// lands mid-move, C the new command after the restart).
struct Scenario {
  DriveConfig drive;
  SimView sim;
  bool home_first = false;
  double standstill_tolerance_mm = 0;  // the manual's in-position window, see each test
  MoveAbsolute to_a;
  MoveAbsolute to_b;
  MoveAbsolute to_c;
};

uint16_t RandomCanPort() {
  std::random_device rd;
  return static_cast<uint16_t>(20000 + rd() % 40000);
}

class GatewayRestartTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    data_dir_ = (std::filesystem::temp_directory_path() /
                 (std::string("dgw-restart-") + info->name() + "-" + std::to_string(::getpid())))
                    .string();
    std::filesystem::remove_all(data_dir_);
    std::filesystem::create_directories(data_dir_);
  }
  void TearDown() override { std::filesystem::remove_all(data_dir_); }

  std::unique_ptr<server::Gateway> StartGateway(const DriveConfig& drive) {
    server::GatewayOptions o;
    o.config.listen.grpc = "127.0.0.1:0";
    o.config.listen.http = "127.0.0.1:0";
    o.config.data_dir = data_dir_;
    o.config.demo = false;  // the one drive below, against the simulator this test owns
    o.config.drives = {drive};
    auto gw = server::Gateway::Start(o);
    EXPECT_TRUE(gw.ok()) << gw.status();
    return gw.ok() ? std::move(*gw) : nullptr;
  }

  static Drive& TheDrive(server::Gateway& gw) { return *gw.core().drives().front(); }

  // Waits (polling the simulator, which publishes no events) until `pred` holds or kLong passes.
  static bool WaitSim(const std::function<bool()>& pred) {
    const auto deadline = std::chrono::steady_clock::now() + kLong;
    while (!pred()) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  static bool Online(const DriveStatus& s) { return s.state != DriveState::kOffline; }

  // Lets the new gateway's session run: `n` more replies of the drive on its link (requests and
  // answers went both ways that often) — a count of exchanges, not a time.
  static void Exchanges(const Drive& d, uint64_t n) {
    const uint64_t from = d.link_health().replies;
    EXPECT_TRUE(WaitSim([&] { return d.link_health().replies >= from + n; }))
        << "the drive answered " << d.link_health().replies - from << " of " << n << " requests";
  }

  void Run(Scenario& sc) {
    // --- First gateway: A, then a slow move to B, stopped mid-move.
    double stopped_at = 0;
    {
      auto gw = StartGateway(sc.drive);
      ASSERT_NE(gw, nullptr);
      Drive& d = TheDrive(*gw);
      ASSERT_TRUE(Online(WaitStatus(d, Online, kLong))) << "first gateway never saw the drive";
      if (d.GetStatus().state == DriveState::kFault) {
        ASSERT_TRUE(d.AcknowledgeFault().ok());
      }
      auto en = d.Enable();
      ASSERT_TRUE(en.ok()) << en.status();
      ASSERT_EQ(WaitCommandFinal(d, en->id, kLong).state, CommandState::kDone);
      if (sc.home_first) {
        auto home = d.Home();
        ASSERT_TRUE(home.ok()) << home.status();
        ASSERT_EQ(WaitCommandFinal(d, home->id, kLong).state, CommandState::kDone);
      }
      auto a = d.Move(sc.to_a);
      ASSERT_TRUE(a.ok()) << a.status();
      ASSERT_EQ(WaitCommandFinal(d, a->id, kLong).state, CommandState::kDone);
      ASSERT_NEAR(sc.sim.position_mm(), sc.to_a.position_mm, sc.standstill_tolerance_mm);
      auto b = d.Move(sc.to_b);
      ASSERT_TRUE(b.ok()) << b.status();
      // Mid-move: the axis left A and is still moving toward B.
      ASSERT_TRUE(WaitSim([&] {
        return sc.sim.moving() && std::abs(sc.sim.position_mm() - sc.to_a.position_mm) >
                                      0.1 * std::abs(sc.to_b.position_mm - sc.to_a.position_mm);
      })) << "move to B never got under way";
      stopped_at = sc.sim.position_mm();
      gw.reset();  // Gateway::Stop: servers, drives and sessions go; the simulator stays
    }
    ASSERT_LT(std::abs(stopped_at - sc.to_b.position_mm),
              std::abs(sc.to_b.position_mm - sc.to_a.position_mm))
        << "the stop did not land mid-move";
    // Whatever the drive does on its own when its master goes silent (finish the profile, brake
    // on a watchdog), it is the drive's doing; wait for its standstill and remember it.
    ASSERT_TRUE(WaitSim([&] { return !sc.sim.moving(); })) << "simulated axis never stood";
    const double rest = sc.sim.position_mm();
    std::cout << "restart: A=" << sc.to_a.position_mm << " B=" << sc.to_b.position_mm
              << " stopped at " << stopped_at << " drive came to rest at " << rest << "\n";
    sc.sim.mark();
    const uint64_t commands_before = sc.sim.motion_commands();

    // --- Second gateway: start-up and enable send no motion command, the axis keeps still.
    auto gw = StartGateway(sc.drive);
    ASSERT_NE(gw, nullptr);
    Drive& d = TheDrive(*gw);
    ASSERT_TRUE(Online(WaitStatus(d, Online, kLong))) << "second gateway never saw the drive";
    Exchanges(d, 20);
    EXPECT_EQ(sc.sim.motion_commands(), commands_before) << "motion command sent on start-up";
    EXPECT_NEAR(sc.sim.position_mm(), rest, sc.standstill_tolerance_mm) << "moved on start-up";
    if (d.GetStatus().state == DriveState::kFault) {
      auto ack = d.AcknowledgeFault();
      ASSERT_TRUE(ack.ok()) << ack.status();
      ASSERT_EQ(WaitCommandFinal(d, ack->id, kLong).state, CommandState::kDone);
    }
    auto en = d.Enable();
    ASSERT_TRUE(en.ok()) << en.status();
    ASSERT_EQ(WaitCommandFinal(d, en->id, kLong).state, CommandState::kDone);
    Exchanges(d, 40);
    const DriveStatus after = d.GetStatus();
    EXPECT_EQ(sc.sim.motion_commands(), commands_before) << "motion command sent on enable";
    EXPECT_FALSE(sc.sim.moving());
    EXPECT_NEAR(sc.sim.position_mm(), rest, sc.standstill_tolerance_mm) << "moved on enable";
    EXPECT_NEAR(after.position_mm, rest, sc.standstill_tolerance_mm);
    EXPECT_FALSE(after.motion_active);

    // --- Only a new command moves it.
    auto c = d.Move(sc.to_c);
    ASSERT_TRUE(c.ok()) << c.status();
    EXPECT_EQ(WaitCommandFinal(d, c->id, kLong).state, CommandState::kDone);
    EXPECT_GT(sc.sim.motion_commands(), commands_before);
    EXPECT_NEAR(sc.sim.position_mm(), sc.to_c.position_mm, sc.standstill_tolerance_mm);
  }

  std::string data_dir_;
};

// LinMot LinUDP: the drive counts every MC command it interprets (new command count in the MC
// header, linmot-linudp.md / MC interface: a command runs only when the count changes). In-target
// window: the simulator's default In Pos window 0.1 mm (LinMot "Position Monitoring").
TEST_F(GatewayRestartTest, LinUdp_RestartMidMove_NothingResentAxisStill) {
  sim::linmot::SimOptions so;
  so.name = "r1";
  so.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
  so.master_port = 0;  // any source port: each gateway binds its own
  auto sim = sim::linmot::LinMotServer::Start(so, SteadyClock::Instance());
  ASSERT_TRUE(sim.ok()) << sim.status();
  sim::linmot::LinMotServer& s = **sim;
  Scenario sc;
  sc.drive = config::DemoDrives(0).front();
  sc.drive.name = "r1";
  sc.drive.linudp->port = s.port();
  sc.drive.linudp->master_port = 0;
  sc.sim.motion_commands = [&] {
    const auto d = s.Snapshot().device;
    return d.mc_commands_executed + d.mc_commands_rejected;
  };
  sc.sim.position_mm = [&] { return s.Snapshot().device.actual_position_mm; };
  sc.sim.moving = [&] { return s.Snapshot().device.motion_active; };
  sc.standstill_tolerance_mm = 0.1;
  sc.to_a = MoveAbsolute{20, 500, 5000, 5000};
  sc.to_b = MoveAbsolute{120, 40, 500, 500};  // 2.5 s: the stop lands mid-move
  sc.to_c = MoveAbsolute{60, 500, 5000, 5000};
  Run(sc);
}

// LinMot DeviceNet: the controller counts executed commands (command toggle T, §6 "Command
// Toggle": a command runs only on a changed T). Same In Pos window as LinUDP.
TEST_F(GatewayRestartTest, DeviceNet_RestartMidMove_NothingResentAxisStill) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.2";
  bus.port = RandomCanPort();
  sim::linmot_devicenet::DnSimOptions dso;
  dso.name = "r2";
  dso.can = bus;
  dso.mac_id = 5;
  auto sim = sim::linmot_devicenet::LinMotDnServer::Start(dso, SteadyClock::Instance());
  ASSERT_TRUE(sim.ok()) << sim.status();
  sim::linmot_devicenet::LinMotDnServer& s = **sim;
  Scenario sc;
  sc.drive.name = "r2";
  sc.drive.family = "linmot-devicenet";
  sc.drive.axis.min_mm = 0;
  sc.drive.axis.max_mm = 150;
  sc.drive.axis.max_velocity_mm_s = 1000;
  sc.drive.axis.max_acceleration_mm_s2 = 10000;
  sc.drive.can = bus;
  sc.drive.mac_id = 5;
  sc.sim.motion_commands = [&] {
    // §8.4: the commands that set a position set point or start motion (0x11-0x15 set point,
    // increment, home; 0x19 set actual position; 0x20-0x23 curves; 0x68 CAM start).
    const auto by_id = s.Snapshot().device.executed_by_id;
    uint64_t n = 0;
    for (uint8_t id : {0x11, 0x12, 0x13, 0x14, 0x15, 0x19, 0x20, 0x21, 0x22, 0x23, 0x68}) {
      n += by_id[id];
    }
    return n;
  };
  sc.sim.position_mm = [&] { return s.Snapshot().device.motors[0].actual_mm; };
  sc.sim.moving = [&] { return s.Snapshot().device.motors[0].motion_active; };
  sc.home_first = true;
  sc.standstill_tolerance_mm = 0.1;
  sc.to_a = MoveAbsolute{20, 500, 5000, 5000};
  sc.to_b = MoveAbsolute{120, 40, 500, 500};
  sc.to_c = MoveAbsolute{60, 500, 5000, 5000};
  Run(sc);
}

// Trinamic SIXpack: the PACK executes what it receives, so the record is the words it executed
// (server wire trace) filtered to the opcodes that start or redirect motion or rewrite the
// position counter (trinamic-sixpack.md §4: $22 reference search, $23 start ramp, $24 PI,
// $25 rotation, $26 set target, $27 set position, $29 parallel ramp, $50 interpolate). Standstill
// tolerance: one microstep (640 microsteps/mm).
TEST_F(GatewayRestartTest, Trinamic_RestartMidMove_NothingResentAxisStill) {
  sim::trinamic::ServerOptions so;
  so.controller.address = 1;
  so.controller.axes = 6;
  so.controller.framing = sim::trinamic::ReplyFraming::kR8;
  so.pty_path = (std::filesystem::path(data_dir_) / "pack.pty").string();
  auto sim = sim::trinamic::TrinamicServer::Start(so, SteadyClock::Instance());
  ASSERT_TRUE(sim.ok()) << sim.status();
  sim::trinamic::TrinamicServer& s = **sim;
  Scenario sc;
  sc.drive = config::DemoTrinamicDrives(so.pty_path).front();
  sc.drive.name = "r3";
  const double per_mm = sc.drive.trinamic->microsteps_per_unit;
  sc.sim.motion_commands = [&] {
    uint64_t n = 0;
    for (const auto& w : s.words()) {
      if (w.size() < 2) continue;
      switch (static_cast<trinamic::Opcode>(w[1])) {
        case trinamic::Opcode::kStartReferenceSearch:
        case trinamic::Opcode::kStartRamp:
        case trinamic::Opcode::kActivatePi:
        case trinamic::Opcode::kStartRotation:
        case trinamic::Opcode::kSetTarget:
        case trinamic::Opcode::kSetPosition:
        case trinamic::Opcode::kStartRampParallel:
        case trinamic::Opcode::kInterpolate:
          ++n;
          break;
        default:
          break;
      }
    }
    return n;
  };
  sc.sim.position_mm = [&] {
    double mm = 0;
    s.WithController([&](sim::trinamic::Controller& c) { mm = c.state(0).position / per_mm; });
    return mm;
  };
  sc.sim.moving = [&] {
    bool moving = false;
    s.WithController([&](sim::trinamic::Controller& c) {
      moving = c.state(0).action != sim::trinamic::Action::kInactive;
    });
    return moving;
  };
  sc.sim.mark = [&] { s.ClearWords(); };
  sc.standstill_tolerance_mm = 1.0 / per_mm;
  sc.to_a = MoveAbsolute{5, 40, 190, 190};
  sc.to_b = MoveAbsolute{60, 10, 100, 100};  // 5.5 s
  sc.to_c = MoveAbsolute{10, 40, 190, 190};
  Run(sc);
}

// STOBER CANopen: the motion core counts rising edges of Execute I402 with a command in I401
// (stober-motion.md §1.1/§2.2: a command starts only on that edge). Standstill: 0.001 u, the
// position resolution on the wire (decision 1172).
TEST_F(GatewayRestartTest, Stober_RestartMidMove_NothingResentAxisStill) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.2";
  bus.port = RandomCanPort();
  Scenario sc;
  sc.drive = config::DemoStoberDrive(bus);
  sc.drive.name = "r4";
  sim::stober::AxisServerOptions so;
  so.node_id = *sc.drive.node_id;
  so.can = bus;
  so.axis.extrapolation_ms = 100;  // as the demo (decision 413)
  auto sim = sim::stober::AxisServer::Start(so, SteadyClock::Instance());
  ASSERT_TRUE(sim.ok()) << sim.status();
  sim::stober::AxisServer& s = **sim;
  sc.sim.motion_commands = [&] {
    uint64_t n = 0;
    s.WithAxis([&](sim::stober::MotionCore& c) { n = c.execute_edges(); });
    return n;
  };
  sc.sim.position_mm = [&] {
    double p = 0;
    s.WithAxis([&](sim::stober::MotionCore& c) { p = c.actual_position_unwrapped(); });
    return p;
  };
  sc.sim.moving = [&] {
    double v = 0;
    s.WithAxis([&](sim::stober::MotionCore& c) { v = c.Read(stober::P("I88")).value_or(0); });
    return std::abs(v) > 1e-9;
  };
  sc.standstill_tolerance_mm = 0.001;
  sc.to_a = MoveAbsolute{20, 200, 2000, 2000};
  sc.to_b = MoveAbsolute{300, 100, 500, 500};  // 3 s
  sc.to_c = MoveAbsolute{60, 200, 2000, 2000};
  Run(sc);
}

}  // namespace
}  // namespace drivegw
