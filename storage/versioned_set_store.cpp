// Shared flow of the versioned set repos (decisions 410, 411); see versioned_set_store.h.
#include "storage/versioned_set_store.h"

#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"
#include "storage/audit_log.h"

namespace drivegw::storage::internal {
namespace {

constexpr size_t kMaxNameLength = 128;

VersionRow ReadVersionRow(const Statement& stmt) {
  return VersionRow{stmt.ColumnInt(0), stmt.ColumnText(1), stmt.ColumnText(2), ReadTime(stmt, 3),
                    stmt.ColumnText(4)};
}

}  // namespace

SetTime NowMs() {
  return std::chrono::floor<std::chrono::milliseconds>(std::chrono::system_clock::now());
}

std::string NewEtag() {
  thread_local std::mt19937_64 engine{[] {
    std::random_device rd;
    std::seed_seq seq{rd(), rd(), rd(), rd(), rd(), rd(), rd(), rd()};
    return std::mt19937_64(seq);
  }()};
  return absl::StrFormat("%016x%016x", engine(), engine());
}

SetTime ReadTime(const Statement& stmt, int column) {
  return ParseTimestamp(stmt.ColumnText(column)).value_or(SetTime{});
}

absl::Status CheckLimit(int limit, int max, std::string_view field) {
  if (limit < 0 || limit > max) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(field), ": ", limit, " is outside 0..", max));
  }
  return absl::OkStatus();
}

absl::Status VersionedSetStore::ValidateName(std::string_view name) const {
  if (name.empty() || name.size() > kMaxNameLength) {
    return absl::InvalidArgumentError(absl::StrCat(names_.field, ".name: length ", name.size(),
                                                   " is outside 1..", kMaxNameLength));
  }
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat(names_.field, ".name: '", std::string(name),
                                                     "' has a character outside ",
                                                     "[A-Za-z0-9._-] at index ", i));
    }
  }
  return absl::OkStatus();
}

std::string SetLabel(const VersionedSetNames& names, std::string_view name) {
  return absl::StrCat(names.label_noun, " '", std::string(name), "'");
}

absl::Status VersionedSetStore::NotFound(std::string_view name) const {
  return absl::NotFoundError(
      absl::StrCat(names_.not_found_noun, " '", std::string(name), "' not found"));
}

absl::StatusOr<SetHead> VersionedSetStore::ReadHead(std::string_view name) const {
  DGW_ASSIGN_OR_RETURN(Statement stmt,
                       db_->Prepare(absl::StrCat("SELECT version, etag FROM ", names_.sets_table,
                                                 " WHERE name = ?1")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, name));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return NotFound(name);
  return SetHead{stmt.ColumnInt(0), stmt.ColumnText(1)};
}

absl::Status VersionedSetStore::CheckEtag(const SetHead& head, std::string_view name,
                                          std::string_view expected) const {
  if (expected.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("etag: empty for ", Label(name), " (updates and deletes are conditional)"));
  }
  if (head.etag != expected) {
    // HTTP 412: the client read an older version; it must re-read and retry.
    return absl::FailedPreconditionError(
        absl::StrCat("etag mismatch: ", Label(name), " is at version ", head.version));
  }
  return absl::OkStatus();
}

absl::Status VersionedSetStore::CheckNameFree(std::string_view name) const {
  DGW_ASSIGN_OR_RETURN(
      Statement exists,
      db_->Prepare(absl::StrCat("SELECT 1 FROM ", names_.sets_table, " WHERE name = ?1")));
  DGW_RETURN_IF_ERROR(exists.Bind(1, name));
  DGW_ASSIGN_OR_RETURN(const bool taken, exists.Step());
  if (taken) {
    return absl::AlreadyExistsError(
        absl::StrCat(names_.field, ".name: '", std::string(name), "' already exists"));
  }
  return absl::OkStatus();
}

absl::Status VersionedSetStore::InsertVersion(std::string_view name, int version,
                                              std::string_view author, std::string_view comment,
                                              const std::string& ts,
                                              const std::string& payload) const {
  DGW_ASSIGN_OR_RETURN(
      Statement stmt,
      db_->Prepare(absl::StrCat("INSERT INTO ", names_.versions_table,
                                " (set_name, version, author, comment, created_at, ",
                                names_.payload_column, ") VALUES (?1, ?2, ?3, ?4, ?5, ?6)")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, name));
  DGW_RETURN_IF_ERROR(stmt.Bind(2, version));
  DGW_RETURN_IF_ERROR(stmt.Bind(3, author));
  DGW_RETURN_IF_ERROR(stmt.Bind(4, comment));
  DGW_RETURN_IF_ERROR(stmt.Bind(5, std::string_view(ts)));
  DGW_RETURN_IF_ERROR(stmt.Bind(6, std::string_view(payload)));
  return stmt.Run();
}

absl::Status VersionedSetStore::Delete(std::string_view name,
                                       std::string_view expected_etag) const {
  return db_->Transaction([&]() -> absl::Status {
    DGW_ASSIGN_OR_RETURN(const SetHead head, ReadHead(name));
    DGW_RETURN_IF_ERROR(CheckEtag(head, name, expected_etag));
    // ON DELETE CASCADE removes the versions (migrations 002/003; the versions' no-delete trigger
    // lets the cascade pass). apply_operations have no foreign key and stay.
    DGW_ASSIGN_OR_RETURN(Statement del, db_->Prepare(absl::StrCat("DELETE FROM ", names_.sets_table,
                                                                  " WHERE name = ?1")));
    DGW_RETURN_IF_ERROR(del.Bind(1, name));
    return del.Run();
  });
}

absl::StatusOr<std::vector<VersionRow>> VersionedSetStore::ListVersions(
    std::string_view name) const {
  auto lock = db_->Lock();
  DGW_RETURN_IF_ERROR(ReadHead(name).status());  // NotFound for an unknown set
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(absl::StrCat(
                                           "SELECT version, author, comment, created_at, ",
                                           names_.payload_column, " FROM ", names_.versions_table,
                                           " WHERE set_name = ?1 ORDER BY version DESC")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, name));
  return ReadAll<VersionRow>(
      stmt, [](const Statement& row) -> absl::StatusOr<VersionRow> { return ReadVersionRow(row); });
}

absl::StatusOr<VersionRow> VersionedSetStore::GetVersion(std::string_view name, int version) const {
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(const SetHead head, ReadHead(name));
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(absl::StrCat(
                                           "SELECT version, author, comment, created_at, ",
                                           names_.payload_column, " FROM ", names_.versions_table,
                                           " WHERE set_name = ?1 AND version = ?2")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, name));
  DGW_RETURN_IF_ERROR(stmt.Bind(2, version));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat(names_.not_found_noun, " '", std::string(name),
                                            "' has no version ", version, " (versions 1..",
                                            head.version, ")"));
  }
  return ReadVersionRow(stmt);
}

}  // namespace drivegw::storage::internal
