// CreateStoberDrive: every check names the field and its limit (issue 5), then builds the drive.
#include "adapters/stober/factory.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/sdo.h"
#include "adapters/stober/drive.h"
#include "adapters/stober/object_map.h"

namespace drivegw::stober {
namespace {

absl::Status Bad(const DriveConfig& c, const std::string& field, const std::string& why) {
  return absl::InvalidArgumentError(absl::StrCat("drive '", c.name, "'.", field, ": ", why));
}

}  // namespace

HealthConfig StoberHealthConfig(const DriveConfig& config) {
  HealthConfig defaults;
  defaults.down_after_failures = 1;
  defaults.backoff_min = defaults.backoff_max = std::chrono::milliseconds(500);
  return ResolveHealthConfig(config.health, defaults);
}

absl::StatusOr<std::unique_ptr<Drive>> CreateStoberDrive(const DriveConfig& config,
                                                         const Clock& clock) {
  if (!config.can) return Bad(config, "can", "family 'stober' needs a CAN bus (can section)");
  const CanBusConfig& can = *config.can;
  if (can.kind == CanBusConfig::Kind::kSocketCan && can.interface.empty()) {
    return Bad(config, "can.interface", "must not be empty for socketcan");
  }
  if (can.kind == CanBusConfig::Kind::kUdpMulticast) {
    if (can.group.empty()) return Bad(config, "can.group", "must not be empty");
    if (can.port == 0) return Bad(config, "can.port", "0 is not a UDP port (1..65535)");
  }
  if (!config.node_id) return Bad(config, "node_id", "missing (CANopen node ID 1..127)");
  if (*config.node_id < 1 || *config.node_id > 127) {
    return Bad(config, "node_id",
               absl::StrCat(std::to_string(*config.node_id),
                            " is not a CANopen node ID 1..127 (CiA 301 §7.3.1)"));
  }
  const CanOpenConfig& co = config.canopen;
  auto positive = [&](const char* field, std::chrono::milliseconds v) -> absl::Status {
    if (v.count() <= 0) {
      return Bad(config, absl::StrCat("canopen.", field),
                 absl::StrCat(v.count(), " ms must be > 0"));
    }
    return absl::OkStatus();
  };
  for (const auto& [field, v] :
       {std::pair<const char*, std::chrono::milliseconds>{"heartbeat", co.heartbeat},
        {"heartbeat_timeout", co.heartbeat_timeout},
        {"sync_period", co.sync_period},
        {"sdo_timeout", co.sdo_timeout}}) {
    if (auto s = positive(field, v); !s.ok()) return s;
  }
  if (co.sdo_retries < 0 || co.sdo_retries > canopen::kSdoMaxRetries) {
    return Bad(config, "canopen.sdo_retries",
               absl::StrCat(co.sdo_retries, " is outside 0..", canopen::kSdoMaxRetries,
                            " (repeats of a timed-out SDO transfer, decision 1481)"));
  }
  if (co.heartbeat.count() > 65535) {
    return Bad(config, "canopen.heartbeat",
               absl::StrCat(co.heartbeat.count(), " ms exceeds 1017h's 65535 ms"));
  }
  if (co.heartbeat_timeout <= co.heartbeat) {
    return Bad(config, "canopen.heartbeat_timeout",
               absl::StrCat(co.heartbeat_timeout.count(), " ms must exceed canopen.heartbeat ",
                            co.heartbeat.count(), " ms"));
  }
  // Decision 1483: the gateway's own heartbeat (700h + master_node_id) and the drive's
  // (700h + node_id) must not share a COB-ID.
  if (co.master_node_id > 127) {
    return Bad(config, "canopen.master_node_id",
               absl::StrCat(co.master_node_id, " is not a CANopen node ID (0 off, 1..127)"));
  }
  if (co.master_node_id == *config.node_id) {
    return Bad(config, "canopen.master_node_id",
               absl::StrCat(co.master_node_id, " is also this drive's node_id ", *config.node_id,
                            "; the gateway's own node ID must differ from every drive's"));
  }
  if (co.master_node_id != 0 && co.heartbeat_timeout.count() > 65535) {
    return Bad(config, "canopen.heartbeat_timeout",
               absl::StrCat(co.heartbeat_timeout.count(),
                            " ms exceeds 1016h's 65535 ms (the drive's consumer time of the "
                            "gateway's heartbeat)"));
  }
  // Positions travel as INTEGER32 in 0.001 u (decision 1172).
  const double limit = std::numeric_limits<int32_t>::max() * kUserUnitScale;
  for (const auto& [field, mm] : {std::pair<const char*, double>{"min_mm", config.axis.min_mm},
                                  std::pair<const char*, double>{"max_mm", config.axis.max_mm}}) {
    if (!std::isfinite(mm) || std::fabs(mm) > limit) {
      return Bad(config, absl::StrCat("axis.", field),
                 absl::StrCat(mm, " mm exceeds the i32 × 0.001 u position range ±", limit,
                              " (decision 1172)"));
    }
  }
  if (config.axis.min_mm >= config.axis.max_mm) {
    return Bad(config, "axis.min_mm",
               absl::StrCat(config.axis.min_mm, " must be below axis.max_mm ", config.axis.max_mm));
  }
  if (auto s = ValidateHealthConfig(StoberHealthConfig(config),
                                    absl::StrCat("drive '", config.name, "'.health."));
      !s.ok()) {
    return s;
  }
  return std::unique_ptr<Drive>(std::make_unique<StoberDrive>(config, clock));
}

}  // namespace drivegw::stober
