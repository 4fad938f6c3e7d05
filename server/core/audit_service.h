// The core of AuditService (issue 7 "Audit trail", decision 017), behind gRPC and REST: filtered
// newest-first pages, a stream of new entries, an oldest-first export, and chain verification.
// Nothing here changes or removes an entry.
#pragma once

#include <atomic>
#include <functional>

#include "absl/status/statusor.h"
#include "drivegw/v1/audit.pb.h"
#include "server/core/call_context.h"
#include "storage/audit_log.h"

namespace drivegw::server {

// The API form of a stored entry.
v1::AuditEvent ToProto(const storage::AuditRecord& r);

class AuditServiceCore {
 public:
  // `log` must outlive the core.
  explicit AuditServiceCore(storage::AuditLog& log) : log_(log) {}

  absl::StatusOr<v1::ListAuditEventsResponse> ListAuditEvents(const v1::ListAuditEventsRequest& r,
                                                              const CallContext& c);
  // Runs until `cancelled`, Shutdown, or the sink refuses (false); new entries only.
  absl::Status WatchAuditEvents(const v1::WatchAuditEventsRequest& r, const CallContext& c,
                                const std::function<bool(const v1::AuditEvent&)>& sink,
                                const std::function<bool()>& cancelled);
  // Every matching entry up to the newest one at the start, oldest first; audited as
  // "audit.export".
  absl::Status ExportAuditEvents(const v1::ExportAuditEventsRequest& r, const CallContext& c,
                                 const std::function<bool(const v1::AuditEvent&)>& sink,
                                 const std::function<bool()>& cancelled);
  // Audited as "audit.verify" with the outcome.
  absl::StatusOr<v1::VerifyAuditLogResponse> VerifyAuditLog(const v1::VerifyAuditLogRequest& r,
                                                            const CallContext& c);

  // Ends every watch stream (gateway shutdown).
  void Shutdown() { shutting_down_.store(true); }

 private:
  storage::AuditLog& log_;
  std::atomic<bool> shutting_down_{false};
};

}  // namespace drivegw::server
