// drives[i].trinamic: transport (serial line or CAN bus), controller address, motor, units,
// polling and the parameter set, each checked against the limit the manual gives.
#include "server/config/trinamic_config.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/parameters.h"
#include "server/config/can_config.h"

namespace drivegw::config::internal {
namespace {

// trinamic-sixpack.md §2.2 / decision 1013: unit addresses 1..255, no broadcast (G-05).
constexpr int64_t kMinAddress = 1;
constexpr int64_t kMaxAddress = 255;
// §4.2 $40 P2/P3: switchover delay 1..1000 x 2 ms (L833).
constexpr int64_t kMinTurnaroundMs = 2;
constexpr int64_t kMaxTurnaroundMs = 2000;
// Same bounds as the LinUDP timing keys (docs/config.md).
constexpr int64_t kMaxPollMs = 1000;
constexpr int64_t kMaxReplyTimeoutMs = 10000;
constexpr int64_t kMaxMisses = 1000;
// §5.2: positions are int32 microsteps (L60, L660).
constexpr double kMaxMicrosteps = std::numeric_limits<int32_t>::max();

std::string Lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// "serial.baud: 12345 is not a supported rate (...)" -> the reason; the caller names our path.
std::string AfterField(const absl::Status& status) {
  const std::string message(status.message());
  const size_t colon = message.find(": ");
  return colon == std::string::npos ? message : message.substr(colon + 2);
}

// serial: {device, baud, rs485, turnaround_ms} (§2.1, §2.5).
void ParseSerial(const Section& t, SerialLineConfig& out) {
  const YAML::Node node = *t.Get("serial");
  const Section s(node, t.Child("serial"), {"device", "baud", "rs485", "turnaround_ms"},
                  t.errors());
  if (!node.IsNull() && !node.IsMap()) return;
  if (s.String("device", out.device, /*required=*/true) && out.device.empty()) {
    s.errors().Add(s.Child("device"), "must not be empty", *s.Get("device"));
  }
  int64_t v = 0;
  if (s.Int("baud", 1, std::numeric_limits<int>::max(), v)) {
    if (absl::Status st = transport::ValidateBaud(static_cast<int>(v)); !st.ok()) {
      // "serial.baud: 12345 is not a supported rate (...)": keep the reason, name our path.
      s.errors().Add(s.Child("baud"), AfterField(st), *s.Get("baud"));
    } else {
      out.baud = static_cast<int>(v);
    }
  }
  s.Bool("rs485", out.rs485);
  if (s.Int("turnaround_ms", kMinTurnaroundMs, kMaxTurnaroundMs, v)) {
    out.turnaround = std::chrono::milliseconds(v);
  }
}

// Decimal, or 0x hex for bit fields such as `$15` motor type.
bool ParseInteger(const std::string& text, int64_t& out) {
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    return absl::SimpleHexAtoi(text, &out);
  }
  return absl::SimpleAtoi(text, &out);
}

// parameters: {"$14.vmax": 300, ...}: names of the catalogue (trinamic::FindParameter), values
// within the field's range. Cross-field rules (amax <= vstart x 64, ...) depend on the other
// values the controller holds and are the drive's (ParameterShadow::Validate at activation).
void ParseParameters(const Section& t, TrinamicConfig& out) {
  const YAML::Node node = *t.Get("parameters");
  const std::string path = t.Child("parameters");
  Errors& errors = t.errors();
  if (node.IsNull()) return;
  if (!node.IsMap()) {
    errors.Add(path,
               absl::StrCat("expected a mapping of parameter name to value ({\"$14.vmax\": 300}), "
                            "got ",
                            KindName(node)),
               node);
    return;
  }
  std::map<std::string, std::string> seen;  // canonical name -> as written
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) {
      errors.Add(path, "keys must be parameter names such as \"$14.vmax\"", kv.first);
      continue;
    }
    const std::string written = kv.first.Scalar();
    const std::string key_path = absl::StrCat(path, ".", written);
    auto def = trinamic::FindParameter(std::string_view(written));
    if (!def.ok()) {
      std::string what = "unknown parameter (names are \"$<opcode>.<field>\", e.g. \"$14.vmax\")";
      size_t best = 3;  // suggest only names at most 2 edits away, the closest one
      for (const trinamic::ParameterDefinition& known : trinamic::ParameterCatalogue()) {
        if (const size_t d = Distance(Lower(written), Lower(known.name)); d < best) {
          best = d;
          what = absl::StrCat("unknown parameter (did you mean '", known.name, "'?)");
        }
      }
      errors.Add(key_path, what, kv.first);
      continue;
    }
    const trinamic::ParameterDefinition& d = **def;
    if (auto [it, fresh] = seen.emplace(d.name, written); !fresh) {
      errors.Add(key_path, absl::StrCat("is the same parameter as ", path, ".", it->second),
                 kv.first);
      continue;
    }
    int64_t value = 0;
    if (!kv.second.IsScalar() || !ParseInteger(kv.second.Scalar(), value)) {
      errors.Add(key_path, absl::StrCat(Section::Shown(kv.second), " is not an integer"),
                 kv.second);
      continue;
    }
    if (value < d.min) {
      errors.Add(key_path, absl::StrCat(value, " is below ", d.min), kv.second);
      continue;
    }
    if (value > d.max) {
      errors.Add(key_path, absl::StrCat(value, " exceeds ", d.max), kv.second);
      continue;
    }
    out.parameters.emplace_back(d.name, value);
  }
}

std::string ControllerName(const TrinamicConfig& c) {
  return absl::StrCat("address ", c.address, " on ", TrinamicTransportKey(c));
}

}  // namespace

std::string TrinamicTransportKey(const TrinamicConfig& config) {
  if (config.serial) return absl::StrCat("serial:", config.serial->device);
  if (config.can) return BusKey(*config.can);
  return "none";
}

bool ParseTrinamic(const Section& drive, const AxisConfig& axis, TrinamicConfig& out) {
  const YAML::Node node = *drive.Get("trinamic");
  Errors& errors = drive.errors();
  const std::string path = drive.Child("trinamic");
  const Section s(
      node, path,
      {"serial", "can", "address", "axis", "axes", "microsteps_per_unit", "response_address",
       "poll_ms", "reply_timeout_ms", "offline_after_misses", "parameters"},
      errors);
  if (!node.IsMap()) {
    if (node.IsNull()) errors.Add(path, "needs exactly one of serial, can", node);
    return false;
  }
  const bool serial = s.Has("serial");
  const bool can = s.Has("can");
  // G-28: a PACK is controlled over one interface (CAN takes over until reset, L291).
  if (serial == can) {
    errors.Add(path,
               serial ? "has both serial and can; a controller is driven over one of them (G-28)"
                      : "needs exactly one of serial, can",
               node);
  }
  if (serial) {
    out.serial.emplace();
    ParseSerial(s, *out.serial);
  } else if (can) {
    out.can.emplace();
    ParseCan(s, *out.can);
  }

  int64_t v = 0;
  if (s.Int("address", kMinAddress, kMaxAddress, v)) out.address = static_cast<uint8_t>(v);
  if (s.Has("axes") && s.Int("axes", 4, 6, v)) {
    if (v != 4 && v != 6) {
      errors.Add(s.Child("axes"), absl::StrCat(v, " is not 6 (SIXpack) or 4 (QUADpack)"),
                 *s.Get("axes"));
    } else {
      out.axes = static_cast<int>(v);
    }
  }
  // G-17: motors 0..5 on a SIXpack, 0..3 on a QUADpack.
  if (s.Int("axis", 0, std::numeric_limits<int64_t>::max(), v)) {
    if (v >= out.axes) {
      errors.Add(
          s.Child("axis"),
          absl::StrCat(v, " exceeds ", out.axes - 1, " (a ", out.axes == 6 ? "SIXpack" : "QUADpack",
                       " has motors 0..", out.axes - 1, ")"),
          *s.Get("axis"));
    } else {
      out.axis = static_cast<uint8_t>(v);
    }
  }
  if (s.Double("microsteps_per_unit", out.microsteps_per_unit, /*required=*/true)) {
    const double mpu = out.microsteps_per_unit;
    if (!(mpu > 0)) {
      errors.Add(s.Child("microsteps_per_unit"), absl::StrCat(mpu, " must be greater than 0"),
                 *s.Get("microsteps_per_unit"));
    } else {
      // §5.2 (L60, L693): every reachable position must be an int32 microstep count.
      const auto [end_key, end_mm] = std::abs(axis.max_mm) >= std::abs(axis.min_mm)
                                         ? std::pair<const char*, double>{"max_mm", axis.max_mm}
                                         : std::pair<const char*, double>{"min_mm", axis.min_mm};
      if (std::abs(end_mm) * mpu > kMaxMicrosteps) {
        errors.Add(s.Child("microsteps_per_unit"),
                   absl::StrCat(mpu, " puts axis.", end_key, " ", end_mm, " at ", end_mm * mpu,
                                " microsteps, beyond the int32 position range (2147483647)"),
                   *s.Get("microsteps_per_unit"));
      }
    }
  }
  // Decision 1013: RA 0 is refused on CAN (reply ID 0); a 00 byte on the serial line is taken
  // for reset noise (decision 1052), so 1..255 on both.
  if (s.Int("response_address", kMinAddress, kMaxAddress, v)) {
    out.response_address = static_cast<uint8_t>(v);
    if (absl::Status st = trinamic::ValidateResponseAddress(out.response_address); !st.ok()) {
      // A reply opcode as RA would make R8 and R9 replies indistinguishable (decision 1011).
      s.errors().Add(s.Child("response_address"), AfterField(st), *s.Get("response_address"));
    } else if (out.response_address == out.address) {
      errors.Add(s.Child("response_address"),
                 absl::StrCat(v, " equals address; replies must go to another address (CT-50)"),
                 *s.Get("response_address"));
    }
  }
  s.Millis("poll_ms", kMaxPollMs, out.poll_period);
  s.Millis("reply_timeout_ms", kMaxReplyTimeoutMs, out.reply_timeout);
  if (s.Int("offline_after_misses", 1, kMaxMisses, v)) {
    out.offline_after_misses = static_cast<int>(v);
  }
  if (s.Has("parameters")) ParseParameters(s, out);
  return true;
}

const TrinamicControllers::Entry* TrinamicControllers::Controller(const std::string& transport,
                                                                  uint8_t address) const {
  for (const Entry& e : entries_) {
    if (TrinamicTransportKey(e.config) == transport && e.config.address == address) return &e;
  }
  return nullptr;
}

void TrinamicControllers::Add(size_t index, const std::string& path, const TrinamicConfig& config,
                              const YAML::Node& at) {
  if (!config.serial && !config.can) return;  // already an error
  const std::string transport = TrinamicTransportKey(config);
  const std::string where = ControllerName(config);
  auto node_of = [&](std::string_view key) {
    const YAML::Node n = at.IsMap() ? at[std::string(key)] : YAML::Node();
    return n.IsDefined() ? n : at;
  };

  // One motor, one drive: two drives would fight over the same motor.
  if (auto [it, fresh] =
          axes_.emplace(std::make_tuple(transport, config.address, config.axis), entries_.size());
      !fresh) {
    errors_.Add(absl::StrCat(path, ".axis"),
                absl::StrCat(config.axis, " is also the axis of drives[",
                             entries_[it->second].index, "] (", where, ")"),
                node_of("axis"));
  }
  // One session per controller (decision 1052): its settings exist once.
  if (const Entry* first = Controller(transport, config.address)) {
    const TrinamicConfig& f = first->config;
    auto differs = [&](std::string_view key, const std::string& mine, const std::string& theirs) {
      errors_.Add(absl::StrCat(path, ".", Av(key)),
                  absl::StrCat(mine, " differs from drives[", first->index, "] (", theirs,
                               ") on the same controller (", where, ")"),
                  node_of(key));
    };
    if (config.axes != f.axes) {
      differs("axes", absl::StrCat(config.axes), absl::StrCat(f.axes));
    }
    if (config.response_address != f.response_address) {
      differs("response_address", absl::StrCat(config.response_address),
              absl::StrCat(f.response_address));
    }
    if (config.offline_after_misses != f.offline_after_misses) {
      differs("offline_after_misses", absl::StrCat(config.offline_after_misses),
              absl::StrCat(f.offline_after_misses));
    }
    // Controller-wide parameters ($12 clkdiv, $40, $41, ...) hold one value per PACK.
    for (const auto& [name, value] : config.parameters) {
      auto def = trinamic::FindParameter(std::string_view(name));
      if (!def.ok() || (*def)->scope != trinamic::ParameterScope::kController) continue;
      for (const auto& [other_name, other_value] : f.parameters) {
        if (other_name == name && other_value != value) {
          errors_.Add(absl::StrCat(path, ".parameters.", name),
                      absl::StrCat(value, " differs from drives[", first->index, "] (", other_value,
                                   "): a controller-wide parameter (", where, ")"),
                      node_of("parameters"));
        }
      }
    }
  }
  // One serial port, one line setting.
  if (config.serial) {
    if (auto [it, fresh] = lines_.emplace(config.serial->device, entries_.size()); !fresh) {
      const Entry& first = entries_[it->second];
      const SerialLineConfig& f = *first.config.serial;
      const SerialLineConfig& m = *config.serial;
      const YAML::Node serial_node = node_of("serial");
      auto differs = [&](std::string_view key, const std::string& mine, const std::string& theirs) {
        const YAML::Node n = serial_node.IsMap() ? serial_node[std::string(key)] : YAML::Node();
        errors_.Add(absl::StrCat(path, ".serial.", Av(key)),
                    absl::StrCat(mine, " differs from drives[", first.index, "] (", theirs,
                                 ") on the same line ", m.device),
                    n.IsDefined() ? n : serial_node);
      };
      if (m.baud != f.baud) differs("baud", absl::StrCat(m.baud), absl::StrCat(f.baud));
      if (m.rs485 != f.rs485) {
        differs("rs485", m.rs485 ? "true" : "false", f.rs485 ? "true" : "false");
      }
      if (m.turnaround != f.turnaround) {
        differs("turnaround_ms",
                absl::StrCat(
                    std::chrono::duration_cast<std::chrono::milliseconds>(m.turnaround).count()),
                absl::StrCat(
                    std::chrono::duration_cast<std::chrono::milliseconds>(f.turnaround).count()));
      }
    }
  }
  entries_.push_back(Entry{index, path, config, at});
}

void TrinamicControllers::Finish() {
  // CT-50 (L289, L291): replies to a PACK's own address would be taken for commands to it.
  for (const Entry& e : entries_) {
    const std::string transport = TrinamicTransportKey(e.config);
    for (const Entry& other : entries_) {
      if (&other == &e || TrinamicTransportKey(other.config) != transport ||
          other.config.address != e.config.response_address) {
        continue;
      }
      const YAML::Node ra = e.node.IsMap() ? e.node["response_address"] : YAML::Node();
      errors_.Add(absl::StrCat(e.path, ".response_address"),
                  absl::StrCat(e.config.response_address, " is the address of drives[", other.index,
                               "]'s controller on ", transport,
                               "; replies must go to an address no controller uses (CT-50)"),
                  ra.IsDefined() ? ra : e.node);
      break;
    }
  }
}

}  // namespace drivegw::config::internal
