// Configuration snapshots: insert the loaded YAML, read back the newest ones.
#include "storage/config_repo.h"

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "storage/audit_log.h"

namespace drivegw::storage {
namespace {

constexpr char kSelect[] =
    "SELECT id, created_at, source, yaml, drive_count FROM drive_config_snapshots "
    "ORDER BY id DESC LIMIT ?1";

Snapshot ReadSnapshot(const Statement& stmt) {
  Snapshot s;
  s.id = stmt.ColumnInt64(0);
  s.created_at =
      ParseTimestamp(stmt.ColumnText(1)).value_or(std::chrono::system_clock::time_point{});
  s.source = stmt.ColumnText(2);
  s.yaml = stmt.ColumnText(3);
  s.drive_count = stmt.ColumnInt(4);
  return s;
}

}  // namespace

absl::StatusOr<int64_t> ConfigRepo::SaveSnapshot(std::string_view source, std::string_view yaml,
                                                 int drive_count) {
  if (drive_count < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("config_snapshot.drive_count: ", drive_count, " is negative"));
  }
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare("INSERT INTO drive_config_snapshots "
                                                    "(created_at, source, yaml, drive_count) "
                                                    "VALUES (?1, ?2, ?3, ?4)"));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, FormatTimestamp(std::chrono::system_clock::now())));
  DGW_RETURN_IF_ERROR(stmt.Bind(2, source));
  DGW_RETURN_IF_ERROR(stmt.Bind(3, yaml));
  DGW_RETURN_IF_ERROR(stmt.Bind(4, drive_count));
  DGW_RETURN_IF_ERROR(stmt.Run());
  // Still under the lock, so the row id is ours.
  return db_->LastInsertRowId();
}

absl::StatusOr<std::optional<Snapshot>> ConfigRepo::Latest() {
  DGW_ASSIGN_OR_RETURN(std::vector<Snapshot> one, List(1));
  if (one.empty()) return std::optional<Snapshot>();
  return std::optional<Snapshot>(std::move(one.front()));
}

absl::StatusOr<std::vector<Snapshot>> ConfigRepo::List(int limit) {
  if (limit < 1 || limit > kMaxListLimit) {
    return absl::InvalidArgumentError(
        absl::StrCat("config_snapshot.limit: ", limit, " is outside 1..", kMaxListLimit));
  }
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(kSelect));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, limit));
  std::vector<Snapshot> out;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadSnapshot(stmt));
  }
  return out;
}

}  // namespace drivegw::storage
