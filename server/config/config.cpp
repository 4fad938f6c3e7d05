// Parses and validates the gateway YAML; yaml-cpp exceptions stop here and become Status.
#include "server/config/config.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <optional>
#include <sstream>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "adapters/stober/factory.h"
#include "adapters/transport/thread_scheduling.h"
#include "adapters/trinamic/factory.h"
#include "server/config/audit_config.h"
#include "server/config/auth_config.h"
#include "server/config/can_buses.h"
#include "server/config/can_config.h"
#include "server/config/section.h"
#include "server/config/stober_config.h"
#include "server/config/tls_config.h"
#include "server/config/trinamic_config.h"

namespace drivegw::config {
namespace {

using internal::Av;
using internal::BusKey;
using internal::Errors;
using internal::KindName;
using internal::ParseCan;
using internal::Section;

// Bounds for every integer key; docs/config.md shows the same table.
constexpr int64_t kMaxPort = 65535;
constexpr int64_t kMaxCycleMs = 1000;
constexpr int64_t kMaxReplyTimeoutMs = 10000;
constexpr int64_t kMaxLostAfterTimeouts = 1000;
constexpr int64_t kMaxRequestMs = 600000;  // 10 min
constexpr int64_t kMaxAcceptMs = 60000;    // 1 min
constexpr int64_t kMaxHomingMs = 3600000;  // 1 h
constexpr size_t kMaxNameLength = 32;
constexpr int64_t kMaxMacId = 63;  // DeviceNet MAC IDs are 0..63

bool IsNameChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}

bool IsValidName(std::string_view name) {
  return !name.empty() && name.size() <= kMaxNameLength &&
         std::all_of(name.begin(), name.end(), IsNameChar);
}

// Host names and IPv4 literals; IPv6 literals go in brackets in host:port only.
bool IsValidHost(std::string_view host) {
  if (host.empty() || host.size() > 253) return false;
  return std::all_of(host.begin(), host.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '-' || c == '_';
  });
}

bool IsValidIpv6Literal(std::string_view host) {
  if (host.size() < 2) return false;
  return std::all_of(host.begin(), host.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F') || c == ':' ||
           c == '.';
  });
}

// "host:port", "[v6]:port" or ":port"; port 0..65535 (0 = ephemeral, used by tests).
bool IsHostPort(std::string_view text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) return false;
  std::string_view host = text.substr(0, colon);
  const std::string_view port = text.substr(colon + 1);
  if (port.empty() || port.size() > 5 ||
      !std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  int value = 0;
  for (char c : port) value = value * 10 + (c - '0');
  if (value > kMaxPort) return false;
  if (host.empty()) return true;  // ":8080": every interface, as the server reads it
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    return IsValidIpv6Literal(host.substr(1, host.size() - 2));
  }
  return IsValidHost(host);
}

void ParseListen(const Section& root, ListenConfig& listen) {
  auto node = root.Get("listen");
  if (!node) return;
  const Section s(*node, "listen", {"grpc", "http"}, root.errors());
  for (auto [key, field] : {std::pair<std::string_view, std::string*>{"grpc", &listen.grpc},
                            std::pair<std::string_view, std::string*>{"http", &listen.http}}) {
    std::string value;
    if (!s.String(key, value)) continue;
    if (!IsHostPort(value)) {
      s.errors().Add(s.Child(key), absl::StrCat("'", value, "' is not a host:port"), *s.Get(key));
      continue;
    }
    *field = value;
  }
}

// A sequence of distinct CPU numbers 0..ThreadScheduling::kMaxCpu.
void ParseCpuList(const Section& s, std::string_view key, std::vector<int>& out) {
  const auto node = s.Get(key);
  if (!node || node->IsNull()) return;
  const std::string path = s.Child(key);
  if (!node->IsSequence()) {
    s.errors().Add(path, absl::StrCat("expected a sequence of CPU numbers, got ", KindName(*node)),
                   *node);
    return;
  }
  std::vector<int> cpus;
  for (size_t i = 0; i < node->size(); ++i) {
    const YAML::Node entry = (*node)[i];
    const std::string at = absl::StrCat(path, "[", i, "]");
    int64_t cpu = 0;
    if (!entry.IsScalar() || !absl::SimpleAtoi(entry.Scalar(), &cpu)) {
      s.errors().Add(at, absl::StrCat(Section::Shown(entry), " is not an integer"), entry);
      return;
    }
    if (cpu < 0 || cpu > transport::ThreadScheduling::kMaxCpu) {
      s.errors().Add(at, absl::StrCat(cpu, " is outside 0..", transport::ThreadScheduling::kMaxCpu),
                     entry);
      return;
    }
    if (std::find(cpus.begin(), cpus.end(), cpu) != cpus.end()) {
      s.errors().Add(at, absl::StrCat("CPU ", cpu, " is given twice"), entry);
      return;
    }
    cpus.push_back(static_cast<int>(cpu));
  }
  out = std::move(cpus);
}

void ParseLinUdp(const Section& drive, LinUdpConfig& out) {
  const YAML::Node node = *drive.Get("linudp");
  const Section s(node, drive.Child("linudp"),
                  {"host", "port", "master_port", "bind_host", "cycle_ms", "reply_timeout_ms",
                   "lost_after_timeouts", "io_priority", "io_cpus"},
                  drive.errors());
  if (!node.IsNull() && !node.IsMap()) return;
  if (s.String("host", out.host, /*required=*/true) && !IsValidHost(out.host)) {
    s.errors().Add(s.Child("host"),
                   absl::StrCat("'", out.host, "' is not a host name or IPv4 address"),
                   *s.Get("host"));
  }
  if (s.String("bind_host", out.bind_host) && !IsValidHost(out.bind_host)) {
    s.errors().Add(s.Child("bind_host"),
                   absl::StrCat("'", out.bind_host, "' is not a host name or IPv4 address"),
                   *s.Get("bind_host"));
  }
  int64_t v = 0;
  if (s.Int("port", 1, kMaxPort, v)) out.port = static_cast<uint16_t>(v);
  // 0 = ephemeral master port: only a simulator that answers the source port replies to it.
  if (s.Int("master_port", 0, kMaxPort, v)) out.master_port = static_cast<uint16_t>(v);
  s.Millis("cycle_ms", kMaxCycleMs, out.cycle);
  s.Millis("reply_timeout_ms", kMaxReplyTimeoutMs, out.reply_timeout);
  if (s.Int("lost_after_timeouts", 1, kMaxLostAfterTimeouts, v)) {
    out.lost_after_timeouts = static_cast<int>(v);
  }
  // Decision 1311: real-time scheduling of the master socket's I/O thread.
  if (s.Int("io_priority", 0, transport::ThreadScheduling::kMaxFifoPriority, v)) {
    out.io_priority = static_cast<int>(v);
  }
  ParseCpuList(s, "io_cpus", out.io_cpus);
}

void ParseAxis(const Section& drive, AxisConfig& out) {
  auto node = drive.Get("axis");
  if (!node) {
    // Travel and dynamics limits guard the machine; they have no safe default (decision 401).
    drive.errors().Add(drive.Child("axis"),
                       "required (min_mm, max_mm, max_velocity_mm_s, "
                       "max_acceleration_mm_s2)",
                       YAML::Node());
    return;
  }
  const Section s(*node, drive.Child("axis"),
                  {"kind", "min_mm", "max_mm", "max_velocity_mm_s", "max_acceleration_mm_s2"},
                  drive.errors());
  if (!node->IsNull() && !node->IsMap()) return;
  std::string kind;
  if (s.String("kind", kind)) {
    if (kind == "linear") {
      out.kind = AxisKind::kLinear;
    } else if (kind == "rotary") {
      out.kind = AxisKind::kRotary;
    } else {
      s.errors().Add(s.Child("kind"), absl::StrCat("'", kind, "' is not one of [linear, rotary]"),
                     *s.Get("kind"));
    }
  }
  const bool have_min = s.Double("min_mm", out.min_mm, /*required=*/true);
  const bool have_max = s.Double("max_mm", out.max_mm, /*required=*/true);
  if (have_min && have_max && !(out.max_mm > out.min_mm)) {
    s.errors().Add(s.Child("max_mm"),
                   absl::StrCat(out.max_mm, " must be greater than min_mm ", out.min_mm),
                   *s.Get("max_mm"));
  }
  for (auto [key, field] :
       {std::pair<std::string_view, double*>{"max_velocity_mm_s", &out.max_velocity_mm_s},
        std::pair<std::string_view, double*>{"max_acceleration_mm_s2",
                                             &out.max_acceleration_mm_s2}}) {
    if (s.Double(key, *field, /*required=*/true) && !(*field > 0)) {
      s.errors().Add(s.Child(key), absl::StrCat(*field, " must be greater than 0"), *s.Get(key));
    }
  }
}

void ParseTimeouts(const Section& drive, TimeoutConfig& out) {
  auto node = drive.Get("timeouts");
  if (!node) return;
  const Section s(*node, drive.Child("timeouts"), {"request_ms", "accept_ms", "homing_ms"},
                  drive.errors());
  s.Millis("request_ms", kMaxRequestMs, out.request);
  s.Millis("accept_ms", kMaxAcceptMs, out.accept);
  s.Millis("homing_ms", kMaxHomingMs, out.homing);
}

// drives[i].health (decision 1431): the keys every family shares. Each is optional; the family's
// own default stands for an absent one. The family-specific count keys stay valid, so giving both
// is ambiguous and refused.
constexpr int64_t kMaxDownAfterFailures = 1000;
constexpr int64_t kMaxBackoffMs = 600000;
constexpr int64_t kMaxUpAfterMs = 600000;
void ParseHealth(const Section& drive, HealthOverrides& out) {
  auto node = drive.Get("health");
  if (!node) return;
  const Section s(*node, drive.Child("health"),
                  {"down_after_failures", "backoff_min_ms", "backoff_max_ms", "up_after_ms"},
                  drive.errors());
  if (!node->IsNull() && !node->IsMap()) return;
  int64_t v = 0;
  if (s.Int("down_after_failures", 1, kMaxDownAfterFailures, v)) {
    out.down_after_failures = static_cast<int>(v);
  }
  // 0 = probe at the family's own pace (LinUDP: every cycle, its behaviour before decision 1431).
  if (s.Int("backoff_min_ms", 0, kMaxBackoffMs, v)) out.backoff_min = std::chrono::milliseconds(v);
  if (s.Int("backoff_max_ms", 0, kMaxBackoffMs, v)) out.backoff_max = std::chrono::milliseconds(v);
  if (out.backoff_min && out.backoff_max && *out.backoff_min > *out.backoff_max) {
    s.errors().Add(s.Child("backoff_min_ms"),
                   absl::StrCat(out.backoff_min->count(), " must not exceed backoff_max_ms ",
                                out.backoff_max->count()),
                   *s.Get("backoff_min_ms"));
  }
  // 0 = UP at the next success, decision 1431's behaviour; the default holds (decision 1432).
  if (s.Int("up_after_ms", 0, kMaxUpAfterMs, v)) out.up_after = std::chrono::milliseconds(v);
  for (auto [section, key] : {std::pair<const char*, const char*>{"linudp", "lost_after_timeouts"},
                              {"trinamic", "offline_after_misses"}}) {
    auto family = drive.Get(section);
    if (out.down_after_failures && family && family->IsMap() && (*family)[key]) {
      s.errors().Add(s.Child("down_after_failures"),
                     absl::StrCat("also given as ", drive.Child(section), ".", key,
                                  " (the same count): give one"),
                     *s.Get("down_after_failures"));
    }
  }
}

// drives[i].trinamic: required for family trinamic and only there; the family's transport lives
// inside it, so the drive-level transport keys would be silently ignored (decision 405).
void ParseTrinamicDrive(const Section& s, size_t index, DriveConfig& drive,
                        internal::TrinamicControllers& controllers) {
  const bool is_trinamic = drive.family == trinamic::kFamilyName;
  if (!s.Has("trinamic")) {
    if (is_trinamic) {
      s.errors().Add(s.Child("trinamic"),
                     "required for family trinamic (serial or can, address, axis, "
                     "microsteps_per_unit)",
                     YAML::Node());
    }
    return;
  }
  if (!is_trinamic) {
    s.errors().Add(s.Child("trinamic"),
                   absl::StrCat("only for family trinamic, not '", drive.family, "'"),
                   *s.Get("trinamic"));
    return;
  }
  for (std::string_view key : {"linudp", "can", "mac_id"}) {
    if (s.Has(key)) {
      s.errors().Add(s.Child(key),
                     absl::StrCat("not used by family trinamic",
                                  key == "can" ? " (its bus goes under trinamic.can)" : ""),
                     *s.Get(key));
    }
  }
  TrinamicConfig t;
  if (internal::ParseTrinamic(s, drive.axis, t)) {
    controllers.Add(index, s.Child("trinamic"), t, *s.Get("trinamic"));
  }
  drive.trinamic = std::move(t);
}

std::string FamilyList(std::span<const std::string_view> families) {
  std::vector<std::string> names;
  for (std::string_view f : families) names.emplace_back(f);
  return absl::StrCat("[", absl::StrJoin(names, ", "), "]");
}

void ParseDrives(const Section& root, std::span<const std::string_view> families,
                 GatewayConfig& cfg) {
  const YAML::Node node = *root.Get("drives");
  Errors& errors = root.errors();
  if (!node.IsSequence() || node.size() == 0) {
    // An empty list is more likely a templating slip than a wish for simulators (decision 402).
    errors.Add("drives",
               node.IsSequence() || node.IsNull()
                   ? std::string("must list at least one drive (omit the key for demo mode)")
                   : absl::StrCat("expected a sequence, got ", KindName(node)),
               node);
    return;
  }
  std::map<std::string, size_t> names;                         // name -> index
  std::map<std::pair<std::string, uint16_t>, size_t> targets;  // linudp host:port -> index
  std::map<std::pair<std::string, uint8_t>, size_t> mac_ids;   // (CAN bus, MAC ID) -> index
  // linudp bind_host:master_port -> (first index, its linudp): one shared I/O thread (1311).
  std::map<std::pair<std::string, uint16_t>, std::pair<size_t, LinUdpConfig>> master_sockets;
  internal::TrinamicControllers trinamic(errors);
  internal::CanOpenNodes canopen_nodes(errors);
  internal::CanBusProtocols bus_protocols(errors);
  for (size_t i = 0; i < node.size(); ++i) {
    const YAML::Node entry = node[i];
    const std::string path = absl::StrCat("drives[", i, "]");
    if (!entry.IsMap()) {
      errors.Add(path, absl::StrCat("expected a mapping, got ", KindName(entry)), entry);
      continue;
    }
    const Section s(entry, path,
                    {"name", "family", "linudp", "can", "mac_id", "node_id", "canopen", "trinamic",
                     "axis", "timeouts", "health"},
                    errors);
    DriveConfig drive;
    if (s.String("name", drive.name, /*required=*/true)) {
      if (!IsValidName(drive.name)) {
        errors.Add(s.Child("name"), absl::StrCat("'", drive.name, "' must match [a-z0-9_-]{1,32}"),
                   *s.Get("name"));
      } else if (auto [it, fresh] = names.emplace(drive.name, i); !fresh) {
        errors.Add(
            s.Child("name"),
            absl::StrCat("'", drive.name, "' is a duplicate of drives[", it->second, "].name"),
            *s.Get("name"));
      }
    }
    if (s.String("family", drive.family, /*required=*/true) &&
        std::find(families.begin(), families.end(), drive.family) == families.end()) {
      errors.Add(s.Child("family"),
                 absl::StrCat("'", drive.family, "' is not one of ", FamilyList(families)),
                 *s.Get("family"));
    }
    if (s.Has("linudp")) {
      drive.linudp.emplace();
      ParseLinUdp(s, *drive.linudp);
      auto [it, fresh] = targets.emplace(std::make_pair(drive.linudp->host, drive.linudp->port), i);
      if (!fresh) {
        errors.Add(s.Child("linudp"),
                   absl::StrCat(drive.linudp->host, ":", drive.linudp->port,
                                " is also the address of drives[", it->second, "]"),
                   *s.Get("linudp"));
      }
      // Port 0 is an ephemeral socket per drive, never shared (decision 702 §5).
      const auto master = std::make_pair(drive.linudp->bind_host, drive.linudp->master_port);
      if (auto [first, fresh_master] =
              master_sockets.emplace(master, std::make_pair(i, *drive.linudp));
          !fresh_master && master.second != 0) {
        const LinUdpConfig& other = first->second.second;
        if (other.io_priority != drive.linudp->io_priority ||
            other.io_cpus != drive.linudp->io_cpus) {
          errors.Add(s.Child("linudp"),
                     absl::StrCat("io_priority/io_cpus differ from drives[", first->second.first,
                                  "], which shares master socket ", master.first, ":",
                                  master.second, " (one I/O thread serves both)"),
                     *s.Get("linudp"));
        }
      }
    } else if (drive.family == "linmot") {
      // linmot-linudp.md §1: the LinMot family talks LinUDP, so it needs the drive's address.
      errors.Add(s.Child("linudp"), "required for family linmot", YAML::Node());
    }
    if (s.Has("can")) {
      drive.can.emplace();
      ParseCan(s, *drive.can);
    } else if (drive.family == "linmot-devicenet") {
      // linmot-devicenet.md: DeviceNet is a CAN protocol, so the drive needs its bus.
      errors.Add(s.Child("can"), "required for family linmot-devicenet", YAML::Node());
    }
    int64_t mac_id = 0;
    if (s.Int("mac_id", 0, kMaxMacId, mac_id)) {
      drive.mac_id = static_cast<uint8_t>(mac_id);
      if (drive.can) {
        // DeviceNet's duplicate MAC ID check would take the second drive off the bus.
        const std::string bus = BusKey(*drive.can);
        auto [it, fresh] = mac_ids.emplace(std::make_pair(bus, *drive.mac_id), i);
        if (!fresh) {
          errors.Add(
              s.Child("mac_id"),
              absl::StrCat(mac_id, " is also the MAC ID of drives[", it->second, "] on ", bus),
              *s.Get("mac_id"));
        }
      }
    } else if (!s.Has("mac_id") && drive.family == "linmot-devicenet") {
      errors.Add(s.Child("mac_id"), "required for family linmot-devicenet (0..63)", YAML::Node());
    }
    ParseAxis(s, drive.axis);
    ParseTimeouts(s, drive.timeouts);
    ParseHealth(s, drive.health);
    ParseTrinamicDrive(s, i, drive, trinamic);
    internal::ParseCanOpenDrive(s, drive);
    canopen_nodes.Add(i, s, drive);
    if (drive.can) bus_protocols.Add(i, drive.family, s.Child("can"), *drive.can, *s.Get("can"));
    if (drive.trinamic && drive.trinamic->can) {
      const YAML::Node t = *s.Get("trinamic");
      bus_protocols.Add(i, drive.family, absl::StrCat(s.Child("trinamic"), ".can"),
                        *drive.trinamic->can, t["can"]);
    }
    cfg.drives.push_back(std::move(drive));
  }
  trinamic.Finish();
}

// Records where each document starts; the tree itself is built by YAML::Load afterwards.
class DocumentStarts : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark& mark) override { last = mark; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

  YAML::Mark last;
};

std::string At(const YAML::Mark& mark) {
  return absl::StrCat("line ", mark.line + 1, ", column ", mark.column + 1);
}

// The text must hold one YAML document. yaml-cpp 0.7 does not consume a stray ',' (or similar
// flow token) at block level: it reports an endless run of empty documents starting at the same
// place, so YAML::LoadAll never returns and YAML::Load silently yields null. A document that
// starts where the previous one did is that stuck token. May throw YAML::Exception.
absl::Status CheckSingleDocument(const std::string& text) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts handler;
  std::vector<YAML::Mark> starts;
  while (starts.size() < 3 && parser.HandleNextDocument(handler)) {
    if (!starts.empty() && handler.last.pos == starts.back().pos) {
      const unsigned char c =
          handler.last.pos >= 0 && static_cast<size_t>(handler.last.pos) < text.size()
              ? static_cast<unsigned char>(text[handler.last.pos])
              : 0;
      const std::string shown = c >= 0x21 && c < 0x7f
                                    ? absl::StrCat("'", std::string(1, static_cast<char>(c)), "'")
                                    : absl::StrCat("byte 0x", absl::Hex(c, absl::kZeroPad2));
      return absl::InvalidArgumentError(
          absl::StrCat("config: YAML error at ", At(handler.last), ": unexpected ", shown));
    }
    starts.push_back(handler.last);
  }
  if (starts.size() > 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "config: more than one YAML document (the second starts at ", At(starts[1]), ")"));
  }
  return absl::OkStatus();
}

absl::StatusOr<GatewayConfig> ParseDocument(const YAML::Node& doc,
                                            std::span<const std::string_view> families) {
  GatewayConfig cfg;
  Errors errors;
  const Section root(doc, "",
                     {"listen", "data_dir", "drives", "tls", "audit", "storage",
                      "shutdown_timeout_s", "auth", "insecure"},
                     errors);
  if (!doc.IsNull() && !doc.IsMap()) return errors.ToStatus();
  ParseListen(root, cfg.listen);
  internal::ParseAuth(root, cfg.auth);
  internal::ApplyAuthToListen(root, cfg.auth, cfg.listen.grpc, cfg.listen.http);
  internal::ParseAudit(root, cfg.audit);
  internal::ParseStorage(root, cfg.storage);
  if (root.String("data_dir", cfg.data_dir) && cfg.data_dir.empty()) {
    errors.Add("data_dir", "must not be empty", *root.Get("data_dir"));
  }
  if (int64_t t = cfg.shutdown_timeout_s; root.Int("shutdown_timeout_s", 1, 300, t)) {
    cfg.shutdown_timeout_s = static_cast<int>(t);
  }
  if (root.Has("drives")) {
    cfg.demo = false;
    ParseDrives(root, families, cfg);
  }
  internal::ParseTls(root, cfg.tls);
  if (!errors.empty()) return errors.ToStatus();
  return cfg;
}

// Sets `o.key` in `doc` to the override's text as a plain scalar, creating the mappings on the
// way (an empty file, `listen:` with nothing below). The text is not parsed as YAML: "[::]:8080"
// would become a flow sequence and "a#b" lose its tail, while every reader takes the scalar's
// text anyway, so "true" and "30" keep their types (decision 024). A parent that is not a
// mapping is left alone: the section reports it with its file position.
void ApplyOverride(YAML::Node& doc, const ConfigOverride& o) {
  if (doc.IsNull()) doc.reset(YAML::Node(YAML::NodeType::Map));
  if (!doc.IsMap()) return;
  const std::vector<std::string> parts = absl::StrSplit(o.key, '.');
  YAML::Node parent = doc;
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node child = parent[parts[i]];
    if (!child.IsDefined() || child.IsNull()) {
      parent[parts[i]] = YAML::Node(YAML::NodeType::Map);
      child.reset(parent[parts[i]]);
    }
    if (!child.IsMap()) return;
    parent.reset(child);
  }
  // Assigning replaces the value node, mark included: an overridden key has no file position.
  parent[parts.back()] = YAML::Node(o.value);
}

}  // namespace

// Every line of Errors starts with the key path ("listen.http: ..."), and the lines are joined
// with "; " (section.cpp).
absl::Status NameOverrides(const absl::Status& status, std::span<const ConfigOverride> overrides) {
  if (status.ok() || overrides.empty()) return status;
  std::vector<std::string> lines = absl::StrSplit(status.message(), "; ");
  for (std::string& line : lines) {
    for (const ConfigOverride& o : overrides) {
      const std::string prefix = absl::StrCat(o.key, ": ");
      if (absl::StartsWith(line, prefix)) {
        line = absl::StrCat(o.key, " (from ", o.variable, "): ", line.substr(prefix.size()));
        break;
      }
    }
  }
  return absl::Status(status.code(), absl::StrJoin(lines, "; "));
}

absl::StatusOr<GatewayConfig> ParseConfig(std::string_view yaml_text,
                                          std::span<const std::string_view> families,
                                          std::span<const ConfigOverride> overrides) {
  if (yaml_text.size() > kMaxConfigBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("config: ", yaml_text.size(), " bytes exceeds ", kMaxConfigBytes));
  }
  try {
    const std::string text(yaml_text);
    if (absl::Status s = CheckSingleDocument(text); !s.ok()) return s;
    YAML::Node doc = YAML::Load(text);
    for (const ConfigOverride& o : overrides) ApplyOverride(doc, o);
    absl::StatusOr<GatewayConfig> cfg = ParseDocument(doc, families);
    if (!cfg.ok()) return NameOverrides(cfg.status(), overrides);
    cfg->source_yaml = std::string(yaml_text);
    return cfg;
  } catch (const YAML::Exception& e) {
    // e.mark is 0-based; the text editors people use count from 1.
    if (e.mark.is_null()) return absl::InvalidArgumentError(absl::StrCat("config: ", e.msg));
    return absl::InvalidArgumentError(
        absl::StrCat("config: YAML error at ", At(e.mark), ": ", e.msg));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("config: ", e.what()));
  } catch (...) {
    return absl::InternalError("config: unknown exception while parsing YAML");
  }
}

absl::StatusOr<GatewayConfig> LoadConfigFile(const std::string& path,
                                             std::span<const std::string_view> families,
                                             std::span<const ConfigOverride> overrides) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) {
    return absl::NotFoundError(absl::StrCat("config: file not found (path=", path, ")"));
  }
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat("config: cannot stat (path=", path, ", error=", ec.message(), ")"));
  }
  if (std::filesystem::is_directory(status)) {
    return absl::InvalidArgumentError(absl::StrCat("config: is a directory (path=", path, ")"));
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxConfigBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("config: ", size, " bytes exceeds ", kMaxConfigBytes, " (path=", path, ")"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::PermissionDeniedError(absl::StrCat("config: cannot read (path=", path, ")"));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    return absl::UnavailableError(absl::StrCat("config: read failed (path=", path, ")"));
  }
  absl::StatusOr<GatewayConfig> cfg = ParseConfig(text.str(), families, overrides);
  if (!cfg.ok()) {
    return absl::Status(cfg.status().code(), absl::StrCat(path, ": ", cfg.status().message()));
  }
  return cfg;
}

std::vector<DriveConfig> DemoDrives(uint16_t first_drive_port) {
  std::vector<DriveConfig> drives;
  for (int i = 0; i < 2; ++i) {
    DriveConfig d;
    d.name = absl::StrCat("x", i + 1);
    d.family = "linmot";
    // A PS01-37x120-style slider: 150 mm usable stroke, motor limits well below catalogue.
    d.axis.kind = AxisKind::kLinear;
    d.axis.min_mm = 0;
    d.axis.max_mm = 150;
    d.axis.max_velocity_mm_s = 2000;
    d.axis.max_acceleration_mm_s2 = 20000;
    LinUdpConfig udp;
    udp.host = "127.0.0.1";
    udp.port = static_cast<uint16_t>(first_drive_port + i);
    d.linudp = udp;
    drives.push_back(std::move(d));
  }
  return drives;
}

std::vector<DriveConfig> DemoTrinamicDrives(const std::string& device) {
  std::vector<DriveConfig> drives;
  for (uint8_t motor : {0, 1}) {
    DriveConfig d;
    d.name = motor == 0 ? "feeder-x" : "feeder-y";
    d.family = trinamic::kFamilyName;
    // A 1.8° stepper at 16 microsteps (3200 microsteps/rev) on a 5 mm lead screw: 640 /mm.
    // Limits reachable with the PACK's reset defaults (trinamic-sixpack.md §5.12, units.h):
    // clkdiv 5, div 2 -> K = 20 MHz / (6 x 2^16) = 50.86 microsteps/s per velocity unit (§5.1);
    // vmax 511 -> 25991 microsteps/s = 40.6 mm/s, so 40 mm/s (register 503).
    // amax <= vstart x 64 = 5 x 64 = 320 (L556) -> 7.8125 x 320 x K = 127157 microsteps/s²
    // = 198.7 mm/s² (§5.3), so 190 mm/s² (amax 306). 200 mm = 128000 microsteps (int32, §5.2).
    d.axis.kind = AxisKind::kLinear;
    d.axis.min_mm = 0;
    d.axis.max_mm = 200;
    d.axis.max_velocity_mm_s = 40;
    d.axis.max_acceleration_mm_s2 = 190;
    TrinamicConfig t;
    t.serial = SerialLineConfig{.device = device, .baud = 19200};
    t.address = 1;
    t.axis = motor;
    t.axes = 6;
    t.microsteps_per_unit = 640;
    d.trinamic = std::move(t);
    drives.push_back(std::move(d));
  }
  return drives;
}

DriveConfig DemoStoberDrive(const CanBusConfig& bus) {
  DriveConfig d;
  d.name = "s1";
  d.family = stober::kFamilyName;
  // The simulator's power-on catalogue is the F-LIN fixture (stober-motion.md §10.1, decision
  // 1141): I50 = +10000, I51 = -10000, I10 = 1000, I11 = 10000 in u; 1 u = 1 mm (decision 409).
  d.axis.kind = AxisKind::kLinear;
  d.axis.min_mm = -10000;
  d.axis.max_mm = 10000;
  d.axis.max_velocity_mm_s = 1000;
  d.axis.max_acceleration_mm_s2 = 10000;
  d.can = bus;
  d.node_id = 3;
  return d;
}

}  // namespace drivegw::config
