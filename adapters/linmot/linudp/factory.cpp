// Factory of the LinMot-over-LinUDP drive family: config checks naming the field, then the drive.
#include "adapters/linmot/linudp/factory.h"

#include "absl/strings/str_cat.h"
#include "adapters/core/drive_config_check.h"
#include "adapters/core/status.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/transport/endpoint.h"
#include "adapters/transport/thread_scheduling.h"

namespace drivegw::linmot::linudp {

HealthConfig LinUdpHealthConfig(const DriveConfig& config) {
  HealthConfig defaults;
  defaults.down_after_failures = config.linudp ? config.linudp->lost_after_timeouts : 5;
  defaults.backoff_min = defaults.backoff_max = std::chrono::milliseconds(0);
  return ResolveHealthConfig(config.health, defaults);
}

absl::StatusOr<std::unique_ptr<Drive>> CreateLinMotUdpDrive(const DriveConfig& config,
                                                            const Clock& clock) {
  const std::string where = absl::StrCat("drive '", config.name, "'");
  if (!config.linudp) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".linudp: missing (family '", config.family,
                     "' needs the LinUDP section: host, port, master_port, ...)"));
  }
  const LinUdpConfig& c = *config.linudp;
  // A name is resolved at activation (Endpoint::Resolve); here only an empty host is refused.
  if (c.host.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".linudp.host: must not be empty"));
  }
  if (c.port == 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".linudp.port: 0 is not a drive port"));
  }
  if (auto e = transport::Endpoint::Parse(c.bind_host, c.master_port); !e.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".linudp.bind_host: ", e.status().message()));
  }
  if (c.cycle < std::chrono::milliseconds(1)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".linudp.cycle: ", c.cycle.count(),
                                                   " ms is below 1 ms (linmot-linudp.md A-10)"));
  }
  if (c.reply_timeout <= std::chrono::milliseconds(0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ".linudp.reply_timeout: ", c.reply_timeout.count(), " ms must be positive"));
  }
  if (c.lost_after_timeouts < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ".linudp.lost_after_timeouts: ", c.lost_after_timeouts, " must be at least 1"));
  }
  if (absl::Status s = ValidateHealthConfig(LinUdpHealthConfig(config), where + ".health.");
      !s.ok()) {
    return s;
  }
  transport::ThreadScheduling scheduling;
  scheduling.fifo_priority = c.io_priority;
  scheduling.cpus = c.io_cpus;
  if (absl::Status s = transport::ValidateThreadScheduling(scheduling, where + ".linudp");
      !s.ok()) {
    return s;
  }
  DGW_RETURN_IF_ERROR(CheckTimeoutsAndAxis(config, where));
  return std::unique_ptr<Drive>(new LinMotUdpDrive(config, clock));
}

}  // namespace drivegw::linmot::linudp
