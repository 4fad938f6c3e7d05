// One audit entry per mutating call (storage::AuditLog), written by the core and by the
// per-stream objects that outlive a single core call (the cyclic set-point stream).
#pragma once

#include <string>

#include "absl/status/status.h"
#include "google/protobuf/message.h"
#include "server/core/call_context.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

// JSON with the proto field names ("{}" if the message cannot be printed).
std::string ToAuditJson(const google::protobuf::Message& m);

// What one call did, for the IEC 62443-4-2 CR 2.8 record (issue 7, decision 017). The principal,
// role and source address come from the CallContext.
struct AuditWrite {
  std::string drive;  // "" when the action is not about one drive
  std::string action;
  std::string request_json;
  absl::Status result;
  // The state before and after, where the call changed one (JSON; "" = none).
  std::string before_json;
  std::string after_json;
  // The entry's message when the result is OK but there is something to say (a drive's fault
  // text); "" = result.message().
  std::string message;
};

// Appends one entry; `audit` may be null (tests without storage). A failed append is logged,
// not returned: the call itself already happened, an operator must look at the storage.
void WriteAudit(storage::AuditLog* audit, const CallContext& c, const AuditWrite& write);

// The original form, kept for every existing caller: no before/after.
void WriteAudit(storage::AuditLog* audit, const CallContext& c, const std::string& drive,
                const std::string& action, const std::string& request_json,
                const absl::Status& result);

}  // namespace drivegw::server
