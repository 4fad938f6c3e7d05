// Applies the embedded NNN_*.sql migrations above PRAGMA user_version, one transaction each.
#include "storage/migrations.h"

#include <algorithm>
#include <cstdlib>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "storage/migrations_embedded.h"

namespace drivegw::storage {
namespace {

std::vector<Migration> LoadEmbedded() {
  std::vector<Migration> out;
  for (int i = 0; i < internal::kEmbeddedMigrationCount; ++i) {
    const auto& m = internal::kEmbeddedMigrations[i];
    // embed_migrations.cmake guarantees the NNN_ prefix.
    out.push_back({std::atoi(m.name), m.name, m.sql});
  }
  std::sort(out.begin(), out.end(),
            [](const Migration& a, const Migration& b) { return a.version < b.version; });
  return out;
}

// Versions must run 1, 2, 3, ... so user_version alone says which files were applied.
absl::Status CheckSequence(const std::vector<Migration>& migrations) {
  for (size_t i = 0; i < migrations.size(); ++i) {
    if (migrations[i].version != static_cast<int>(i) + 1) {
      return absl::InternalError(absl::StrCat("storage.migrate: ", std::string(migrations[i].name),
                                              " has version ", migrations[i].version, ", want ",
                                              i + 1, " (versions must be 1, 2, 3, ...)"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

const std::vector<Migration>& Migrations() {
  static const std::vector<Migration> migrations = LoadEmbedded();
  return migrations;
}

int LatestSchemaVersion() { return Migrations().empty() ? 0 : Migrations().back().version; }

absl::StatusOr<int> SchemaVersion(Db& db) {
  auto lock = db.Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db.Prepare("PRAGMA user_version"));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return absl::InternalError("storage: PRAGMA user_version returned no row");
  return stmt.ColumnInt(0);
}

absl::Status Migrate(Db& db) {
  const auto& migrations = Migrations();
  DGW_RETURN_IF_ERROR(CheckSequence(migrations));
  const int latest = LatestSchemaVersion();
  for (const Migration& m : migrations) {
    bool applied = false;
    // The version is re-read inside the IMMEDIATE transaction, so two processes migrating the
    // same file at once apply each step exactly once.
    DGW_RETURN_IF_ERROR(db.Transaction([&]() -> absl::Status {
      DGW_ASSIGN_OR_RETURN(const int current, SchemaVersion(db));
      if (current > latest) {
        return absl::FailedPreconditionError(absl::StrCat(
            "storage.migrate: database schema version ", current,
            " is newer than this build's schema version ", latest, " (path=", db.path(), ")"));
      }
      if (current >= m.version) return absl::OkStatus();
      if (absl::Status s = db.Exec(m.sql); !s.ok()) {
        return absl::Status(
            s.code(), absl::StrCat("storage.migrate: ", std::string(m.name), ": ", s.message()));
      }
      DGW_RETURN_IF_ERROR(db.Exec(absl::StrCat("PRAGMA user_version=", m.version)));
      applied = true;
      return absl::OkStatus();
    }));
    if (applied) {
      log::Info("storage.migrated", log::Fields().Add("path", db.path()).Add("file", m.name));
    }
  }
  // With no migrations at all the loop never checked the stored version.
  if (migrations.empty()) {
    DGW_ASSIGN_OR_RETURN(const int current, SchemaVersion(db));
    if (current > 0) {
      return absl::FailedPreconditionError(
          absl::StrCat("storage.migrate: database schema version ", current,
                       " is newer than this build's schema version 0 (path=", db.path(), ")"));
    }
  }
  return absl::OkStatus();
}

}  // namespace drivegw::storage
