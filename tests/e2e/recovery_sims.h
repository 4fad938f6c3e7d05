// Test support for the safe-recovery tests (issue 11, decision 1451): one simulated drive per
// family that lives OUTSIDE any gateway — the test owns it, gateways come and go — with the
// drive's own record of what it executed, its configuration (in code and as drivegw YAML) and the
// moves of the scenario (A fast, B slow so a stop lands mid-move, C the new command after).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/clock.h"
#include "adapters/core/command.h"
#include "adapters/core/drive_config.h"
#include "adapters/stober/param_id.h"
#include "adapters/trinamic/codec.h"
#include "server/config/config.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/server.h"
#include "sim/stober/motion_core.h"
#include "sim/stober/server.h"
#include "sim/trinamic/server.h"

namespace drivegw::test_support {

// The family-independent view of one simulated drive, read without any gateway.
struct SimView {
  // Motion commands and set points the drive received and executed since power-up.
  std::function<uint64_t()> motion_commands;
  std::function<double()> position_mm;  // actual position
  std::function<bool()> moving;
  // Called once the drive stands, before the next gateway starts: a simulator whose record is
  // a bounded trace empties it here so the count after the restart cannot roll over.
  std::function<void()> mark = [] {};
};

struct FamilySim {
  std::shared_ptr<void> owner;  // the simulator; outlives every gateway of the test
  SimView sim;
  DriveConfig drive;
  std::string yaml;  // the drive's entry under `drives:` of a drivegw configuration file
  bool home_first = false;
  double standstill_tolerance_mm = 0;  // the manual's in-position window, see each family
  MoveAbsolute to_a;
  MoveAbsolute to_b;
  MoveAbsolute to_c;
};

inline CanBusConfig RandomUdpBus() {
  std::random_device rd;
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.2";
  bus.port = static_cast<uint16_t>(20000 + rd() % 40000);
  return bus;
}

inline std::string YamlBus(const CanBusConfig& bus) {
  return absl::StrCat("{udp: {group: ", bus.group, ", port: ", bus.port, "}}");
}

// LinMot LinUDP: the drive counts every MC command it interprets (linmot-mc.md L351: a command
// runs only when the count nibble changed; rejected ones count too). Standstill: the default
// In Pos window, 0.1 mm.
inline absl::StatusOr<FamilySim> StartLinUdpSim(const std::string& name) {
  sim::linmot::SimOptions so;
  so.name = name;
  so.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
  so.master_port = 0;  // any source port: each gateway binds its own
  auto started = sim::linmot::LinMotServer::Start(so, SteadyClock::Instance());
  if (!started.ok()) return started.status();
  std::shared_ptr<sim::linmot::LinMotServer> s = std::move(*started);
  FamilySim f;
  f.owner = s;
  f.drive = config::DemoDrives(0).front();
  f.drive.name = name;
  f.drive.linudp->port = s->port();
  f.drive.linudp->master_port = 0;
  f.yaml = absl::StrCat("  - name: ", name, "\n    family: linmot\n",
                        "    linudp: {host: 127.0.0.1, port: ", s->port(), ", master_port: 0}\n",
                        "    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, ",
                        "max_acceleration_mm_s2: 20000}\n");
  sim::linmot::LinMotServer* p = s.get();
  f.sim.motion_commands = [p] {
    const auto d = p->Snapshot().device;
    return d.mc_commands_executed + d.mc_commands_rejected;
  };
  f.sim.position_mm = [p] { return p->Snapshot().device.actual_position_mm; };
  f.sim.moving = [p] { return p->Snapshot().device.motion_active; };
  f.standstill_tolerance_mm = 0.1;
  f.to_a = MoveAbsolute{20, 500, 5000, 5000};
  f.to_b = MoveAbsolute{80, 40, 500, 500};  // 1.6 s: a stop lands mid-move
  f.to_c = MoveAbsolute{60, 500, 5000, 5000};
  return f;
}

// LinMot DeviceNet: §8.4 commands that set a position set point or start motion (0x11-0x15 set
// point, increment, home; 0x19 set actual position; 0x20-0x23 curves; 0x68 CAM start), counted
// by the drive when executed (T-commands only on a changed toggle, D-4). Same In Pos window.
inline absl::StatusOr<FamilySim> StartDeviceNetSim(const std::string& name) {
  const CanBusConfig bus = RandomUdpBus();
  sim::linmot_devicenet::DnSimOptions dso;
  dso.name = name;
  dso.can = bus;
  dso.mac_id = 5;
  auto started = sim::linmot_devicenet::LinMotDnServer::Start(dso, SteadyClock::Instance());
  if (!started.ok()) return started.status();
  std::shared_ptr<sim::linmot_devicenet::LinMotDnServer> s = std::move(*started);
  FamilySim f;
  f.owner = s;
  f.drive.name = name;
  f.drive.family = "linmot-devicenet";
  f.drive.axis.min_mm = 0;
  f.drive.axis.max_mm = 150;
  f.drive.axis.max_velocity_mm_s = 1000;
  f.drive.axis.max_acceleration_mm_s2 = 10000;
  f.drive.can = bus;
  f.drive.mac_id = 5;
  f.yaml = absl::StrCat("  - name: ", name, "\n    family: linmot-devicenet\n",
                        "    can: ", YamlBus(bus), "\n    mac_id: 5\n",
                        "    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 1000, ",
                        "max_acceleration_mm_s2: 10000}\n");
  sim::linmot_devicenet::LinMotDnServer* p = s.get();
  f.sim.motion_commands = [p] {
    const auto by_id = p->Snapshot().device.executed_by_id;
    uint64_t n = 0;
    for (uint8_t id : {0x11, 0x12, 0x13, 0x14, 0x15, 0x19, 0x20, 0x21, 0x22, 0x23, 0x68}) {
      n += by_id[id];
    }
    return n;
  };
  f.sim.position_mm = [p] { return p->Snapshot().device.motors[0].actual_mm; };
  f.sim.moving = [p] { return p->Snapshot().device.motors[0].motion_active; };
  f.home_first = true;
  f.standstill_tolerance_mm = 0.1;
  f.to_a = MoveAbsolute{20, 500, 5000, 5000};
  f.to_b = MoveAbsolute{120, 40, 500, 500};
  f.to_c = MoveAbsolute{60, 500, 5000, 5000};
  return f;
}

// Trinamic SIXpack on a pty in `dir`: the PACK executes every word it receives (§4.1), so the
// record is its word trace filtered to the opcodes that start or redirect motion or rewrite
// posact ($22 reference search, $23 ramp, $24 PI, $25 rotation, $26 set target, $27 set position,
// $29 parallel ramp, $50 interpolate). Standstill: one microstep (640 microsteps/mm).
inline absl::StatusOr<FamilySim> StartTrinamicSim(const std::string& name, const std::string& dir) {
  sim::trinamic::ServerOptions so;
  so.controller.address = 1;
  so.controller.axes = 6;
  so.controller.framing = sim::trinamic::ReplyFraming::kR8;
  so.pty_path = (std::filesystem::path(dir) / "pack.pty").string();
  auto started = sim::trinamic::TrinamicServer::Start(so, SteadyClock::Instance());
  if (!started.ok()) return started.status();
  std::shared_ptr<sim::trinamic::TrinamicServer> s = std::move(*started);
  FamilySim f;
  f.owner = s;
  f.drive = config::DemoTrinamicDrives(so.pty_path).front();
  f.drive.name = name;
  f.yaml = absl::StrCat("  - name: ", name, "\n    family: trinamic\n",
                        "    trinamic: {serial: {device: ", so.pty_path,
                        "}, address: 1, axis: 0, microsteps_per_unit: 640}\n",
                        "    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 40, ",
                        "max_acceleration_mm_s2: 190}\n");
  const double per_mm = f.drive.trinamic->microsteps_per_unit;
  sim::trinamic::TrinamicServer* p = s.get();
  f.sim.motion_commands = [p] {
    uint64_t n = 0;
    for (const auto& w : p->words()) {
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
  f.sim.position_mm = [p, per_mm] {
    double mm = 0;
    p->WithController([&](sim::trinamic::Controller& c) { mm = c.state(0).position / per_mm; });
    return mm;
  };
  f.sim.moving = [p] {
    bool moving = false;
    p->WithController([&](sim::trinamic::Controller& c) {
      moving = c.state(0).action != sim::trinamic::Action::kInactive;
    });
    return moving;
  };
  f.sim.mark = [p] { p->ClearWords(); };
  f.standstill_tolerance_mm = 1.0 / per_mm;
  f.to_a = MoveAbsolute{5, 40, 190, 190};
  f.to_b = MoveAbsolute{25, 10, 100, 100};  // 2.1 s
  f.to_c = MoveAbsolute{10, 40, 190, 190};
  return f;
}

// STOBER CANopen node 3: the motion core counts rising edges of Execute I402 with a command in
// I401 (stober-motion.md L156-166: only that edge starts a command). Standstill: 0.001 u, the
// position resolution on the wire (decision 1172).
inline absl::StatusOr<FamilySim> StartStoberSim(const std::string& name) {
  const CanBusConfig bus = RandomUdpBus();
  FamilySim f;
  f.drive = config::DemoStoberDrive(bus);
  f.drive.name = name;
  sim::stober::AxisServerOptions so;
  so.node_id = *f.drive.node_id;
  so.can = bus;
  so.axis.extrapolation_ms = 100;  // as the demo (decision 413)
  auto started = sim::stober::AxisServer::Start(so, SteadyClock::Instance());
  if (!started.ok()) return started.status();
  std::shared_ptr<sim::stober::AxisServer> s = std::move(*started);
  f.owner = s;
  f.yaml = absl::StrCat("  - name: ", name, "\n    family: stober\n", "    can: ", YamlBus(bus),
                        "\n    node_id: ", *f.drive.node_id, "\n",
                        "    axis: {min_mm: -10000, max_mm: 10000, max_velocity_mm_s: 1000, ",
                        "max_acceleration_mm_s2: 10000}\n");
  sim::stober::AxisServer* p = s.get();
  f.sim.motion_commands = [p] {
    uint64_t n = 0;
    p->WithAxis([&](sim::stober::MotionCore& c) { n = c.execute_edges(); });
    return n;
  };
  f.sim.position_mm = [p] {
    double x = 0;
    p->WithAxis([&](sim::stober::MotionCore& c) { x = c.actual_position_unwrapped(); });
    return x;
  };
  f.sim.moving = [p] {
    double v = 0;
    p->WithAxis([&](sim::stober::MotionCore& c) { v = c.Read(stober::P("I88")).value_or(0); });
    return v != 0;
  };
  f.standstill_tolerance_mm = 0.001;
  f.to_a = MoveAbsolute{20, 200, 2000, 2000};
  f.to_b = MoveAbsolute{160, 100, 500, 500};  // 1.6 s
  f.to_c = MoveAbsolute{60, 200, 2000, 2000};
  return f;
}

}  // namespace drivegw::test_support
