// drives[i].node_id / drives[i].canopen of family stober, and the rules between CANopen drives.
#include "server/config/stober_config.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "server/config/can_config.h"

namespace drivegw::config::internal {
namespace {

// CiA 301 §7.5.2.1 / §7.3.3: node IDs 1..127 (0 addresses every node in NMT).
constexpr int64_t kMinNodeId = 1;
constexpr int64_t kMaxNodeId = 127;
// 1017h producer heartbeat time and 1016h consumer time are UNSIGNED16 ms (CiA 301 §7.5.2.19-20).
constexpr int64_t kMaxHeartbeatMs = 65535;
// A291 (controller cycle time) 0.125..1000 ms; the SYNC producer runs at 1 ms or more
// (decision 1116).
constexpr int64_t kMaxSyncPeriodMs = 1000;
// Same bound as the other per-exchange reply timeouts (linudp.reply_timeout_ms).
constexpr int64_t kMaxSdoTimeoutMs = 10000;
// Decision 1172: positions and velocities travel as INTEGER32, accelerations as UNSIGNED32, in
// increments of 0.001 u; with 1 u = 1 mm (decision 409) these are the limits in mm.
constexpr double kMaxPositionMm = std::numeric_limits<int32_t>::max() * stober::kUserUnitScale;
constexpr double kMaxVelocityMmS = std::numeric_limits<int32_t>::max() * stober::kUserUnitScale;
constexpr double kMaxAccelerationMmS2 =
    std::numeric_limits<uint32_t>::max() * stober::kUserUnitScale;

int64_t Ms(std::chrono::milliseconds d) { return d.count(); }

// 2147483.647 and 3000000 rather than StrCat's six significant digits (2.14748e+06).
std::string Exact(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", value);
  return text;
}

// The node under `key` of mapping `parent`, or `parent` itself (for the line number).
YAML::Node NodeOf(const std::optional<YAML::Node>& parent, std::string_view key) {
  if (!parent) return YAML::Node();
  if (parent->IsMap()) {
    const YAML::Node n = (*parent)[std::string(key)];
    if (n.IsDefined()) return n;
  }
  return *parent;
}

// CiA 301 §7.5.2.35 sub 2 for an RPDO: 0..240 synchronous (actuated at the next SYNC), 254/255
// event-driven (on reception); 241..251 are reserved and 252/253 (RTR) exist for TPDOs only
// (decision 1119).
void ParseRpdoTransmissionType(const Section& c, CanOpenConfig& out) {
  int64_t type = out.rpdo_transmission_type;
  if (!c.Int("rpdo_transmission_type", 0, 255, type)) return;
  const bool synchronous = type <= canopen::kTransmissionSyncEveryMax;
  const bool event =
      type == canopen::kTransmissionEventManufacturer || type == canopen::kTransmissionEventProfile;
  if (!synchronous && !event) {
    c.errors().Add(c.Child("rpdo_transmission_type"),
                   absl::StrCat(type,
                                type >= canopen::kTransmissionSyncRtr ? " is for TPDOs only (RTR)"
                                                                      : " is reserved",
                                "; an RPDO is synchronous (0..240, applied at the next SYNC) or "
                                "event-driven (254, 255)"),
                   *c.Get("rpdo_transmission_type"));
    return;
  }
  out.rpdo_transmission_type = static_cast<uint8_t>(type);
}

void ParseCanOpen(const Section& s, CanOpenConfig& out) {
  const auto node = s.Get("canopen");
  if (node) {
    const Section c(*node, s.Child("canopen"),
                    {"heartbeat_ms", "heartbeat_timeout_ms", "sync_period_ms", "sdo_timeout_ms",
                     "sdo_retries", "rpdo_transmission_type", "master_node_id"},
                    s.errors());
    if (node->IsNull() || node->IsMap()) {
      c.Millis("heartbeat_ms", kMaxHeartbeatMs, out.heartbeat);
      c.Millis("heartbeat_timeout_ms", kMaxHeartbeatMs, out.heartbeat_timeout);
      c.Millis("sync_period_ms", kMaxSyncPeriodMs, out.sync_period);
      c.Millis("sdo_timeout_ms", kMaxSdoTimeoutMs, out.sdo_timeout);
      int64_t retries = out.sdo_retries;
      if (c.Int("sdo_retries", 0, canopen::kSdoMaxRetries, retries)) {
        out.sdo_retries = static_cast<int>(retries);
      }
      ParseRpdoTransmissionType(c, out);
      // Decision 1483: the gateway's own node ID for its heartbeat; 0 = no drive watchdog.
      int64_t master = out.master_node_id;
      if (c.Int("master_node_id", 0, kMaxNodeId, master)) {
        out.master_node_id = static_cast<uint8_t>(master);
      }
    }
  }
  // CiA 301 §7.2.8.3.2: the consumer must wait longer than the producer's period, or every
  // heartbeat on time would still count as lost.
  if (!(out.heartbeat_timeout > out.heartbeat)) {
    const bool given = node && node->IsMap() && (*node)["heartbeat_timeout_ms"].IsDefined();
    s.errors().Add(absl::StrCat(s.Child("canopen"), ".heartbeat_timeout_ms"),
                   absl::StrCat(Ms(out.heartbeat_timeout), given ? "" : " (the default)",
                                " must be greater than heartbeat_ms ", Ms(out.heartbeat)),
                   NodeOf(node, "heartbeat_timeout_ms"));
  }
}

// Decision 1172: every limit the drive writes must fit its wire type.
void CheckWireRange(const Section& s, const AxisConfig& axis) {
  const auto node = s.Get("axis");
  if (!node) return;  // already "required"
  const std::string path = s.Child("axis");
  auto beyond = [&](std::string_view key, double value, double limit, std::string_view type) {
    s.errors().Add(
        absl::StrCat(path, ".", Av(key)),
        absl::StrCat(Exact(value), " is beyond the STOBER wire range ", type == "i32" ? "±" : "",
                     Exact(limit), " (", Av(type == "i32" ? "INTEGER32" : "UNSIGNED32"),
                     " in 0.001 units, decision 1172)"),
        NodeOf(node, key));
  };
  if (std::abs(axis.min_mm) > kMaxPositionMm) beyond("min_mm", axis.min_mm, kMaxPositionMm, "i32");
  if (std::abs(axis.max_mm) > kMaxPositionMm) beyond("max_mm", axis.max_mm, kMaxPositionMm, "i32");
  if (axis.max_velocity_mm_s > kMaxVelocityMmS) {
    beyond("max_velocity_mm_s", axis.max_velocity_mm_s, kMaxVelocityMmS, "i32");
  }
  if (axis.max_acceleration_mm_s2 > kMaxAccelerationMmS2) {
    beyond("max_acceleration_mm_s2", axis.max_acceleration_mm_s2, kMaxAccelerationMmS2, "u32");
  }
}

}  // namespace

void ParseCanOpenDrive(const Section& s, DriveConfig& drive) {
  if (drive.family != stober::kFamilyName) {
    // A key the family would never read is refused, as unknown keys are (decision 408).
    for (std::string_view key : {"node_id", "canopen"}) {
      if (s.Has(key)) {
        s.errors().Add(s.Child(key),
                       absl::StrCat("only for CANopen families (stober), not '", drive.family, "'",
                                    key == "node_id" && drive.family == "linmot-devicenet"
                                        ? " (a DeviceNet drive is addressed by mac_id)"
                                        : ""),
                       *s.Get(key));
      }
    }
    return;
  }
  for (std::string_view key : {"linudp", "mac_id"}) {
    if (s.Has(key)) {
      s.errors().Add(
          s.Child(key),
          absl::StrCat("not used by family stober",
                       key == "mac_id" ? " (a CANopen drive is addressed by node_id)" : ""),
          *s.Get(key));
    }
  }
  if (!s.Has("can")) {
    s.errors().Add(s.Child("can"), "required for family stober (the CANopen bus)", YAML::Node());
  }
  int64_t node_id = 0;
  if (s.Int("node_id", kMinNodeId, kMaxNodeId, node_id)) {
    drive.node_id = static_cast<uint8_t>(node_id);
  } else if (!s.Has("node_id")) {
    s.errors().Add(s.Child("node_id"), "required for family stober (1..127)", YAML::Node());
  }
  ParseCanOpen(s, drive.canopen);
  if (drive.node_id && *drive.node_id == drive.canopen.master_node_id) {
    // One heartbeat COB-ID 700h + n per node ID: the drive's and the gateway's would collide.
    s.errors().Add(absl::StrCat(s.Child("canopen"), ".master_node_id"),
                   absl::StrCat(static_cast<int>(drive.canopen.master_node_id),
                                " is also this drive's node_id; the gateway's own node ID on the "
                                "bus must differ from every drive's (decision 1483)"),
                   NodeOf(s.Get("canopen"), "master_node_id"));
  }
  CheckWireRange(s, drive.axis);
}

void CanOpenNodes::Add(size_t index, const Section& s, const DriveConfig& drive) {
  if (drive.family != stober::kFamilyName || !drive.can || !drive.node_id) return;
  const std::string bus = BusKey(*drive.can);
  // Two drives on one node would both configure and command the same axis.
  if (auto [it, fresh] = nodes_.emplace(std::make_pair(bus, *drive.node_id), index); !fresh) {
    errors_.Add(
        s.Child("node_id"),
        absl::StrCat(*drive.node_id, " is also the node ID of drives[", it->second, "] on ", bus),
        *s.Get("node_id"));
  }
  CheckMasterNode(index, s, drive, bus);
  const int64_t sync = Ms(drive.canopen.sync_period);
  if (auto [it, fresh] = sync_.emplace(bus, std::make_pair(index, sync)); !fresh) {
    if (it->second.second != sync) {
      errors_.Add(absl::StrCat(s.Child("canopen"), ".sync_period_ms"),
                  absl::StrCat(sync, " differs from drives[", it->second.first, "] (",
                               it->second.second, ") on the same bus ", bus,
                               "; the bus's CANopen master has one SYNC producer (decision 1116)"),
                  NodeOf(s.Get("canopen"), "sync_period_ms"));
    }
  }
}

// Decision 1483: the bus's one master has one own node ID, and no drive on the bus may use it.
void CanOpenNodes::CheckMasterNode(size_t index, const Section& s, const DriveConfig& drive,
                                   const std::string& bus) {
  const uint8_t master = drive.canopen.master_node_id;
  const YAML::Node at = NodeOf(s.Get("canopen"), "master_node_id");
  const std::string key = absl::StrCat(s.Child("canopen"), ".master_node_id");
  if (auto [it, fresh] = masters_.emplace(bus, std::make_pair(index, master)); !fresh) {
    if (it->second.second != master) {
      errors_.Add(key,
                  absl::StrCat(static_cast<int>(master), " differs from drives[", it->second.first,
                               "] (", static_cast<int>(it->second.second), ") on the same bus ",
                               bus, "; the bus's CANopen master has one node ID"),
                  at);
    }
  }
  if (auto it = nodes_.find({bus, master});
      master != 0 && it != nodes_.end() && it->second != index) {
    errors_.Add(key,
                absl::StrCat(static_cast<int>(master), " is the node_id of drives[", it->second,
                             "] on ", bus, "; the gateway's own node ID must differ"),
                at);
  }
  const auto& [first, first_master] = masters_.at(bus);
  if (first != index && first_master != 0 && first_master == *drive.node_id) {
    errors_.Add(s.Child("node_id"),
                absl::StrCat(static_cast<int>(*drive.node_id),
                             " is the gateway's own node ID (canopen.master_node_id of drives[",
                             first, "]) on ", bus),
                *s.Get("node_id"));
  }
}

}  // namespace drivegw::config::internal
