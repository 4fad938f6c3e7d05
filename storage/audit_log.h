// Append-only audit log of operator actions (table audit_log, guarded by triggers).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/db.h"

namespace drivegw::storage {

struct AuditEntry {
  std::chrono::system_clock::time_point time;  // stored as UTC ISO-8601 with milliseconds
  std::string principal;                       // who: peer identity or "anonymous"
  std::string source_address;                  // e.g. "ipv4:127.0.0.1:53122"
  std::string drive;                           // "" when the action is not about one drive
  std::string action;                          // e.g. "MoveAbsolute"
  std::string request_json;
  int result_code = 0;  // absl::StatusCode as int
  std::string result_message;
};

struct AuditRecord : AuditEntry {
  int64_t id = 0;  // ascending in append order
};

struct AuditQuery {
  static constexpr int kMaxLimit = 1000;
  std::optional<std::string> drive;                            // exact match
  std::optional<std::string> action;                           // exact match
  std::optional<std::chrono::system_clock::time_point> since;  // time >= since (ms resolution)
  std::optional<int64_t> before_id;  // id < before_id: pages backwards from the last record seen
  int limit = 100;                   // 1..kMaxLimit; 0 means the default 100
};

class AuditLog {
 public:
  // Keeps `db`, which must outlive this object and stay migrated to the latest schema.
  explicit AuditLog(Db& db) : db_(&db) {}

  // One INSERT through a cached prepared statement; safe from any thread.
  absl::Status Append(const AuditEntry& entry);
  // Newest first (by id). InvalidArgument for limit < 0 or > kMaxLimit.
  absl::StatusOr<std::vector<AuditRecord>> Query(const AuditQuery& query);
  absl::StatusOr<int64_t> Count();

 private:
  Db* db_;
  Statement insert_;  // prepared on first Append, guarded by db_->Lock()
};

// UTC ISO-8601 with milliseconds, "2024-05-01T12:00:00.123Z" (fixed width for 0000..9999, so
// text order is time order).
std::string FormatTimestamp(std::chrono::system_clock::time_point time);
absl::StatusOr<std::chrono::system_clock::time_point> ParseTimestamp(std::string_view text);

}  // namespace drivegw::storage
