// Audit log: cached-statement appends, filtered newest-first queries, ISO-8601 timestamps.
#include "storage/audit_log.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"

namespace drivegw::storage {
namespace {

using std::chrono::days;
using std::chrono::milliseconds;
using std::chrono::system_clock;

constexpr int kDefaultLimit = 100;

bool ParseDigits(std::string_view text, size_t pos, size_t count, int& out) {
  if (pos + count > text.size()) return false;
  out = 0;
  for (size_t i = pos; i < pos + count; ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
    out = out * 10 + (text[i] - '0');
  }
  return true;
}

AuditRecord ReadRecord(const Statement& stmt) {
  AuditRecord r;
  r.id = stmt.ColumnInt64(0);
  // Rows are only written by Append, so the text always parses; fall back to the epoch.
  r.time = ParseTimestamp(stmt.ColumnText(1)).value_or(system_clock::time_point{});
  r.principal = stmt.ColumnText(2);
  r.source_address = stmt.ColumnText(3);
  r.drive = stmt.ColumnText(4);
  r.action = stmt.ColumnText(5);
  r.request_json = stmt.ColumnText(6);
  r.result_code = stmt.ColumnInt(7);
  r.result_message = stmt.ColumnText(8);
  return r;
}

}  // namespace

std::string FormatTimestamp(system_clock::time_point time) {
  using namespace std::chrono;
  // Clamp to years 0000..9999 so the text stays fixed width (and ordered).
  constexpr sys_days kMin = year{0} / January / 1;
  constexpr sys_days kMax = year{10000} / January / 1;
  auto ms = floor<milliseconds>(time);
  ms = std::clamp(ms, time_point_cast<milliseconds>(kMin),
                  time_point_cast<milliseconds>(kMax) - milliseconds{1});
  const sys_days day = floor<days>(ms);
  const year_month_day ymd(day);
  const hh_mm_ss hms(ms - day);
  return absl::StrFormat(
      "%04d-%02u-%02uT%02d:%02d:%02d.%03dZ", static_cast<int>(ymd.year()),
      static_cast<unsigned>(ymd.month()), static_cast<unsigned>(ymd.day()),
      static_cast<int>(hms.hours().count()), static_cast<int>(hms.minutes().count()),
      static_cast<int>(hms.seconds().count()), static_cast<int>(hms.subseconds().count()));
}

absl::StatusOr<system_clock::time_point> ParseTimestamp(std::string_view text) {
  using namespace std::chrono;
  // "YYYY-MM-DDTHH:MM:SS.mmmZ" or without ".mmm".
  int y, mo, d, h, mi, s, frac = 0;
  bool ok = ParseDigits(text, 0, 4, y) && text.size() > 4 && text[4] == '-' &&
            ParseDigits(text, 5, 2, mo) && text.size() > 7 && text[7] == '-' &&
            ParseDigits(text, 8, 2, d) && text.size() > 10 && text[10] == 'T' &&
            ParseDigits(text, 11, 2, h) && text.size() > 13 && text[13] == ':' &&
            ParseDigits(text, 14, 2, mi) && text.size() > 16 && text[16] == ':' &&
            ParseDigits(text, 17, 2, s);
  if (ok) {
    if (text.size() == 24 && text[19] == '.' && text[23] == 'Z') {
      ok = ParseDigits(text, 20, 3, frac);
    } else {
      ok = text.size() == 20 && text[19] == 'Z';
    }
  }
  const year_month_day ymd{year{ok ? y : 0}, month{ok ? static_cast<unsigned>(mo) : 1u},
                           day{ok ? static_cast<unsigned>(d) : 1u}};
  if (!ok || !ymd.ok() || h > 23 || mi > 59 || s > 59) {
    return absl::InvalidArgumentError(absl::StrCat(
        "timestamp: '", std::string(text), "' is not UTC ISO-8601 (YYYY-MM-DDTHH:MM:SS.mmmZ)"));
  }
  return sys_days(ymd) + hours{h} + minutes{mi} + seconds{s} + milliseconds{frac};
}

absl::Status AuditLog::Append(const AuditEntry& entry) {
  auto lock = db_->Lock();
  if (!insert_.valid()) {
    DGW_ASSIGN_OR_RETURN(
        insert_,
        db_->Prepare("INSERT INTO audit_log (ts, principal, source_address, drive, action, "
                     "request_json, result_code, result_message) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)"));
  }
  absl::Status status = [&]() -> absl::Status {
    DGW_RETURN_IF_ERROR(insert_.Bind(1, FormatTimestamp(entry.time)));
    DGW_RETURN_IF_ERROR(insert_.Bind(2, std::string_view(entry.principal)));
    DGW_RETURN_IF_ERROR(insert_.Bind(3, std::string_view(entry.source_address)));
    DGW_RETURN_IF_ERROR(insert_.Bind(4, std::string_view(entry.drive)));
    DGW_RETURN_IF_ERROR(insert_.Bind(5, std::string_view(entry.action)));
    DGW_RETURN_IF_ERROR(insert_.Bind(6, std::string_view(entry.request_json)));
    DGW_RETURN_IF_ERROR(insert_.Bind(7, entry.result_code));
    DGW_RETURN_IF_ERROR(insert_.Bind(8, std::string_view(entry.result_message)));
    return insert_.Run();
  }();
  // Reset also drops the bound copies of request_json; keep the statement either way.
  insert_.Reset().IgnoreError();
  return status;
}

absl::StatusOr<std::vector<AuditRecord>> AuditLog::Query(const AuditQuery& query) {
  if (query.limit < 0 || query.limit > AuditQuery::kMaxLimit) {
    return absl::InvalidArgumentError(
        absl::StrCat("audit_query.limit: ", query.limit, " is outside 0..", AuditQuery::kMaxLimit));
  }
  const int limit = query.limit == 0 ? kDefaultLimit : query.limit;
  std::string sql =
      "SELECT id, ts, principal, source_address, drive, action, request_json, result_code, "
      "result_message FROM audit_log";
  const char* glue = " WHERE ";
  int next = 1;
  int drive_index = 0, action_index = 0, since_index = 0, before_index = 0;
  if (query.drive) {
    absl::StrAppend(&sql, glue, "drive = ?", drive_index = next++);
    glue = " AND ";
  }
  if (query.action) {
    absl::StrAppend(&sql, glue, "action = ?", action_index = next++);
    glue = " AND ";
  }
  if (query.since) {
    absl::StrAppend(&sql, glue, "ts >= ?", since_index = next++);
    glue = " AND ";
  }
  if (query.before_id) {
    absl::StrAppend(&sql, glue, "id < ?", before_index = next++);
  }
  absl::StrAppend(&sql, " ORDER BY id DESC LIMIT ?", next);

  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(sql));
  if (drive_index) DGW_RETURN_IF_ERROR(stmt.Bind(drive_index, std::string_view(*query.drive)));
  if (action_index) DGW_RETURN_IF_ERROR(stmt.Bind(action_index, std::string_view(*query.action)));
  if (since_index) DGW_RETURN_IF_ERROR(stmt.Bind(since_index, FormatTimestamp(*query.since)));
  if (before_index) DGW_RETURN_IF_ERROR(stmt.Bind(before_index, *query.before_id));
  DGW_RETURN_IF_ERROR(stmt.Bind(next, limit));
  std::vector<AuditRecord> out;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadRecord(stmt));
  }
  return out;
}

absl::StatusOr<int64_t> AuditLog::Count() {
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare("SELECT COUNT(*) FROM audit_log"));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return absl::InternalError("storage: SELECT COUNT(*) returned no row");
  return stmt.ColumnInt64(0);
}

}  // namespace drivegw::storage
