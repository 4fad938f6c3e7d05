// Schema migrations: numbered storage/migrations/NNN_*.sql files embedded at build time.
#pragma once

#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/db.h"

namespace drivegw::storage {

struct Migration {
  int version;            // NNN from the file name
  std::string_view name;  // file name, e.g. "001_initial.sql"
  std::string_view sql;   // file contents, verbatim
};

// All embedded migrations, ascending by version (generated from storage/migrations/*.sql).
const std::vector<Migration>& Migrations();
// The schema version this build writes: the highest embedded migration.
int LatestSchemaVersion();
// PRAGMA user_version of `db`.
absl::StatusOr<int> SchemaVersion(Db& db);

// Applies every migration newer than PRAGMA user_version, each in its own transaction that also
// bumps user_version. Idempotent. A database newer than this build is refused
// (FailedPrecondition naming both versions) and left untouched.
absl::Status Migrate(Db& db);

}  // namespace drivegw::storage
