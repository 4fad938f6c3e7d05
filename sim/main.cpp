// drivegw-sim: runs simulated drives on real UDP sockets or a CAN bus until SIGINT/SIGTERM
// (commissioning, demos, manual tests of the gateway). Bad flags: message naming the flag on
// stderr, exit 2.
#include <signal.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "adapters/core/clock.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/transport/endpoint.h"
#include "adapters/transport/impaired_can_channel.h"
#include "adapters/transport/impaired_link.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/cli.h"
#include "sim/linmot_devicenet/server.h"
#include "sim/stober/server.h"
#include "sim/trinamic/can_server.h"
#include "sim/trinamic/server.h"

namespace {

using drivegw::SteadyClock;
using drivegw::sim::linmot::LinMotServer;
using drivegw::sim::linmot::SimOptions;

constexpr int kUsageError = 2;

constexpr const char* kUsage = R"(usage: drivegw-sim linmot [flags]
       drivegw-sim linmot-devicenet [flags]   (drivegw-sim linmot-devicenet --help)
       drivegw-sim trinamic --pty PATH | --can SPEC [--pty PATH] [trinamic flags]
                            (drivegw-sim trinamic --help)
       drivegw-sim stober --can SPEC --node N [stober flags]   (drivegw-sim stober --help)

Simulated LinMot drive(s) speaking LinUDP V2 on real UDP sockets (linmot-linudp.md, linmot-mc.md).

flags:
  --host IP              address to listen on (default 127.0.0.1)
  --port N               drive port; 0 = ephemeral (default 49360)
  --master-port N        only datagrams from this source port are answered, replies go to it;
                         0 = answer any source port (default 41136)
  --count N              N drives on consecutive ports port, port+1, ... (default 1)
  --name NAME            drive name; with --count, NAME-1, NAME-2, ... (default linmot)
  --stroke-min MM        mechanical stroke and position limits (default 0)
  --stroke-max MM        (default 150)
  --initial-position MM  slider position at power-up (default 10)
  --home-position MM     where homing (control word bit 11) moves to (default 0)
  --max-velocity MM_S    motor speed capability (default 4000)
  --tick-ms MS           physics tick, 0.25 ... 10 (default 1)
  --hw-test-ms MS        duration of state 5 (default 300)
  --boot-ms MS           silence after restart 0x30 / Reset 00F0h (default 2000)
  --product P            C1100, C1250, E1200 or E1400: command availability (default C1250)
  --reply-payload N      zero-fill replies to N bytes: 14 (observed) or 64 (manual) (default 14)
  --status-every S       print each drive's state every S seconds (default 0 = never)
  -h, --help             this text

every family:
  --impair SPEC          seeded faults on the simulator's link, both directions, e.g.
                         drop=0.1,duplicate=0.05,reorder=0.02,corrupt=0.01,delay=1ms..5ms,seed=7
                         (one direction uses seed, the other seed+1; a serial trinamic line
                         takes drop and corrupt only; decision 1421)
)";

struct Flags {
  std::string family;
  std::string host = "127.0.0.1";
  uint16_t port = 49360;
  int count = 1;
  double status_every_s = 0;
  SimOptions sim;
};

[[noreturn]] void UsageError(const std::string& message) {
  std::cerr << "drivegw-sim: " << message << "\n(drivegw-sim --help for the flags)\n";
  std::exit(kUsageError);
}

// --impair (main takes it out of the arguments before the families parse theirs).
std::optional<drivegw::transport::Impairment> g_impair;

// nullptr without --impair (the server opens its own channel); otherwise the bus wrapped in
// ImpairedCanChannel: what the simulator sends uses the seed, what it receives seed + 1, and
// each further drive `index` shifts both by 2 so no two links share a decision sequence.
std::unique_ptr<drivegw::transport::CanChannel> ImpairedChannel(const drivegw::CanBusConfig& can,
                                                                int index = 0) {
  if (!g_impair) return nullptr;
  auto inner = drivegw::transport::OpenCanChannel(can);
  if (!inner.ok()) {
    std::cerr << "drivegw-sim: " << inner.status().message() << "\n";
    std::exit(1);
  }
  drivegw::transport::Impairment send = *g_impair;
  send.seed += 2 * static_cast<uint64_t>(index);
  drivegw::transport::Impairment receive = send;
  ++receive.seed;
  auto wrapped = drivegw::transport::ImpairedCanChannel::Wrap(*std::move(inner), send, receive);
  if (!wrapped.ok()) UsageError(absl::StrCat("--impair: ", wrapped.status().message()));
  std::cout << "impaired link: " << drivegw::transport::ImpairmentString(*g_impair) << "\n";
  return *std::move(wrapped);
}

double ParseDouble(const std::string& flag, const std::string& v) {
  double d = 0;
  if (!absl::SimpleAtod(v, &d) || !std::isfinite(d)) {
    UsageError(absl::StrCat(flag, ": '", v, "' is not a number"));
  }
  return d;
}

int64_t ParseInt(const std::string& flag, const std::string& v, int64_t lo, int64_t hi) {
  int64_t n = 0;
  if (!absl::SimpleAtoi(v, &n) || n < lo || n > hi) {
    UsageError(absl::StrCat(flag, ": '", v, "' is not an integer in [", lo, ", ", hi, "]"));
  }
  return n;
}

drivegw::Duration Millis(const std::string& flag, const std::string& v, double lo, double hi) {
  const double ms = ParseDouble(flag, v);
  if (ms < lo || ms > hi)
    UsageError(absl::StrCat(flag, ": ", ms, " is outside [", lo, ", ", hi, "]"));
  return std::chrono::duration_cast<drivegw::Duration>(
      std::chrono::duration<double, std::milli>(ms));
}

Flags ParseFlags(int argc, char** argv) {
  Flags f;
  std::vector<std::string> args(argv + 1, argv + argc);
  for (size_t i = 0; i < args.size(); ++i) {
    std::string arg = args[i];
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (arg.rfind("--", 0) != 0) {
      if (!f.family.empty()) UsageError(absl::StrCat("unexpected argument '", arg, "'"));
      f.family = arg;
      continue;
    }
    std::string value;
    if (const size_t eq = arg.find('='); eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    } else {
      if (i + 1 >= args.size()) UsageError(absl::StrCat(arg, ": missing value"));
      value = args[++i];
    }
    if (arg == "--host") {
      f.host = value;
    } else if (arg == "--port") {
      f.port = static_cast<uint16_t>(ParseInt(arg, value, 0, 65535));
    } else if (arg == "--master-port") {
      f.sim.master_port = static_cast<uint16_t>(ParseInt(arg, value, 0, 65535));
    } else if (arg == "--count") {
      f.count = static_cast<int>(ParseInt(arg, value, 1, 256));
    } else if (arg == "--name") {
      if (value.empty()) UsageError("--name: empty");
      f.sim.name = value;
    } else if (arg == "--stroke-min") {
      f.sim.stroke_min_mm = ParseDouble(arg, value);
    } else if (arg == "--stroke-max") {
      f.sim.stroke_max_mm = ParseDouble(arg, value);
    } else if (arg == "--initial-position") {
      f.sim.initial_position_mm = ParseDouble(arg, value);
    } else if (arg == "--home-position") {
      f.sim.home_position_mm = ParseDouble(arg, value);
    } else if (arg == "--max-velocity") {
      f.sim.max_velocity_mm_s = ParseDouble(arg, value);
    } else if (arg == "--tick-ms") {
      f.sim.tick = Millis(arg, value, 0.25, 10);
    } else if (arg == "--hw-test-ms") {
      f.sim.hw_test_time = Millis(arg, value, 0, 60'000);
    } else if (arg == "--boot-ms") {
      f.sim.boot_time = Millis(arg, value, 0, 600'000);
    } else if (arg == "--product") {
      bool found = false;
      for (size_t p = 0; p < drivegw::linmot::mc::kProductCount; ++p) {
        const auto product = static_cast<drivegw::linmot::mc::Product>(p);
        if (value == drivegw::linmot::mc::ProductName(product)) {
          f.sim.product = product;
          found = true;
        }
      }
      if (!found)
        UsageError(absl::StrCat("--product: '", value, "' is not C1100, C1250, E1200 or E1400"));
    } else if (arg == "--reply-payload") {
      f.sim.min_reply_payload = static_cast<size_t>(ParseInt(arg, value, 0, 1472));
    } else if (arg == "--status-every") {
      f.status_every_s = ParseDouble(arg, value);
      if (f.status_every_s < 0) UsageError("--status-every: must be >= 0");
    } else {
      UsageError(absl::StrCat("unknown flag '", arg, "'"));
    }
  }
  if (f.family.empty()) {
    UsageError("missing the drive family (supported: linmot, linmot-devicenet, trinamic, stober)");
  }
  if (f.family != "linmot") {
    UsageError(
        absl::StrCat("unknown family '", f.family, "' (supported: linmot, linmot-devicenet)"));
  }
  if (f.port != 0 && f.port + f.count - 1 > 65535) {
    UsageError(absl::StrCat("--count: ", f.count, " drives from port ", f.port, " exceed 65535"));
  }
  auto endpoint = drivegw::transport::Endpoint::Parse(f.host, f.port);
  if (!endpoint.ok()) UsageError(absl::StrCat("--host: ", endpoint.status().message()));
  f.sim.bind = *endpoint;
  return f;
}

// "sim_options.stroke_max_mm: ..." -> "--stroke-max: ..." so the message names the flag.
std::string FlagMessage(const std::string& message) {
  static const std::map<std::string, std::string> kFlags = {
      {"stroke_min_mm", "--stroke-min"},
      {"stroke_max_mm", "--stroke-max"},
      {"initial_position_mm", "--initial-position"},
      {"home_position_mm", "--home-position"},
      {"max_velocity_mm_s", "--max-velocity"},
      {"tick_ms", "--tick-ms"},
      {"min_reply_payload", "--reply-payload"},
  };
  const std::string prefix = "sim_options.";
  if (message.rfind(prefix, 0) != 0) return message;
  const size_t colon = message.find(':');
  const std::string field = message.substr(prefix.size(), colon - prefix.size());
  auto it = kFlags.find(field);
  return it == kFlags.end() ? message : it->second + message.substr(colon);
}

void PrintStatus(const std::vector<std::unique_ptr<LinMotServer>>& servers) {
  for (const auto& s : servers) {
    const auto snap = s->Snapshot();
    const auto& d = snap.device;
    std::cout << absl::StrFormat(
        "%s state=%u sv=0x%04X sw=0x%04X err=0x%04X pos=%.4f mm demand=%.4f mm homed=%d "
        "rx=%u tx=%u dropped_port=%u malformed=%u\n",
        s->options().name, d.main_state, d.state_var, d.status_word, d.error_code,
        d.actual_position_mm, d.demand_position_mm, d.homed ? 1 : 0, snap.server.datagrams_received,
        snap.server.replies_sent, snap.server.dropped_wrong_port, snap.server.malformed);
  }
  std::cout.flush();
}

// Blocks SIGINT/SIGTERM for every thread (taken synchronously by WaitForSignal).
sigset_t BlockSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// Waits for SIGINT/SIGTERM, calling `status` every status_every_s seconds (0: never).
template <typename F>
void WaitForSignal(const sigset_t& signals, double status_every_s, F status) {
  while (true) {
    int sig = 0;
    if (status_every_s > 0) {
      timespec timeout{};
      timeout.tv_sec = static_cast<time_t>(status_every_s);
      timeout.tv_nsec = static_cast<long>((status_every_s - timeout.tv_sec) * 1e9);
      sig = sigtimedwait(&signals, nullptr, &timeout);
      if (sig < 0) {
        if (errno == EAGAIN) status();
        continue;
      }
    } else if (sigwait(&signals, &sig) != 0) {
      continue;
    }
    return;
  }
}

// The family word: the first argument that is neither a flag nor a flag's value (every flag
// but -h/--help takes a value).
std::string FindFamily(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") continue;
    if (arg.rfind("--", 0) == 0) {
      if (arg.find('=') == std::string::npos) ++i;
      continue;
    }
    return arg;
  }
  return "";
}

// drivegw-sim linmot-devicenet: linmot-devicenet.md §12 on a CAN bus.
int RunLinMotDeviceNet(int argc, char** argv) {
  namespace dnsim = drivegw::sim::linmot_devicenet;
  std::vector<std::string> args;
  bool family_seen = false;
  for (int i = 1; i < argc; ++i) {
    if (!family_seen && std::string_view(argv[i]) == "linmot-devicenet") {
      family_seen = true;
      continue;
    }
    args.emplace_back(argv[i]);
  }
  auto flags = dnsim::ParseCliFlags(args);
  if (!flags.ok()) UsageError(std::string(flags.status().message()));
  if (flags->help) {
    std::cout << dnsim::kCliUsage;
    return 0;
  }
  const sigset_t signals = BlockSignals();
  std::vector<std::unique_ptr<dnsim::LinMotDnServer>> servers;
  for (int i = 0; i < flags->count; ++i) {
    const dnsim::DnSimOptions o = dnsim::DriveOptions(*flags, i);
    auto server =
        dnsim::LinMotDnServer::Start(o, SteadyClock::Instance(), ImpairedChannel(o.can, i));
    if (!server.ok()) {
      std::cerr << "drivegw-sim: " << server.status().message() << "\n";
      for (auto& s : servers) s->Stop();
      return 1;
    }
    std::cout << absl::StrFormat(
        "linmot-devicenet %s MAC %d on %s (%s; consumed %d, produced %d bytes)\n", o.name,
        (*server)->mac_id(), (*server)->bus_name(), o.dn_enable ? "enabled" : "DeviceNet disabled",
        drivegw::linmot::devicenet::ConsumedSize(dnsim::PollLayout(o)),
        drivegw::linmot::devicenet::ProducedSize(dnsim::PollLayout(o)));
    servers.push_back(std::move(*server));
  }
  std::cout.flush();
  WaitForSignal(signals, flags->status_every_s, [&] {
    for (const auto& s : servers) {
      const auto snap = s->Snapshot();
      const auto& d = snap.device;
      const auto& st = snap.stack;
      std::cout << absl::StrFormat(
          "%s mac=%d net=%s owner=%s poll=%s state=%s sl=0x%04X sh=0x%04X coded=0x%04X "
          "pos=%.3f mm polls=%u malformed=%u\n",
          s->options().name, st.mac_id, dnsim::NetworkStateName(st.network),
          st.owner ? std::to_string(*st.owner) : std::string("-"),
          dnsim::ConnectionStateName(st.poll_connection.state), dnsim::ControllerStateName(d.state),
          d.status_low, d.status_high, d.coded_error, d.motors[0].actual_mm,
          st.counters.polls_received, st.counters.malformed + snap.server.malformed);
    }
    std::cout.flush();
  });
  for (auto& s : servers) s->Stop();
  std::cout << "drivegw-sim: stopped\n";
  return 0;
}

constexpr const char* kTrinamicUsage =
    R"(usage: drivegw-sim trinamic --pty PATH | --can udp:GROUP:PORT|socketcan:IFACE [--pty PATH]
                            [flags]

A simulated Trinamic SIXpack/QUADpack (trinamic-sixpack.md). With --pty only: serial control on
a pseudo-terminal whose slave is symlinked at PATH. With --can: the PACK on a CAN bus (~2 ms per
queued command, at most 16 queued); adding --pty makes PATH its RS-232 port, which takes serial
commands until the first CAN instruction and is the transparent tunnel afterwards.

flags:
  --address N          unit address 1..255 (default 1)
  --axes 6|4           6 = SIXpack, 4 = QUADpack (default 6)
  --framing r8|r9      serial reply framing (default r8)
  --second-address N   serial only: a second PACK with address N on the same line
  --more-addresses N,M serial only: further PACKs with these addresses on the same line (RS-485
                       multi-drop; may be combined with --second-address)
  --supply-volts V     supply voltage 0..60 (default 24; below 13 V is undervoltage)
  --can-jumpers 0..3   CAN bit-rate jumpers JP1 (bit 0), JP2 (bit 1) as read by $30 (default 0)
  --no-turnaround      serial only: reply at once instead of after the $40 switchover time
  --check-baud         serial only: ignore bytes while the peer's pty speed differs from $40's
)";

// `drivegw-sim trinamic`: one SIXpack/QUADpack (or two on one serial line) on a pty, on a CAN bus,
// or on a CAN bus with its RS-232 port on a pty (issue 4; decisions 1037-1045).
int RunTrinamic(int argc, char** argv) {
  namespace tsim = drivegw::sim::trinamic;
  tsim::ServerOptions o;
  o.turnaround = true;  // a real PACK answers after its switchover time (L283, decision 1040)
  std::optional<drivegw::CanBusConfig> can;
  std::vector<uint8_t> more_addresses;  // --second-address, then --more-addresses
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "trinamic") continue;
    if (arg == "--help" || arg == "-h") {
      std::cout << kTrinamicUsage;
      return 0;
    }
    if (arg == "--no-turnaround") {
      o.turnaround = false;
      continue;
    }
    if (arg == "--check-baud") {
      o.check_peer_baud = true;
      continue;
    }
    if (i + 1 >= argc) UsageError(absl::StrCat(arg, ": missing value"));
    const std::string value = argv[++i];
    if (arg == "--pty") {
      o.pty_path = value;
    } else if (arg == "--can") {
      auto parsed = drivegw::transport::ParseCanSpec(value);
      if (!parsed.ok()) UsageError(std::string(parsed.status().message()));
      can = *std::move(parsed);
    } else if (arg == "--address") {
      o.controller.address = static_cast<uint8_t>(ParseInt(arg, value, 1, 255));
    } else if (arg == "--framing") {
      if (value == "r8") {
        o.controller.framing = drivegw::trinamic::ReplyFraming::kR8;
      } else if (value == "r9") {
        o.controller.framing = drivegw::trinamic::ReplyFraming::kR9;
      } else {
        UsageError(absl::StrCat("--framing: '", value, "' is not r8 or r9"));
      }
    } else if (arg == "--axes") {
      o.controller.axes = static_cast<int>(ParseInt(arg, value, 4, 6));
      if (o.controller.axes == 5) UsageError("--axes: 5 is not 6 (SIXpack) or 4 (QUADpack)");
    } else if (arg == "--second-address") {
      more_addresses.insert(more_addresses.begin(),
                            static_cast<uint8_t>(ParseInt(arg, value, 1, 255)));
    } else if (arg == "--more-addresses") {
      const std::vector<std::string> parts = absl::StrSplit(value, ',');
      for (const std::string& a : parts) {
        more_addresses.push_back(static_cast<uint8_t>(ParseInt(arg, a, 1, 255)));
      }
    } else if (arg == "--supply-volts") {
      o.controller.supply_volts = ParseDouble(arg, value);
      if (o.controller.supply_volts < 0 || o.controller.supply_volts > 60) {
        UsageError(absl::StrCat("--supply-volts: ", value, " is outside 0..60"));
      }
    } else if (arg == "--can-jumpers") {
      const int64_t j = ParseInt(arg, value, 0, 3);
      o.controller.jumper1 = (j & 1) != 0;
      o.controller.jumper2 = (j & 2) != 0;
    } else {
      UsageError(absl::StrCat("unknown flag '", arg, "'"));
    }
  }
  if (o.pty_path.empty() && !can) {
    UsageError("--pty: missing (the path where the pty's symlink goes, or --can SPEC)");
  }
  if (!more_addresses.empty() && can) {
    UsageError("--second-address/--more-addresses: only for a serial line (without --can)");
  }
  for (uint8_t address : more_addresses) {
    tsim::ControllerOptions unit = o.controller;
    unit.address = address;
    o.more_units.push_back(unit);
  }
  if (auto s = tsim::ValidateOptions(o); !s.ok()) UsageError(std::string(s.message()));
  const sigset_t signals = BlockSignals();
  if (can) {
    tsim::CanServerOptions co;
    co.controller = o.controller;
    co.can = *can;
    co.faults = o.faults;
    co.command_time = std::chrono::milliseconds(2);  // ~2 ms per command (L303, decision 1041)
    if (!o.pty_path.empty()) {
      co.serial_endpoint = true;  // the RS-232 port (L291, L307-317, decision 1042)
      co.serial_pty_path = o.pty_path;
      co.serial_framing = o.controller.framing;
    }
    auto server =
        tsim::TrinamicCanServer::Start(co, SteadyClock::Instance(), ImpairedChannel(co.can));
    if (!server.ok()) {
      std::cerr << "drivegw-sim: " << server.status().message() << "\n";
      return 1;
    }
    std::cout << absl::StrFormat("trinamic address %d (%d axes) on %s (command id 0x%03X)",
                                 o.controller.address, o.controller.axes, (*server)->bus_name(),
                                 (*server)->command_id());
    if (!o.pty_path.empty()) {
      std::cout << absl::StrFormat(", RS-232 %s -> %s", o.pty_path, (*server)->serial_path());
    }
    std::cout << "\n";
    std::cout.flush();
    WaitForSignal(signals, 0, [] {});
    (*server)->Stop();
    std::cout << "drivegw-sim: stopped\n";
    return 0;
  }
  auto server = tsim::TrinamicServer::Start(o, SteadyClock::Instance());
  if (!server.ok()) {
    std::cerr << "drivegw-sim: " << server.status().message() << "\n";
    return 1;
  }
  if (g_impair) {
    // Host words use the seed, replies seed + 1; a serial line takes drop and corrupt only.
    drivegw::transport::Impairment replies = *g_impair;
    ++replies.seed;
    if (auto s = (*server)->SetImpairment(*g_impair, replies); !s.ok()) {
      (*server)->Stop();
      UsageError(absl::StrCat("--impair: ", s.message()));
    }
    std::cout << "impaired link: " << drivegw::transport::ImpairmentString(*g_impair) << "\n";
  }
  std::cout << absl::StrFormat("trinamic address %d (%d axes) on %s -> %s", o.controller.address,
                               o.controller.axes, o.pty_path, (*server)->slave_path());
  if (more_addresses.size() == 1) {
    std::cout << absl::StrFormat(", second address %d", more_addresses[0]);  // as before
  } else if (!more_addresses.empty()) {
    std::cout << ", further addresses "
              << absl::StrJoin(more_addresses, ",", [](std::string* out, uint8_t a) {
                   absl::StrAppend(out, static_cast<int>(a));
                 });
  }
  std::cout << "\n";
  std::cout.flush();
  WaitForSignal(signals, 0, [] {});
  (*server)->Stop();
  std::cout << "drivegw-sim: stopped\n";
  return 0;
}

constexpr const char* kStoberUsage =
    R"(usage: drivegw-sim stober --can udp:GROUP:PORT|socketcan:IFACE --node N [flags]

A simulated STOBER axis (stober-motion.md, issue 5) as a CANopen CiA 402 slave: NMT, SDO server,
PDOs (power-on mapping = the gateway's default layout, adapters/stober/object_map.h), heartbeat
producer (1017h), EMCY; the STOBER parameters at 2000h + group x 200h + line, the CiA 402 objects
at 6040h... The drive powers up in "Not ready to switch on", PLCopen state I89 = 0.

flags:
  --can SPEC           the CAN bus: udp:GROUP:PORT (UDP multicast) or socketcan:IFACE
  --node N             CANopen node id 1..127
  --endless            endless (modulo) axis: I00 = 1
  --revolution U       revolution length I01 of the endless axis (default 360)
  --cycle-ms MS        motion-core cycle time A150, 0.125..32 (default 1)
  --heartbeat-ms MS    heartbeat producer time 1017h at power-on, 0..65535 (default 0: off)
  --extrapolation-ms MS  extrapolation time I423 of cyclic set values at power-on, 0..60000
                       (default 5; the gateway's demo uses 100 for a master that is not hard
                       real-time, decision 413)
  --enabled            start in CiA 402 "Operation enabled", I89 = 2 (the reference's fixtures)
)";

// `drivegw-sim stober`: one simulated STOBER axis on a CAN bus (issue 5; decisions 1171-1181).
int RunStober(int argc, char** argv) {
  namespace ssim = drivegw::sim::stober;
  ssim::AxisServerOptions o;
  std::optional<drivegw::CanBusConfig> can;
  std::optional<int64_t> node;
  std::optional<double> revolution;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "stober") continue;
    if (arg == "--help" || arg == "-h") {
      std::cout << kStoberUsage;
      return 0;
    }
    if (arg == "--endless") {
      o.axis.endless = true;
      continue;
    }
    if (arg == "--enabled") {
      o.axis.core.start_operation_enabled = true;
      continue;
    }
    if (i + 1 >= argc) UsageError(absl::StrCat(arg, ": missing value"));
    const std::string value = argv[++i];
    if (arg == "--can") {
      auto parsed = drivegw::transport::ParseCanSpec(value);
      if (!parsed.ok()) UsageError(absl::StrCat("--can: ", parsed.status().message()));
      can = *std::move(parsed);
    } else if (arg == "--node") {
      node = ParseInt(arg, value, 1, 127);
    } else if (arg == "--revolution") {
      revolution = ParseDouble(arg, value);
      if (!(*revolution > 0)) UsageError(absl::StrCat("--revolution: ", value, " must be > 0"));
    } else if (arg == "--cycle-ms") {
      const double ms = ParseDouble(arg, value);
      if (!(ms >= 0.125 && ms <= 32)) {
        UsageError(absl::StrCat("--cycle-ms: ", value, " is outside [0.125, 32]"));
      }
      o.axis.cycle_ms = ms;
    } else if (arg == "--heartbeat-ms") {
      o.heartbeat_ms = static_cast<uint16_t>(ParseInt(arg, value, 0, 65535));
    } else if (arg == "--extrapolation-ms") {
      // I423's catalogue range (sim/stober/parameters.cpp): 0..60000 ms.
      const double ms = ParseDouble(arg, value);
      if (!(ms >= 0 && ms <= 60000)) {
        UsageError(absl::StrCat("--extrapolation-ms: ", value, " is outside [0, 60000]"));
      }
      o.axis.extrapolation_ms = ms;
    } else {
      UsageError(absl::StrCat("unknown flag '", arg, "'"));
    }
  }
  if (!can) UsageError("--can: missing (udp:GROUP:PORT or socketcan:IFACE)");
  if (!node) UsageError("--node: missing (CANopen node id 1..127)");
  if (revolution && !o.axis.endless) UsageError("--revolution: only with --endless");
  o.can = *can;
  o.node_id = static_cast<uint8_t>(*node);
  if (revolution) o.axis.revolution = *revolution;
  if (auto s = ssim::AxisDevice::Validate(o.axis); !s.ok()) UsageError(std::string(s.message()));
  // The drive's reaction to a dead master (6007h, decision 1483) in the motion log on stdout.
  o.on_abort = [node = o.node_id](const ssim::Event& e) {
    std::cout << absl::StrFormat("stober node %d: cycle %d: %s\n", node, e.cycle, e.text);
    std::cout.flush();
  };
  const sigset_t signals = BlockSignals();
  auto server = ssim::AxisServer::Start(o, SteadyClock::Instance(), ImpairedChannel(o.can));
  if (!server.ok()) {
    std::cerr << "drivegw-sim: " << server.status().message() << "\n";
    return 1;
  }
  // The banner shows the axis's own A150/I423, so the power-on values can be checked from outside.
  double cycle_ms = 0;
  double extrapolation_ms = 0;
  (*server)->WithAxis([&](ssim::MotionCore& core) {
    cycle_ms = core.Read(drivegw::stober::P("A150")).value_or(0);
    extrapolation_ms = core.Read(drivegw::stober::P("I423")).value_or(0);
  });
  std::cout << absl::StrFormat("stober node %d on %s (%s axis, A150 %g ms, I423 %g ms)\n",
                               o.node_id, (*server)->bus_name(),
                               o.axis.endless ? "endless" : "limited", cycle_ms, extrapolation_ms);
  std::cout.flush();
  WaitForSignal(signals, 0, [] {});
  (*server)->Stop();
  std::cout << "drivegw-sim: stopped\n";
  return 0;
}
}  // namespace

int main(int argc_in, char** argv_in) {
  // --impair is common to every family: taken out here, applied by each Run* below.
  std::vector<char*> args;
  for (int i = 0; i < argc_in; ++i) {
    const std::string_view a = argv_in[i];
    std::string_view spec;
    if (a == "--impair") {
      if (i + 1 >= argc_in) UsageError("--impair: missing value");
      spec = argv_in[++i];
    } else if (a.rfind("--impair=", 0) == 0) {
      spec = a.substr(9);
    } else {
      args.push_back(argv_in[i]);
      continue;
    }
    auto parsed = drivegw::transport::ParseImpairment(spec);
    if (!parsed.ok()) UsageError(absl::StrCat("--", parsed.status().message()));
    g_impair = *parsed;
  }
  args.push_back(nullptr);
  const int argc = static_cast<int>(args.size()) - 1;
  char** argv = args.data();
  if (FindFamily(argc, argv) == "linmot-devicenet") return RunLinMotDeviceNet(argc, argv);
  if (FindFamily(argc, argv) == "trinamic") return RunTrinamic(argc, argv);
  if (FindFamily(argc, argv) == "stober") return RunStober(argc, argv);
  const Flags flags = ParseFlags(argc, argv);
  if (auto s = drivegw::sim::linmot::ValidateOptions(flags.sim); !s.ok()) {
    UsageError(FlagMessage(std::string(s.message())));
  }

  // Signals are taken synchronously by sigwait below; every thread inherits the blocked mask.
  const sigset_t signals = BlockSignals();

  std::vector<std::unique_ptr<LinMotServer>> servers;
  for (int i = 0; i < flags.count; ++i) {
    SimOptions o = flags.sim;
    if (flags.count > 1) o.name = absl::StrCat(flags.sim.name, "-", i + 1);
    if (flags.port != 0) o.bind.port = static_cast<uint16_t>(flags.port + i);
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    if (!server.ok()) {
      std::cerr << "drivegw-sim: " << server.status().message() << "\n";
      for (auto& s : servers) s->Stop();
      return 1;
    }
    if (g_impair) {
      // Replies use the seed, requests seed + 1; each further drive shifts both by 2.
      drivegw::transport::Impairment replies = *g_impair;
      replies.seed += 2 * static_cast<uint64_t>(i);
      drivegw::transport::Impairment requests = replies;
      ++requests.seed;
      if (auto s = (*server)->SetImpairment(replies); !s.ok()) UsageError(std::string(s.message()));
      if (auto s = (*server)->SetRequestImpairment(requests); !s.ok()) {
        UsageError(std::string(s.message()));
      }
      std::cout << "impaired link: " << drivegw::transport::ImpairmentString(*g_impair) << "\n";
    }
    std::cout << absl::StrFormat(
        "linmot %s listening on %s (master port %s)\n", o.name, (*server)->endpoint().ToString(),
        o.master_port == 0 ? std::string("any") : std::to_string(o.master_port));
    servers.push_back(std::move(*server));
  }
  std::cout.flush();

  WaitForSignal(signals, flags.status_every_s, [&] { PrintStatus(servers); });
  for (auto& s : servers) s->Stop();
  std::cout << "drivegw-sim: stopped\n";
  return 0;
}
