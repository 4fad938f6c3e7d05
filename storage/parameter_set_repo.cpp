// Parameter sets: one row per set pointing at its newest immutable version, optimistic
// concurrency by etag, apply operations with JSON per-drive results (decision 410).
#include "storage/parameter_set_repo.h"

#include <algorithm>
#include <charconv>
#include <unordered_map>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "storage/audit_log.h"
#include "storage/parameter_set_json.h"
#include "storage/versioned_set_store.h"

namespace drivegw::storage {
namespace {

using internal::NowMs;
using internal::ReadTime;

constexpr int kDefaultLimit = 100;
constexpr const char* kOpPrefix = "op-";
constexpr size_t kOpPrefixLength = 3;

// Migration 002; the wording is what clients and tests already see.
constexpr internal::VersionedSetNames kNames{
    "parameter_sets", "parameter_set_versions", "values_json", "parameter_set", "set",
    "parameter set"};

internal::VersionedSetStore Store(Db& db) { return internal::VersionedSetStore(db, kNames); }

std::string SetLabel(std::string_view name) { return internal::SetLabel(kNames, name); }

absl::Status ValidateValues(const std::vector<ParameterValue>& values) {
  std::unordered_map<std::string_view, size_t> seen;
  for (size_t i = 0; i < values.size(); ++i) {
    const std::string& p = values[i].parameter;
    if (p.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("parameter_set.values[", i, "].parameter: empty"));
    }
    const auto [it, inserted] = seen.emplace(p, i);
    if (!inserted) {
      return absl::InvalidArgumentError(absl::StrCat("parameter_set.values[", i, "].parameter: '",
                                                     p, "' is listed twice (values[", it->second,
                                                     "] and values[", i, "])"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateForWrite(const internal::VersionedSetStore& store, const ParameterSet& set) {
  DGW_RETURN_IF_ERROR(store.ValidateName(set.name));
  return ValidateValues(set.values);
}

absl::Status CheckLimit(int limit, std::string_view field) {
  return internal::CheckLimit(limit, ParameterSetQuery::kMaxLimit, field);
}

// The join of a set with its newest version; ReadSet() reads these columns in this order.
constexpr const char* kSetColumns =
    "SELECT s.name, s.family, s.model, s.description, s.target_stored, s.created_at, "
    "s.updated_at, s.version, s.etag, v.author, v.values_json FROM parameter_sets s "
    "JOIN parameter_set_versions v ON v.set_name = s.name AND v.version = s.version";

absl::StatusOr<ParameterSet> ReadSet(const Statement& stmt) {
  ParameterSet s;
  s.name = stmt.ColumnText(0);
  s.family = stmt.ColumnText(1);
  s.model = stmt.ColumnText(2);
  s.description = stmt.ColumnText(3);
  s.target_stored = stmt.ColumnInt(4) != 0;
  s.created_at = ReadTime(stmt, 5);
  s.updated_at = ReadTime(stmt, 6);
  s.version = stmt.ColumnInt(7);
  s.etag = stmt.ColumnText(8);
  s.author = stmt.ColumnText(9);
  DGW_ASSIGN_OR_RETURN(
      s.values,
      ValuesFromJson(stmt.ColumnText(10), absl::StrCat(SetLabel(s.name), " version ", s.version)));
  return s;
}

absl::StatusOr<ParameterSetVersion> DecodeVersion(const internal::VersionRow& row,
                                                  std::string_view name) {
  auto v = internal::VersionFields<ParameterSetVersion>(row);
  DGW_ASSIGN_OR_RETURN(
      v.values, ValuesFromJson(row.payload, absl::StrCat(SetLabel(name), " version ", v.version)));
  return v;
}

constexpr const char* kOpColumns =
    "SELECT id, set_name, set_version, dry_run, state, principal, created_at, updated_at, "
    "drives_json, target_stored, restores FROM apply_operations";

absl::StatusOr<ApplyOperation> ReadOperation(const Statement& stmt) {
  ApplyOperation op;
  op.id = absl::StrCat(kOpPrefix, stmt.ColumnInt64(0));
  op.set_name = stmt.ColumnText(1);
  op.set_version = stmt.ColumnInt(2);
  op.dry_run = stmt.ColumnInt(3) != 0;
  op.state = stmt.ColumnText(4);
  op.principal = stmt.ColumnText(5);
  op.created_at = ReadTime(stmt, 6);
  op.updated_at = ReadTime(stmt, 7);
  DGW_ASSIGN_OR_RETURN(op.drives,
                       DrivesFromJson(stmt.ColumnText(8), absl::StrCat("operation ", op.id)));
  op.target_stored = stmt.ColumnInt(9) != 0;
  op.restores = stmt.ColumnText(10);
  return op;
}

absl::Status ValidateOperation(const ApplyOperation& op) {
  static constexpr std::string_view kStates[] = {"RUNNING", "SUCCEEDED", "FAILED",
                                                 "FAILED_ROLLBACK", "INTERRUPTED"};
  static constexpr std::string_view kDriveStates[] = {"PENDING",     "APPLYING",        "APPLIED",
                                                      "ROLLED_BACK", "ROLLBACK_FAILED", "UNCHANGED",
                                                      "INTERRUPTED"};
  if (op.set_name.empty()) return absl::InvalidArgumentError("apply_operation.set_name: empty");
  if (op.set_version < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("apply_operation.set_version: ", op.set_version, " is negative"));
  }
  if (std::find(std::begin(kStates), std::end(kStates), op.state) == std::end(kStates)) {
    return absl::InvalidArgumentError(
        absl::StrCat("apply_operation.state: '", op.state,
                     "' is not RUNNING, SUCCEEDED, FAILED, FAILED_ROLLBACK or INTERRUPTED"));
  }
  for (size_t i = 0; i < op.drives.size(); ++i) {
    const std::string& s = op.drives[i].state;
    if (std::find(std::begin(kDriveStates), std::end(kDriveStates), s) == std::end(kDriveStates)) {
      return absl::InvalidArgumentError(
          absl::StrCat("apply_operation.drives[", i, "].state: '", s,
                       "' is not PENDING, APPLYING, APPLIED, ROLLED_BACK, ROLLBACK_FAILED, "
                       "UNCHANGED or INTERRUPTED"));
    }
  }
  if (!op.restores.empty() && !absl::StartsWith(op.restores, kOpPrefix)) {
    return absl::InvalidArgumentError(
        absl::StrCat("apply_operation.restores: '", op.restores, "' is not an operation id"));
  }
  return absl::OkStatus();
}

// "op-12" -> 12; NotFound for anything else (an id we never issued cannot exist).
absl::StatusOr<int64_t> ParseOpId(std::string_view id) {
  int64_t n = 0;
  if (id.substr(0, kOpPrefixLength) == kOpPrefix) {
    const char* begin = id.data() + kOpPrefixLength;
    const char* end = id.data() + id.size();
    const auto [ptr, ec] = std::from_chars(begin, end, n);
    if (ec == std::errc() && ptr == end && begin != end && n > 0) return n;
  }
  return absl::NotFoundError(
      absl::StrCat("apply operation '", std::string(id), "' not found (ids are op-<n>)"));
}

}  // namespace

absl::StatusOr<ParameterSet> ParameterSetRepo::Create(const ParameterSet& set,
                                                      std::string_view comment) {
  const internal::VersionedSetStore store = Store(*db_);
  DGW_RETURN_IF_ERROR(ValidateForWrite(store, set));
  if (set.family.empty()) return absl::InvalidArgumentError("parameter_set.family: empty");
  DGW_ASSIGN_OR_RETURN(const std::string values_json, ValuesToJson(set.values));
  const auto insert_row = [&](const std::string& ts, const std::string& etag) -> absl::Status {
    DGW_ASSIGN_OR_RETURN(
        Statement insert,
        db_->Prepare("INSERT INTO parameter_sets (name, family, model, description, "
                     "target_stored, created_at, updated_at, version, etag) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?6, 1, ?7)"));
    DGW_RETURN_IF_ERROR(insert.Bind(1, std::string_view(set.name)));
    DGW_RETURN_IF_ERROR(insert.Bind(2, std::string_view(set.family)));
    DGW_RETURN_IF_ERROR(insert.Bind(3, std::string_view(set.model)));
    DGW_RETURN_IF_ERROR(insert.Bind(4, std::string_view(set.description)));
    DGW_RETURN_IF_ERROR(insert.Bind(5, set.target_stored ? 1 : 0));
    DGW_RETURN_IF_ERROR(insert.Bind(6, std::string_view(ts)));
    DGW_RETURN_IF_ERROR(insert.Bind(7, std::string_view(etag)));
    return insert.Run();
  };
  return store.Create<ParameterSet>(set.name, set.author, comment, values_json, insert_row,
                                    [this](std::string_view name) { return Get(name); });
}

absl::StatusOr<ParameterSet> ParameterSetRepo::Get(std::string_view name) {
  return Store(*db_).GetSet(kSetColumns, name, ReadSet);
}

absl::StatusOr<std::vector<ParameterSet>> ParameterSetRepo::List(const ParameterSetQuery& query) {
  DGW_RETURN_IF_ERROR(CheckLimit(query.limit, "parameter_set_query.limit"));
  const int limit = query.limit == 0 ? kDefaultLimit : query.limit;
  std::string sql(kSetColumns);
  const char* glue = " WHERE ";
  int next = 1;
  int family_index = 0, after_index = 0;
  if (query.family) {
    absl::StrAppend(&sql, glue, "s.family = ?", family_index = next++);
    glue = " AND ";
  }
  if (query.after_name) absl::StrAppend(&sql, glue, "s.name > ?", after_index = next++);
  // BINARY collation: byte order, the same order clients see and page by.
  absl::StrAppend(&sql, " ORDER BY s.name LIMIT ?", next);

  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(sql));
  if (family_index) DGW_RETURN_IF_ERROR(stmt.Bind(family_index, std::string_view(*query.family)));
  if (after_index) DGW_RETURN_IF_ERROR(stmt.Bind(after_index, std::string_view(*query.after_name)));
  DGW_RETURN_IF_ERROR(stmt.Bind(next, limit));
  return internal::ReadAll<ParameterSet>(stmt, ReadSet);
}

absl::StatusOr<ParameterSet> ParameterSetRepo::Update(const ParameterSet& set,
                                                      std::string_view expected_etag,
                                                      std::string_view comment) {
  const internal::VersionedSetStore store = Store(*db_);
  DGW_RETURN_IF_ERROR(ValidateForWrite(store, set));
  DGW_ASSIGN_OR_RETURN(const std::string values_json, ValuesToJson(set.values));
  const auto update_row = [&](const std::string& ts, int version,
                              const std::string& etag) -> absl::Status {
    DGW_ASSIGN_OR_RETURN(Statement family,
                         db_->Prepare("SELECT family FROM parameter_sets WHERE name = ?1"));
    DGW_RETURN_IF_ERROR(family.Bind(1, std::string_view(set.name)));
    DGW_ASSIGN_OR_RETURN(const bool row, family.Step());
    // The values were checked against the family's catalogue: a set never changes family.
    if (row && !set.family.empty() && family.ColumnText(0) != set.family) {
      return absl::InvalidArgumentError(absl::StrCat("parameter_set.family: '", set.family,
                                                     "' differs from ", SetLabel(set.name),
                                                     "'s family '", family.ColumnText(0), "'"));
    }
    DGW_ASSIGN_OR_RETURN(
        Statement update,
        db_->Prepare("UPDATE parameter_sets SET model = ?2, description = ?3, target_stored = ?4, "
                     "updated_at = ?5, version = ?6, etag = ?7 WHERE name = ?1"));
    DGW_RETURN_IF_ERROR(update.Bind(1, std::string_view(set.name)));
    DGW_RETURN_IF_ERROR(update.Bind(2, std::string_view(set.model)));
    DGW_RETURN_IF_ERROR(update.Bind(3, std::string_view(set.description)));
    DGW_RETURN_IF_ERROR(update.Bind(4, set.target_stored ? 1 : 0));
    DGW_RETURN_IF_ERROR(update.Bind(5, std::string_view(ts)));
    DGW_RETURN_IF_ERROR(update.Bind(6, version));
    DGW_RETURN_IF_ERROR(update.Bind(7, std::string_view(etag)));
    return update.Run();
  };
  return store.Update<ParameterSet>(set.name, expected_etag, set.author, comment, values_json,
                                    update_row,
                                    [this](std::string_view name) { return Get(name); });
}

absl::Status ParameterSetRepo::Delete(std::string_view name, std::string_view expected_etag) {
  // apply_operations have no foreign key to the set and keep their copy.
  return Store(*db_).Delete(name, expected_etag);
}

absl::StatusOr<std::vector<ParameterSetVersion>> ParameterSetRepo::ListVersions(
    std::string_view name) {
  DGW_ASSIGN_OR_RETURN(const std::vector<internal::VersionRow> rows,
                       Store(*db_).ListVersions(name));
  return internal::DecodeVersions<ParameterSetVersion>(
      rows, [&](const internal::VersionRow& row) { return DecodeVersion(row, name); });
}

absl::StatusOr<ParameterSetVersion> ParameterSetRepo::GetVersion(std::string_view name,
                                                                 int version) {
  DGW_ASSIGN_OR_RETURN(const internal::VersionRow row, Store(*db_).GetVersion(name, version));
  return DecodeVersion(row, name);
}

absl::StatusOr<ApplyOperation> ParameterSetRepo::CreateOperation(const ApplyOperation& op) {
  ApplyOperation stored = op;
  if (stored.state.empty()) stored.state = "RUNNING";
  DGW_RETURN_IF_ERROR(ValidateOperation(stored));
  DGW_ASSIGN_OR_RETURN(const std::string drives_json, DrivesToJson(stored.drives));
  stored.created_at = stored.updated_at = NowMs();
  const std::string ts = FormatTimestamp(stored.created_at);
  DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
    DGW_ASSIGN_OR_RETURN(
        Statement insert,
        db_->Prepare("INSERT INTO apply_operations (set_name, set_version, dry_run, state, "
                     "principal, created_at, updated_at, drives_json, target_stored, restores) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?6, ?7, ?8, ?9)"));
    DGW_RETURN_IF_ERROR(insert.Bind(1, std::string_view(stored.set_name)));
    DGW_RETURN_IF_ERROR(insert.Bind(2, stored.set_version));
    DGW_RETURN_IF_ERROR(insert.Bind(3, stored.dry_run ? 1 : 0));
    DGW_RETURN_IF_ERROR(insert.Bind(4, std::string_view(stored.state)));
    DGW_RETURN_IF_ERROR(insert.Bind(5, std::string_view(stored.principal)));
    DGW_RETURN_IF_ERROR(insert.Bind(6, std::string_view(ts)));
    DGW_RETURN_IF_ERROR(insert.Bind(7, std::string_view(drives_json)));
    DGW_RETURN_IF_ERROR(insert.Bind(8, stored.target_stored ? 1 : 0));
    DGW_RETURN_IF_ERROR(insert.Bind(9, std::string_view(stored.restores)));
    DGW_RETURN_IF_ERROR(insert.Run());
    // Still under the transaction's lock: the rowid is this INSERT's.
    stored.id = absl::StrCat(kOpPrefix, db_->LastInsertRowId());
    return absl::OkStatus();
  }));
  return stored;
}

absl::Status ParameterSetRepo::UpdateOperation(const ApplyOperation& op) {
  DGW_ASSIGN_OR_RETURN(const int64_t id, ParseOpId(op.id));
  DGW_RETURN_IF_ERROR(ValidateOperation(op));
  DGW_ASSIGN_OR_RETURN(const std::string drives_json, DrivesToJson(op.drives));
  const std::string ts = FormatTimestamp(NowMs());
  return db_->Transaction([&]() -> absl::Status {
    DGW_ASSIGN_OR_RETURN(
        Statement read,
        db_->Prepare("SELECT set_name, set_version, dry_run FROM apply_operations WHERE id = ?1"));
    DGW_RETURN_IF_ERROR(read.Bind(1, id));
    DGW_ASSIGN_OR_RETURN(const bool row, read.Step());
    if (!row) return absl::NotFoundError(absl::StrCat("apply operation '", op.id, "' not found"));
    // What the operation applies is fixed at creation (a trigger also enforces it).
    if (read.ColumnText(0) != op.set_name || read.ColumnInt(1) != op.set_version ||
        (read.ColumnInt(2) != 0) != op.dry_run) {
      return absl::InvalidArgumentError(
          absl::StrCat("apply_operation: ", op.id, " applies set '", read.ColumnText(0),
                       "' version ", read.ColumnInt(1), read.ColumnInt(2) != 0 ? " (dry run)" : "",
                       "; set_name, set_version and dry_run cannot change"));
    }
    DGW_ASSIGN_OR_RETURN(Statement update,
                         db_->Prepare("UPDATE apply_operations SET state = ?2, drives_json = ?3, "
                                      "updated_at = ?4 WHERE id = ?1"));
    DGW_RETURN_IF_ERROR(update.Bind(1, id));
    DGW_RETURN_IF_ERROR(update.Bind(2, std::string_view(op.state)));
    DGW_RETURN_IF_ERROR(update.Bind(3, std::string_view(drives_json)));
    DGW_RETURN_IF_ERROR(update.Bind(4, std::string_view(ts)));
    return update.Run();
  });
}

absl::StatusOr<ApplyOperation> ParameterSetRepo::GetOperation(std::string_view id) {
  DGW_ASSIGN_OR_RETURN(const int64_t n, ParseOpId(id));
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(absl::StrCat(kOpColumns, " WHERE id = ?1")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, n));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat("apply operation '", std::string(id), "' not found"));
  }
  return ReadOperation(stmt);
}

absl::StatusOr<std::vector<ApplyOperation>> ParameterSetRepo::ListOperations(int limit) {
  DGW_RETURN_IF_ERROR(CheckLimit(limit, "apply_operations.limit"));
  auto lock = db_->Lock();
  // By id, not created_at: the wall clock can step back (decision 404).
  DGW_ASSIGN_OR_RETURN(Statement stmt,
                       db_->Prepare(absl::StrCat(kOpColumns, " ORDER BY id DESC LIMIT ?1")));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, limit == 0 ? kDefaultLimit : limit));
  return internal::ReadAll<ApplyOperation>(stmt, ReadOperation);
}

absl::StatusOr<std::vector<ApplyOperation>> ParameterSetRepo::InterruptRunning(
    std::string_view reason) {
  std::vector<ApplyOperation> out;
  const Time now = NowMs();
  const std::string ts = FormatTimestamp(now);
  DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
    out.clear();
    DGW_ASSIGN_OR_RETURN(
        Statement select,
        db_->Prepare(absl::StrCat(kOpColumns, " WHERE state = 'RUNNING' ORDER BY id")));
    DGW_ASSIGN_OR_RETURN(out, internal::ReadAll<ApplyOperation>(select, ReadOperation));
    for (ApplyOperation& op : out) {
      op.state = "INTERRUPTED";
      for (ApplyDriveResult& d : op.drives) {
        // PENDING drives were never touched; APPLYING ones may hold some of the set's values.
        if (d.state != "APPLYING") continue;
        d.state = "INTERRUPTED";
        d.error = std::string(reason);
      }
      DGW_ASSIGN_OR_RETURN(const std::string drives_json, DrivesToJson(op.drives));
      DGW_ASSIGN_OR_RETURN(Statement update,
                           db_->Prepare("UPDATE apply_operations SET state = 'INTERRUPTED', "
                                        "drives_json = ?2, updated_at = ?3 WHERE id = ?1"));
      DGW_ASSIGN_OR_RETURN(const int64_t id, ParseOpId(op.id));
      DGW_RETURN_IF_ERROR(update.Bind(1, id));
      DGW_RETURN_IF_ERROR(update.Bind(2, std::string_view(drives_json)));
      DGW_RETURN_IF_ERROR(update.Bind(3, std::string_view(ts)));
      DGW_RETURN_IF_ERROR(update.Run());
      op.updated_at = now;
    }
    return absl::OkStatus();
  }));
  return out;
}

}  // namespace drivegw::storage
