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

// Appends one entry; `audit` may be null (tests without storage). A failed append is logged,
// not returned: the call itself already happened, an operator must look at the storage.
void WriteAudit(storage::AuditLog* audit, const CallContext& c, const std::string& drive,
                const std::string& action, const std::string& request_json,
                const absl::Status& result);

}  // namespace drivegw::server
