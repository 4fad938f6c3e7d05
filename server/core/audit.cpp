// Audit entries of the service core.
#include "server/core/audit.h"

#include <chrono>

#include "adapters/core/log.h"
#include "google/protobuf/util/json_util.h"
#include "server/ops/metrics.h"
#include "storage/audit_log.h"

namespace drivegw::server {

std::string ToAuditJson(const google::protobuf::Message& m) {
  std::string out;
  google::protobuf::util::JsonPrintOptions o;
  o.preserve_proto_field_names = true;
  if (!google::protobuf::util::MessageToJsonString(m, &out, o).ok()) return "{}";
  return out;
}

void WriteAudit(storage::AuditLog* audit, const CallContext& c, const AuditWrite& w) {
  if (audit == nullptr) return;
  storage::AuditEntry e;
  e.time = std::chrono::system_clock::now();
  e.principal = c.principal;
  e.role = c.role;
  e.source_address = c.source_address;
  e.drive = w.drive;
  e.action = w.action;
  e.request_json = w.request_json;
  e.result_code = static_cast<int>(w.result.code());
  e.result_message = w.message.empty() ? std::string(w.result.message()) : w.message;
  e.before_json = w.before_json;
  e.after_json = w.after_json;
  const auto started = std::chrono::steady_clock::now();
  const absl::Status appended = audit->Append(e);
  ops::ObserveAuditWrite(  // /metrics: drivegw_audit_write_seconds (decision 021)
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  if (const absl::Status& s = appended; !s.ok()) {
    log::Error(
        "audit_append_failed",
        log::Fields().Add("drive", w.drive).Add("action", w.action).Add("error", s.message()));
  }
}

void WriteAudit(storage::AuditLog* audit, const CallContext& c, const std::string& drive,
                const std::string& action, const std::string& request_json,
                const absl::Status& result) {
  WriteAudit(audit, c, AuditWrite{drive, action, request_json, result, "", "", ""});
}

}  // namespace drivegw::server
