// StopMovingDrives (shutdown.h).
#include "server/ops/shutdown.h"

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "server/core/audit.h"

namespace drivegw::ops {

bool IsMoving(const DriveStatus& s) {
  if (s.state == DriveState::kOffline) return false;  // nothing to tell it; it may still coast
  return s.motion_active || s.state == DriveState::kMoving || s.state == DriveState::kHoming;
}

StopReport StopMovingDrives(const std::vector<std::shared_ptr<Drive>>& drives,
                            std::chrono::steady_clock::time_point deadline,
                            storage::AuditLog* audit) {
  StopReport report;
  server::CallContext system;
  system.principal = "drivegw";
  system.role = "system";
  system.source_address = "local";
  system.transport = "shutdown";
  std::vector<Drive*> waiting;
  for (const auto& d : drives) {
    if (d->lifecycle() != Lifecycle::kActive || !IsMoving(d->GetStatus())) continue;
    const double dec = d->config().axis.max_acceleration_mm_s2;
    absl::StatusOr<CommandInfo> r = d->Move(StopMotion{dec});
    const std::string json = absl::StrCat("{\"deceleration_mm_s2\":", dec, "}");
    server::WriteAudit(audit, system, d->config().name, "ShutdownStop", json, r.status());
    log::Info("shutdown_stop", log::Fields()
                                   .Add("drive", d->config().name)
                                   .Add("deceleration_mm_s2", dec)
                                   .Add("result", r.ok() ? "accepted" : r.status().ToString()));
    if (r.ok()) {
      waiting.push_back(d.get());
    } else {
      report.still_moving.push_back(d->config().name);
    }
  }
  for (Drive* d : waiting) {
    DriveStatus s = d->GetStatus();
    while (IsMoving(s) && std::chrono::steady_clock::now() < deadline) {
      s = d->WaitForStatus(s.sequence, deadline);
    }
    (IsMoving(s) ? report.still_moving : report.stopped).push_back(d->config().name);
  }
  return report;
}

}  // namespace drivegw::ops
