// OpsServiceCore: wire trace switch (audited) and readiness.
#include "server/ops/ops_service.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "server/core/audit.h"

namespace drivegw::server {

absl::StatusOr<v1::SetWireTraceResponse> OpsServiceCore::SetWireTrace(
    const v1::SetWireTraceRequest& r, const CallContext& c) {
  std::string id = r.name();
  if (absl::StartsWith(id, "drives/")) id = id.substr(7);
  Drive* drive = nullptr;
  for (const auto& d : drives_) {
    if (d->config().name == id) drive = d.get();
  }
  absl::Status s = drive == nullptr
                       ? absl::NotFoundError(absl::StrCat("name: drive '", id, "' not found"))
                       : drive->SetWireTrace(r.enabled());
  WriteAudit(audit_, c, drive == nullptr ? "" : id, "SetWireTrace", ToAuditJson(r), s);
  if (!s.ok()) return s;
  log::Info("wire_trace", log::Fields()
                              .Add("drive", id)
                              .Add("enabled", r.enabled() ? "true" : "false")
                              .Add("principal", c.principal));
  v1::SetWireTraceResponse out;
  out.set_name(absl::StrCat("drives/", id));
  out.set_enabled(r.enabled());
  return out;
}

absl::StatusOr<v1::Readiness> OpsServiceCore::GetReadiness(const v1::GetReadinessRequest& r,
                                                           const CallContext& c) {
  (void)r;
  (void)c;
  const absl::Status s = readiness_.Check();
  v1::Readiness out;
  out.set_ready(s.ok());
  out.set_reason(std::string(s.message()));
  return out;
}

}  // namespace drivegw::server
