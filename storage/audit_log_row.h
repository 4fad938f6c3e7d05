// Internal to storage/audit_log*.cpp: the column list every audit SELECT reads, and its reader.
#pragma once

#include "storage/audit_log.h"
#include "storage/db.h"

namespace drivegw::storage::internal {

inline constexpr char kAuditColumns[] =
    "id, ts, principal, source_address, drive, action, request_json, result_code, "
    "result_message, seq, role, before_json, after_json, prev_hash, hash";

// Reads one row selected with kAuditColumns first.
AuditRecord ReadAuditRecord(const Statement& stmt);

}  // namespace drivegw::storage::internal
