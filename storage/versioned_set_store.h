// The part ParameterSetRepo and CurveSetRepo share (decisions 410, 411): a set table whose row
// points at the newest of its immutable versions in a version table with one JSON payload column,
// optimistic concurrency by a random etag. Each repo keeps its own set columns and payload codec;
// this class only knows the table names, so both keep their public headers and migrations.
#pragma once

#include <chrono>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "storage/audit_log.h"
#include "storage/db.h"

namespace drivegw::storage::internal {

using SetTime = std::chrono::system_clock::time_point;

// Table and wording of one kind of versioned set. All literals: they are spliced into SQL.
struct VersionedSetNames {
  const char* sets_table;      // "parameter_sets": name, version, etag, ...
  const char* versions_table;  // "parameter_set_versions": set_name, version, author, ...
  const char* payload_column;  // "values_json" in versions_table
  const char* field;           // error field prefix: "parameter_set" -> "parameter_set.name: ..."
  const char* label_noun;      // etag/JSON errors: "set" -> "set 'x' is at version 4"
  const char* not_found_noun;  // "parameter set" -> "parameter set 'x' not found"
};

// One row of versions_table, payload still JSON (the repo decodes it with Label()+" version n").
struct VersionRow {
  int version = 0;
  std::string author;
  std::string comment;
  SetTime created_at{};
  std::string payload;
};

// The current version and etag of a set.
struct SetHead {
  int version = 0;
  std::string etag;
};

SetTime NowMs();  // UTC, floored to the millisecond the timestamps store
// 128 random bits as 32 hex digits: unguessable and different for every update, so a client
// holding an old etag can never match by accident (unlike a version number after delete+create).
std::string NewEtag();
// Rows are only written by the repos, so the text always parses; falls back to the epoch.
SetTime ReadTime(const Statement& stmt, int column);
// "<label_noun> 'name'", the row named in etag and stored-JSON errors: "set 'x'".
std::string SetLabel(const VersionedSetNames& names, std::string_view name);
// InvalidArgument "<field>: <limit> is outside 0..<max>".
absl::Status CheckLimit(int limit, int max, std::string_view field);

// Steps `stmt` to the end, `read` (Statement -> StatusOr<T>) turning each row into a T.
template <class T, class Read>
absl::StatusOr<std::vector<T>> ReadAll(Statement& stmt, const Read& read) {
  std::vector<T> out;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    DGW_ASSIGN_OR_RETURN(T t, read(stmt));
    out.push_back(std::move(t));
  }
  return out;
}

// The fields every version type has (version, author, comment, created_at); the repo decodes
// row.payload into its own member.
template <class V>
V VersionFields(const VersionRow& row) {
  V v;
  v.version = row.version;
  v.author = row.author;
  v.comment = row.comment;
  v.created_at = row.created_at;
  return v;
}

// Each row through `decode` (VersionRow -> StatusOr<V>), order kept; the first error wins.
template <class V, class Decode>
absl::StatusOr<std::vector<V>> DecodeVersions(const std::vector<VersionRow>& rows,
                                              const Decode& decode) {
  std::vector<V> out;
  out.reserve(rows.size());
  for (const VersionRow& row : rows) {
    DGW_ASSIGN_OR_RETURN(V v, decode(row));
    out.push_back(std::move(v));
  }
  return out;
}

class VersionedSetStore {
 public:
  VersionedSetStore(Db& db, const VersionedSetNames& names) : db_(&db), names_(names) {}

  // 1..128 chars of [A-Za-z0-9._-]; InvalidArgument naming "<field>.name".
  absl::Status ValidateName(std::string_view name) const;
  std::string Label(std::string_view name) const { return SetLabel(names_, name); }
  absl::Status NotFound(std::string_view name) const;  // "parameter set 'x' not found"

  // The caller holds Db::Lock() or is inside Db::Transaction().
  absl::StatusOr<SetHead> ReadHead(std::string_view name) const;  // NotFound if absent
  // InvalidArgument for an empty `expected` (updates and deletes are conditional),
  // FailedPrecondition "etag mismatch: ..." (HTTP 412) when it is not the current etag.
  absl::Status CheckEtag(const SetHead& head, std::string_view name,
                         std::string_view expected) const;
  absl::Status CheckNameFree(std::string_view name) const;  // AlreadyExists "<field>.name: ..."
  absl::Status InsertVersion(std::string_view name, int version, std::string_view author,
                             std::string_view comment, const std::string& ts,
                             const std::string& payload) const;

  // Whole operations, each in its own transaction or lock.
  // Version 1 of a new set in one transaction: AlreadyExists when the name is taken, then
  // `insert_row(ts, etag)` writes the repo's own set row (version 1, created_at = updated_at = ts),
  // then the version row. `get(name)` reads the result back inside the transaction, so the caller
  // gets this version, not a later writer's.
  template <class Set, class InsertRow, class Get>
  absl::StatusOr<Set> Create(std::string_view name, std::string_view author,
                             std::string_view comment, const std::string& payload,
                             const InsertRow& insert_row, const Get& get) const {
    const std::string ts = FormatTimestamp(NowMs());
    Set result;
    DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
      DGW_RETURN_IF_ERROR(CheckNameFree(name));
      DGW_RETURN_IF_ERROR(insert_row(ts, NewEtag()));
      DGW_RETURN_IF_ERROR(InsertVersion(name, 1, author, comment, ts, payload));
      DGW_ASSIGN_OR_RETURN(result, get(name));
      return absl::OkStatus();
    }));
    return result;
  }

  // The next version of `name` in one transaction: the etag rule of CheckEtag(), then
  // `update_row(ts, version, etag)` rewrites the repo's own set row (it may refuse first), then
  // the version row; `get(name)` reads the result back as in Create().
  template <class Set, class UpdateRow, class Get>
  absl::StatusOr<Set> Update(std::string_view name, std::string_view expected_etag,
                             std::string_view author, std::string_view comment,
                             const std::string& payload, const UpdateRow& update_row,
                             const Get& get) const {
    const std::string ts = FormatTimestamp(NowMs());
    Set result;
    DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
      // BEGIN IMMEDIATE holds the write lock from here, so the etag read and the write are
      // atomic even against another connection or process.
      DGW_ASSIGN_OR_RETURN(const SetHead head, ReadHead(name));
      DGW_RETURN_IF_ERROR(CheckEtag(head, name, expected_etag));
      const int version = head.version + 1;
      DGW_RETURN_IF_ERROR(update_row(ts, version, NewEtag()));
      DGW_RETURN_IF_ERROR(InsertVersion(name, version, author, comment, ts, payload));
      DGW_ASSIGN_OR_RETURN(result, get(name));
      return absl::OkStatus();
    }));
    return result;
  }

  // The row of `select` (a SELECT of the sets table aliased `s`) for `name`, read by `read`
  // (Statement -> StatusOr<Set>); NotFound naming the set.
  template <class Read>
  auto GetSet(const char* select, std::string_view name, const Read& read) const
      -> decltype(read(std::declval<const Statement&>())) {
    auto lock = db_->Lock();
    DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(absl::StrCat(select, " WHERE s.name = ?1")));
    DGW_RETURN_IF_ERROR(stmt.Bind(1, name));
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) return NotFound(name);
    return read(stmt);
  }
  absl::Status Delete(std::string_view name, std::string_view expected_etag) const;
  absl::StatusOr<std::vector<VersionRow>> ListVersions(std::string_view name) const;  // newest 1st
  absl::StatusOr<VersionRow> GetVersion(std::string_view name, int version) const;

 private:
  Db* db_;
  VersionedSetNames names_;
};

}  // namespace drivegw::storage::internal
