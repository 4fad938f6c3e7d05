// `drivegw-sim linmot-devicenet` flag parsing (linmot-devicenet.md §12.1; issue 3 command line).
#include "sim/linmot_devicenet/cli.h"

#include <cmath>
#include <map>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

absl::Status FlagError(const std::string& flag, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat(flag, ": ", what));
}

absl::StatusOr<double> Double(const std::string& flag, const std::string& v) {
  double d = 0;
  if (!absl::SimpleAtod(v, &d) || !std::isfinite(d)) {
    return FlagError(flag, absl::StrCat("'", v, "' is not a number"));
  }
  return d;
}

absl::StatusOr<int64_t> Int(const std::string& flag, const std::string& v, int64_t lo, int64_t hi) {
  int64_t n = 0;
  if (!absl::SimpleAtoi(v, &n) || n < lo || n > hi) {
    return FlagError(flag, absl::StrCat("'", v, "' is not an integer in [", lo, ", ", hi, "]"));
  }
  return n;
}

Duration Millis(double ms) {
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double, std::milli>(ms));
}

// "ci,ai,di" / "so,ao,do1,do2" module lists (§7 module names, short forms).
absl::StatusOr<dn::ModuleSet> Modules(const std::string& flag, const std::string& v) {
  dn::ModuleSet m;
  if (v == "none") return m;
  const std::vector<std::string> words = absl::StrSplit(v, ',');
  for (const std::string& w : words) {
    if (w == "ci" || w == "control-in") {
      m.control_in = true;
    } else if (w == "ai" || w == "addressed-in") {
      m.addressed_in = true;
    } else if (w == "di" || w == "direct-in") {
      m.direct_in = true;
    } else if (w == "so" || w == "status-out") {
      m.status_out = true;
    } else if (w == "ao" || w == "addressed-out") {
      m.addressed_out = true;
    } else if (w == "do1" || w == "direct-out-1") {
      m.direct_out_1 = true;
    } else if (w == "do2" || w == "direct-out-2") {
      m.direct_out_2 = true;
    } else {
      return FlagError(flag, absl::StrCat("'", w, "' is not one of ci, ai, di, so, ao, do1, do2"));
    }
  }
  return m;
}

// "dn_sim_options.motors[0].stroke_max_mm: ..." -> "--stroke-max: ..." (the flag that sets it).
std::string FlagMessage(const std::string& message) {
  static const std::map<std::string, std::string> kFlags = {
      {"mac_id", "--mac"},
      {"mac_switches", "--mac-switches"},
      {"name", "--name"},
      {"io_setup", "--io"},
      {"cos_modules", "--cos-modules"},
      {"motor_count", "--motors"},
      {"stroke_max_mm", "--stroke-max"},
      {"initial_position_mm", "--initial-position"},
      {"init_position_mm", "--init-position"},
      {"max_velocity_mm_s", "--max-velocity"},
      {"motors", "--masters"},
      {"tick_ms", "--tick-ms"},
      {"epr_resolution_ms", "--epr-resolution-ms"},
      {"response_latency_cycles", "--latency-cycles"},
  };
  const std::string prefix = "dn_sim_options.";
  if (message.rfind(prefix, 0) != 0) return message;
  const size_t colon = message.find(':');
  std::string field = message.substr(prefix.size(), colon - prefix.size());
  if (const size_t dot = field.rfind('.'); dot != std::string::npos) field = field.substr(dot + 1);
  auto it = kFlags.find(field);
  return it == kFlags.end() ? message : it->second + message.substr(colon);
}

}  // namespace

const char kCliUsage[] = R"(usage: drivegw-sim linmot-devicenet [flags]

Simulated LinMot DeviceNet drive(s) (firmware 1.3) on a CAN bus: duplicate MAC ID check,
Allocate/Release, explicit messages, polled and CoS/cyclic I/O with fragmentation, the 102
general-purpose commands (linmot-devicenet.md §12).

flags:
  --can SPEC              udp:GROUP:PORT (python-can udp_multicast bus) or socketcan:IFACE
                          (default udp:239.74.163.2:43113)
  --trace FILE            append every frame in and out to FILE (candump -l format)
  --mac N                 MAC ID 0..63 (default 5)
  --mac-switches HH       take the MAC ID from the two hex rotary switches instead (e.g. 2A)
  --count N               N drives on MAC IDs N consecutive: mac, mac+1, ... (default 1)
  --name NAME             drive name; with --count, NAME-1, NAME-2, ... (default linmot-dn)
  --baud K                125, 250 or 500 kbit/s (informational on the UDP bus; default 125)
  --dn-enable on|off      DeviceNet Dis-/Enable; off: the drive never transmits (default on)
  --io poll|cos|poll+cos  I/O connections set up (default poll)
  --poll-modules LIST     ci,ai,di,so,ao,do1,do2 (default ci,ai,so,ao: 6/8 bytes)
  --cos-modules LIST      modules of the CoS/cyclic connection (default so)
  --motors N              motors A.. 1..4 (default 1)
  --masters LETTERS       master drives, e.g. AC (default: every motor)
  --byte-order le|be      byte order of the I/O words, D-1 (default le)
  --initialised on|off    motors initialised at power-up (INIT Done = 1; default off)
  --stroke-min MM         stroke of every motor (default -10)
  --stroke-max MM         (default 200)
  --initial-position MM   slider position at power-up (default 0)
  --init-position MM      where the INIT move ends (default 0)
  --max-velocity MM_S     motor speed capability (default 2000)
  --master-encoder on|off master encoder module (default off)
  --digital-io on|off     digital IO module (default off)
  --tick-ms MS            physics tick, 0.25 ... 10 (default 1)
  --epr-resolution-ms MS  granted EPR rounding, D-13 (default 10)
  --latency-cycles N      Addressed Out answers N polls late, D-5 (default 0)
  --response-delay-ms MS  poll responses leave MS after the poll, D-33 (default 0)
  --bus-off-recover-s S   leave bus-off automatically after S seconds, D-16 (default: hold)
  --status-every S        print each drive's state every S seconds (default 0 = never)
  -h, --help              this text
)";

absl::StatusOr<CliFlags> ParseCliFlags(const std::vector<std::string>& args) {
  CliFlags f;
  std::string masters;
  bool masters_set = false;
  double stroke_min = -10, stroke_max = 200, initial = 0, init_pos = 0, max_velocity = 2000;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string arg = args[i];
    if (arg == "-h" || arg == "--help") {
      f.help = true;
      return f;
    }
    if (arg.rfind("--", 0) != 0)
      return absl::InvalidArgumentError("unexpected argument '" + arg + "'");
    std::string value;
    if (const size_t eq = arg.find('='); eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    } else {
      if (i + 1 >= args.size()) return FlagError(arg, "missing value");
      value = args[++i];
    }
    auto on_off = [&](bool* out) -> absl::Status {
      if (value == "on" || value == "yes" || value == "1") {
        *out = true;
      } else if (value == "off" || value == "no" || value == "0") {
        *out = false;
      } else {
        return FlagError(arg, absl::StrCat("'", value, "' is not on or off"));
      }
      return absl::OkStatus();
    };
    absl::Status s;
    if (arg == "--can") {
      auto can = transport::ParseCanSpec(value);
      if (!can.ok()) return absl::InvalidArgumentError(std::string(can.status().message()));
      const std::string trace = f.sim.can.trace_file;
      f.sim.can = *can;
      f.sim.can.trace_file = trace;
    } else if (arg == "--trace") {
      if (value.empty()) return FlagError(arg, "empty");
      f.sim.can.trace_file = value;
    } else if (arg == "--mac") {
      auto n = Int(arg, value, 0, dn::kMaxMacId);
      if (!n.ok()) return n.status();
      f.sim.mac_id = static_cast<uint8_t>(*n);
      f.sim.mac_source = MacIdSource::kParameter;
    } else if (arg == "--mac-switches") {
      int n = 0;
      if (value.size() != 2 || !absl::SimpleHexAtoi(value, &n)) {
        return FlagError(arg, absl::StrCat("'", value, "' is not two hex digits (e.g. 2A)"));
      }
      if (n > dn::kMaxMacId) {
        return FlagError(arg,
                         absl::StrCat("0x", value, " exceeds 0x3F (D-26: drive stays offline)"));
      }
      f.sim.mac_switches = static_cast<uint8_t>(n);
      f.sim.mac_source = MacIdSource::kSwitches;
    } else if (arg == "--count") {
      auto n = Int(arg, value, 1, 64);
      if (!n.ok()) return n.status();
      f.count = static_cast<int>(*n);
    } else if (arg == "--name") {
      if (value.empty()) return FlagError(arg, "empty");
      f.sim.name = value;
    } else if (arg == "--baud") {
      if (value == "125") {
        f.sim.baud = BaudRate::k125;
      } else if (value == "250") {
        f.sim.baud = BaudRate::k250;
      } else if (value == "500") {
        f.sim.baud = BaudRate::k500;
      } else {
        return FlagError(arg, absl::StrCat("'", value, "' is not 125, 250 or 500"));
      }
    } else if (arg == "--dn-enable") {
      s = on_off(&f.sim.dn_enable);
    } else if (arg == "--io") {
      if (value == "poll") {
        f.sim.io_polled = true, f.sim.io_cos = false;
      } else if (value == "cos") {
        f.sim.io_polled = false, f.sim.io_cos = true;
      } else if (value == "poll+cos") {
        f.sim.io_polled = true, f.sim.io_cos = true;
      } else {
        return FlagError(arg, absl::StrCat("'", value, "' is not poll, cos or poll+cos"));
      }
    } else if (arg == "--poll-modules") {
      auto m = Modules(arg, value);
      if (!m.ok()) return m.status();
      f.sim.poll_modules = *m;
    } else if (arg == "--cos-modules") {
      auto m = Modules(arg, value);
      if (!m.ok()) return m.status();
      f.sim.cos_modules = *m;
    } else if (arg == "--motors") {
      auto n = Int(arg, value, 1, 4);
      if (!n.ok()) return n.status();
      f.sim.motor_count = static_cast<size_t>(*n);
    } else if (arg == "--masters") {
      masters = value;
      masters_set = true;
    } else if (arg == "--byte-order") {
      if (value == "le") {
        f.sim.byte_order = dn::ByteOrder::kLittleEndian;
      } else if (value == "be") {
        f.sim.byte_order = dn::ByteOrder::kBigEndian;
      } else {
        return FlagError(arg, absl::StrCat("'", value, "' is not le or be"));
      }
    } else if (arg == "--initialised") {
      s = on_off(&f.sim.initialised);
    } else if (arg == "--master-encoder") {
      s = on_off(&f.sim.master_encoder_module);
    } else if (arg == "--digital-io") {
      s = on_off(&f.sim.digital_io_module);
    } else if (arg == "--stroke-min" || arg == "--stroke-max" || arg == "--initial-position" ||
               arg == "--init-position" || arg == "--max-velocity") {
      auto d = Double(arg, value);
      if (!d.ok()) return d.status();
      double* target = arg == "--stroke-min"         ? &stroke_min
                       : arg == "--stroke-max"       ? &stroke_max
                       : arg == "--initial-position" ? &initial
                       : arg == "--init-position"    ? &init_pos
                                                     : &max_velocity;
      *target = *d;
    } else if (arg == "--tick-ms") {
      auto d = Double(arg, value);
      if (!d.ok()) return d.status();
      if (*d < 0.25 || *d > 10) return FlagError(arg, absl::StrCat(*d, " is outside [0.25, 10]"));
      f.sim.tick = Millis(*d);
    } else if (arg == "--epr-resolution-ms") {
      auto n = Int(arg, value, 1, 1000);
      if (!n.ok()) return n.status();
      f.sim.epr_resolution_ms = static_cast<uint16_t>(*n);
    } else if (arg == "--latency-cycles") {
      auto n = Int(arg, value, 0, 16);
      if (!n.ok()) return n.status();
      f.sim.response_latency_cycles = static_cast<int>(*n);
    } else if (arg == "--response-delay-ms") {
      auto d = Double(arg, value);
      if (!d.ok()) return d.status();
      if (*d < 0 || *d > 10'000) return FlagError(arg, absl::StrCat(*d, " is outside [0, 10000]"));
      f.sim.response_delay = Millis(*d);
    } else if (arg == "--bus-off-recover-s") {
      auto d = Double(arg, value);
      if (!d.ok()) return d.status();
      if (*d < 0 || *d > 3600) return FlagError(arg, absl::StrCat(*d, " is outside [0, 3600]"));
      f.sim.bus_off_recovery = BusOffRecovery::kAutoRecover;
      f.sim.bus_off_recover_after = FromSeconds(*d);
    } else if (arg == "--status-every") {
      auto d = Double(arg, value);
      if (!d.ok()) return d.status();
      if (*d < 0) return FlagError(arg, "must be >= 0");
      f.status_every_s = *d;
    } else {
      return absl::InvalidArgumentError("unknown flag '" + arg + "'");
    }
    if (!s.ok()) return s;
  }
  for (size_t m = 0; m < 4; ++m) {
    MotorOptions& mo = f.sim.motors[m];
    mo.stroke_min_mm = stroke_min;
    mo.stroke_max_mm = stroke_max;
    mo.initial_position_mm = initial;
    mo.init_position_mm = init_pos;
    mo.max_velocity_mm_s = max_velocity;
    if (masters_set) {
      mo.master = masters.find(static_cast<char>('A' + m)) != std::string::npos ||
                  masters.find(static_cast<char>('a' + m)) != std::string::npos;
    }
  }
  if (masters_set) {
    for (char c : masters) {
      const int m = (c >= 'a' ? c - 'a' : c - 'A');
      if (m < 0 || m >= static_cast<int>(f.sim.motor_count)) {
        return FlagError(
            "--masters",
            absl::StrCat("'", std::string(1, c), "' is not a motor of A..",
                         std::string(1, static_cast<char>('A' + f.sim.motor_count - 1))));
      }
    }
  }
  const int mac = ResolvedMacId(f.sim);
  if (mac + f.count - 1 > dn::kMaxMacId) {
    return FlagError("--count",
                     absl::StrCat(f.count, " drives from MAC ", mac, " exceed ", dn::kMaxMacId));
  }
  if (absl::Status s = ValidateOptions(f.sim); !s.ok()) {
    return absl::InvalidArgumentError(FlagMessage(std::string(s.message())));
  }
  return f;
}

DnSimOptions DriveOptions(const CliFlags& flags, int i) {
  DnSimOptions o = flags.sim;
  if (flags.count > 1) o.name = absl::StrCat(flags.sim.name, "-", i + 1);
  const uint8_t mac = static_cast<uint8_t>(ResolvedMacId(flags.sim) + i);
  if (o.mac_source == MacIdSource::kSwitches) {
    o.mac_switches = mac;
  } else {
    o.mac_id = mac;
  }
  return o;
}

}  // namespace drivegw::sim::linmot_devicenet
