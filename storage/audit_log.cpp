// Audit log: chained appends (genesis anchor, retention), filtered queries, ISO-8601 timestamps.
// The chain, the anchors and the pruning path are decision 017.
#include "storage/audit_log.h"

#include <algorithm>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "nlohmann/json.hpp"
#include "storage/audit_log_hash.h"
#include "storage/audit_log_row.h"

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

// One scalar of a one-row SELECT; `fallback` when it returned no row or NULL.
absl::StatusOr<int64_t> ScalarInt(Db& db, std::string_view sql, int64_t fallback,
                                  std::string_view bind_text = {}) {
  DGW_ASSIGN_OR_RETURN(Statement stmt, db.Prepare(sql));
  if (!bind_text.empty()) DGW_RETURN_IF_ERROR(stmt.Bind(1, bind_text));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row || stmt.ColumnIsNull(0)) return fallback;
  return stmt.ColumnInt64(0);
}

AuditEntry SystemEntry(system_clock::time_point time, std::string_view action,
                       std::string request_json, std::string message) {
  AuditEntry e;
  e.time = time;
  e.principal = std::string(AuditLog::kSystemPrincipal);
  e.action = std::string(action);
  e.request_json = std::move(request_json);
  e.result_message = std::move(message);
  return e;
}

}  // namespace

namespace internal {

AuditRecord ReadAuditRecord(const Statement& stmt) {
  AuditRecord r;
  r.id = stmt.ColumnInt64(0);
  // Rows are only written by Append, so the text parses; a tampered one falls back to the
  // epoch, which then fails its hash (the canonical form re-formats the time).
  r.time = ParseTimestamp(stmt.ColumnText(1)).value_or(system_clock::time_point{});
  r.principal = stmt.ColumnText(2);
  r.source_address = stmt.ColumnText(3);
  r.drive = stmt.ColumnText(4);
  r.action = stmt.ColumnText(5);
  r.request_json = stmt.ColumnText(6);
  r.result_code = stmt.ColumnInt(7);
  r.result_message = stmt.ColumnText(8);
  r.seq = stmt.ColumnIsNull(9) ? 0 : stmt.ColumnInt64(9);
  r.role = stmt.ColumnText(10);
  r.before_json = stmt.ColumnText(11);
  r.after_json = stmt.ColumnText(12);
  r.prev_hash = stmt.ColumnText(13);
  r.hash = stmt.ColumnText(14);
  return r;
}

}  // namespace internal

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

absl::Status AuditLog::SetRetention(const AuditRetention& r) {
  if (r.max_entries != 0 && r.max_entries < AuditRetention::kMinEntries) {
    return absl::InvalidArgumentError(absl::StrCat("audit.max_entries: ", r.max_entries,
                                                   " is below ", AuditRetention::kMinEntries,
                                                   " (0 = unlimited)"));
  }
  if (r.warn_at_percent < 1 || r.warn_at_percent > 100) {
    return absl::InvalidArgumentError(
        absl::StrCat("audit.warn_at_percent: ", r.warn_at_percent, " is outside 1..100"));
  }
  if (r.prune_to_percent < 1 || r.prune_to_percent >= r.warn_at_percent) {
    return absl::InvalidArgumentError(absl::StrCat("audit.prune_to_percent: ", r.prune_to_percent,
                                                   " must be 1..", r.warn_at_percent - 1,
                                                   " (below warn_at_percent)"));
  }
  std::lock_guard lock(mu_);
  retention_ = r;
  return absl::OkStatus();
}

absl::StatusOr<AuditLog::Head> AuditLog::ReadHeadLocked() {
  if (!head_.valid()) {
    // The newest row by id is the chain's head (migration 006: id order is seq order); two
    // descents of the table's b-tree. A legacy row there (seq NULL) means no chain yet.
    DGW_ASSIGN_OR_RETURN(head_, db_->Prepare("SELECT seq, hash FROM audit_log WHERE id = "
                                             "(SELECT MAX(id) FROM audit_log)"));
  }
  absl::StatusOr<bool> row = head_.Step();
  Head head;
  if (row.ok() && *row && !head_.ColumnIsNull(0)) {
    head.seq = head_.ColumnInt64(0);
    head.hash = head_.ColumnText(1);
  }
  head_.Reset().IgnoreError();
  if (!row.ok()) return row.status();
  return head;
}

absl::StatusOr<AuditLink> AuditLog::InsertLocked(const AuditEntry& entry, Head& head) {
  return InsertLocked(entry, PrepareAuditEntry(entry), head);
}

absl::StatusOr<AuditLink> AuditLog::InsertLocked(const AuditEntry& entry,
                                                 const PreparedAuditEntry& prepared, Head& head) {
  if (!insert_.valid()) {
    DGW_ASSIGN_OR_RETURN(
        insert_,
        db_->Prepare("INSERT INTO audit_log (ts, principal, source_address, drive, action, "
                     "request_json, result_code, result_message, seq, role, before_json, "
                     "after_json, prev_hash, hash) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)"));
  }
  const int64_t seq = head.seq + 1;
  const std::string_view prev = head.seq == 0 ? kGenesisPrevHash : std::string_view(head.hash);
  std::string hash = PreparedAuditHash(seq, prepared, prev);
  absl::Status status = [&]() -> absl::Status {
    DGW_RETURN_IF_ERROR(insert_.Bind(1, std::string_view(prepared.ts)));
    DGW_RETURN_IF_ERROR(insert_.Bind(2, std::string_view(entry.principal)));
    DGW_RETURN_IF_ERROR(insert_.Bind(3, std::string_view(entry.source_address)));
    DGW_RETURN_IF_ERROR(insert_.Bind(4, std::string_view(entry.drive)));
    DGW_RETURN_IF_ERROR(insert_.Bind(5, std::string_view(entry.action)));
    DGW_RETURN_IF_ERROR(insert_.Bind(6, std::string_view(entry.request_json)));
    DGW_RETURN_IF_ERROR(insert_.Bind(7, entry.result_code));
    DGW_RETURN_IF_ERROR(insert_.Bind(8, std::string_view(entry.result_message)));
    DGW_RETURN_IF_ERROR(insert_.Bind(9, seq));
    DGW_RETURN_IF_ERROR(insert_.Bind(10, std::string_view(entry.role)));
    DGW_RETURN_IF_ERROR(insert_.Bind(11, std::string_view(entry.before_json)));
    DGW_RETURN_IF_ERROR(insert_.Bind(12, std::string_view(entry.after_json)));
    DGW_RETURN_IF_ERROR(insert_.Bind(13, prev));
    DGW_RETURN_IF_ERROR(insert_.Bind(14, std::string_view(hash)));
    return insert_.Run();
  }();
  // Reset also drops the bound copies of request_json; keep the statement either way.
  insert_.Reset().IgnoreError();
  DGW_RETURN_IF_ERROR(status);
  AuditLink link{db_->LastInsertRowId(), seq, hash};
  head.seq = seq;
  head.hash = std::move(hash);
  return link;
}

absl::Status AuditLog::WriteGenesisLocked(system_clock::time_point time, Head& head) {
  // Rows from before migration 005 stay as they are (SQL cannot hash them and rewriting them
  // would need the update guard off); the genesis anchor fixes their number and a digest over
  // their canonical forms (seq 0, prev_hash ""), so a later change is still detected.
  DGW_ASSIGN_OR_RETURN(Statement stmt,
                       db_->Prepare(absl::StrCat("SELECT ", internal::kAuditColumns,
                                                 " FROM audit_log WHERE seq IS NULL ORDER BY id")));
  Sha256 digest;
  int64_t rows = 0, last_id = 0;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    const AuditRecord r = internal::ReadAuditRecord(stmt);
    digest.Update(CanonicalAuditForm(0, r, ""));
    ++rows;
    last_id = r.id;
  }
  const nlohmann::json request = {
      {"legacy_rows", rows}, {"legacy_last_id", last_id}, {"legacy_digest", digest.HexDigest()}};
  return InsertLocked(SystemEntry(time, kGenesisAction, request.dump(),
                                  "hash chain starts here (decision 017)"),
                      head)
      .status();
}

absl::StatusOr<int64_t> AuditLog::CountLocked(const Head& head) {
  // Chained rows are contiguous in seq (pruning removes the oldest), so the head's seq and the
  // oldest chained seq count them without a scan; legacy rows (seq NULL) only ever shrink and
  // are counted on their own partial index (migration 006).
  if (!count_legacy_.valid()) {
    DGW_ASSIGN_OR_RETURN(count_legacy_,
                         db_->Prepare("SELECT COUNT(*), MAX(id) FROM audit_log WHERE seq IS NULL"));
    // The oldest chained row is the first one after the last legacy row (id order is seq
    // order, migration 006): one descent of the table's b-tree.
    DGW_ASSIGN_OR_RETURN(oldest_chained_,
                         db_->Prepare("SELECT seq FROM audit_log WHERE id > ?1 AND seq IS NOT "
                                      "NULL ORDER BY id LIMIT 1"));
  }
  DGW_ASSIGN_OR_RETURN(const bool has_row, count_legacy_.Step());
  const int64_t legacy = has_row ? count_legacy_.ColumnInt64(0) : 0;
  const int64_t last_legacy_id = has_row && !count_legacy_.ColumnIsNull(1)
                                     ? count_legacy_.ColumnInt64(1)
                                     : std::numeric_limits<int64_t>::min();
  count_legacy_.Reset().IgnoreError();
  if (head.seq == 0) return legacy;
  DGW_RETURN_IF_ERROR(oldest_chained_.Bind(1, last_legacy_id));
  absl::StatusOr<bool> found = oldest_chained_.Step();
  const int64_t oldest = found.ok() && *found ? oldest_chained_.ColumnInt64(0) : head.seq;
  oldest_chained_.Reset().IgnoreError();
  if (!found.ok()) return found.status();
  return legacy + head.seq - oldest + 1;
}

absl::Status AuditLog::ApplyRetentionLocked(const AuditRetention& r, system_clock::time_point time,
                                            Head& head, std::vector<std::string>& warnings) {
  DGW_ASSIGN_OR_RETURN(const int64_t count, CountLocked(head));
  if (count >= r.max_entries) {
    // Prune so that, with the anchor, prune_to_percent of the limit remain (at least the
    // entry just appended and the anchor).
    const int64_t target = std::max<int64_t>(2, r.max_entries * r.prune_to_percent / 100);
    const int64_t remove = count - target + 1;
    DGW_ASSIGN_OR_RETURN(Statement cut,
                         db_->Prepare("SELECT id FROM audit_log ORDER BY id LIMIT 1 OFFSET ?1"));
    DGW_RETURN_IF_ERROR(cut.Bind(1, remove - 1));
    DGW_ASSIGN_OR_RETURN(const bool has_cut, cut.Step());
    if (!has_cut) return absl::InternalError("audit: retention found fewer rows than counted");
    const int64_t cut_id = cut.ColumnInt64(0);
    DGW_ASSIGN_OR_RETURN(Statement last,
                         db_->Prepare("SELECT seq, hash FROM audit_log WHERE id <= ?1 AND seq IS "
                                      "NOT NULL ORDER BY id DESC LIMIT 1"));
    DGW_RETURN_IF_ERROR(last.Bind(1, cut_id));
    DGW_ASSIGN_OR_RETURN(const bool has_chained, last.Step());
    const int64_t pruned_through = has_chained ? last.ColumnInt64(0) : 0;
    const std::string last_hash = has_chained ? last.ColumnText(1) : "";
    // The one privileged path: the guard row lets audit_log_no_delete pass, inside this
    // transaction only (migration 005).
    DGW_RETURN_IF_ERROR(db_->Exec("INSERT INTO audit_prune_guard (id) VALUES (1)"));
    DGW_ASSIGN_OR_RETURN(Statement del, db_->Prepare("DELETE FROM audit_log WHERE id <= ?1"));
    DGW_RETURN_IF_ERROR(del.Bind(1, cut_id));
    absl::Status deleted = del.Run();
    DGW_RETURN_IF_ERROR(db_->Exec("DELETE FROM audit_prune_guard"));
    DGW_RETURN_IF_ERROR(deleted);
    const nlohmann::json request = {
        {"pruned_rows", remove},         {"pruned_through_seq", pruned_through},
        {"last_pruned_hash", last_hash}, {"first_kept_seq", pruned_through + 1},
        {"max_entries", r.max_entries},  {"prune_to_percent", r.prune_to_percent}};
    std::string message = absl::StrCat("retention: removed the ", remove,
                                       " oldest entries (max_entries ", r.max_entries, ")");
    DGW_RETURN_IF_ERROR(
        InsertLocked(SystemEntry(time, kPrunedAction, request.dump(), message), head).status());
    warnings.push_back(std::move(message));
    return absl::OkStatus();
  }
  const int64_t warn_at = (r.max_entries * r.warn_at_percent + 99) / 100;
  if (count < warn_at) return absl::OkStatus();
  // One warning per fill-up: none since the last prune (index on (action, id)).
  constexpr char kLastOf[] = "SELECT MAX(id) FROM audit_log WHERE action = ?1";
  DGW_ASSIGN_OR_RETURN(const int64_t warned, ScalarInt(*db_, kLastOf, 0, kWarningAction));
  DGW_ASSIGN_OR_RETURN(const int64_t pruned, ScalarInt(*db_, kLastOf, 0, kPrunedAction));
  if (warned > pruned) return absl::OkStatus();
  const nlohmann::json request = {
      {"entries", count}, {"max_entries", r.max_entries}, {"warn_at_percent", r.warn_at_percent}};
  std::string message = absl::StrCat("retention: ", count, " of max_entries ", r.max_entries,
                                     " entries; the oldest are pruned when the limit is reached");
  DGW_RETURN_IF_ERROR(
      InsertLocked(SystemEntry(time, kWarningAction, request.dump(), message), head).status());
  warnings.push_back(std::move(message));
  return absl::OkStatus();
}

absl::Status AuditLog::Append(const AuditEntry& entry) { return AppendLinked(entry).status(); }

absl::StatusOr<AuditLink> AuditLog::AppendLinked(const AuditEntry& entry) {
  // Leader/follower group commit (decision 017 "Group commit"): the canonical form is built
  // here, in parallel on every caller's thread; whoever finds no writer active becomes the
  // writer and commits everything queued so far in one transaction. A lone caller writes its
  // own entry at once (no hand-off to another thread, no added latency); under load, the
  // entries queued during one commit share the next.
  Pending me;
  me.entry = &entry;
  me.prepared = PrepareAuditEntry(entry);
  std::unique_lock lock(group_mu_);
  queue_.push_back(&me);
  if (leader_active_) {
    me.cv.wait(lock, [&] { return me.done || me.lead; });
  } else {
    leader_active_ = true;
    me.lead = true;
  }
  while (!me.done) {
    // This thread leads: it commits the head of the queue (which may not hold its own entry
    // when more than kMaxBatch are queued), then wakes exactly the callers it wrote for and
    // hands the lead to the next queued caller, so no other thread wakes for nothing.
    me.lead = false;
    lock.unlock();
    std::vector<Pending*> batch;
    {
      // The connection first, then the batch: entries that queue while another user of the
      // connection holds it join this batch instead of waiting for the next.
      auto db_lock = db_->Lock();
      {
        std::lock_guard queue_lock(group_mu_);
        const size_t n = std::min(queue_.size(), kMaxBatch);
        batch.assign(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(n));
        queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(n));
      }
      CommitBatch(batch);
    }
    lock.lock();
    // Notified under the lock: a waiter that sees done returns and destroys its Pending.
    for (Pending* p : batch) {
      p->done = true;
      if (p != &me) p->cv.notify_one();
    }
    if (queue_.empty()) {
      leader_active_ = false;
    } else {
      queue_.front()->lead = true;
      queue_.front()->cv.notify_one();
    }
    if (!me.done) me.cv.wait(lock, [&] { return me.done || me.lead; });
  }
  return std::move(me.result);
}

void AuditLog::CommitBatch(const std::vector<Pending*>& batch) {
  AuditRetention retention;
  {
    std::lock_guard lock(mu_);
    retention = retention_;
  }
  std::vector<std::string> warnings;
  std::vector<AuditLink> links;
  links.reserve(batch.size());
  int64_t last_id = 0;
  absl::Status status = db_->Transaction([&]() -> absl::Status {
    warnings.clear();
    links.clear();
    // Read once per batch: another process may have appended since our last commit.
    DGW_ASSIGN_OR_RETURN(Head head, ReadHeadLocked());
    if (head.seq == 0) DGW_RETURN_IF_ERROR(WriteGenesisLocked(batch.front()->entry->time, head));
    for (const Pending* p : batch) {
      DGW_ASSIGN_OR_RETURN(AuditLink link, InsertLocked(*p->entry, p->prepared, head));
      links.push_back(std::move(link));
      if (retention.max_entries > 0) {
        DGW_RETURN_IF_ERROR(ApplyRetentionLocked(retention, p->entry->time, head, warnings));
      }
    }
    last_id = db_->LastInsertRowId();
    return absl::OkStatus();
  });
  if (!status.ok()) {
    // Rolled back as a whole: none of these entries is in the log, so each caller learns it.
    const absl::Status failed =
        batch.size() == 1
            ? status
            : absl::Status(status.code(), absl::StrCat("audit: batch of ", batch.size(),
                                                       " entries rolled back: ", status.message()));
    for (Pending* p : batch) p->result = failed;
    return;
  }
  for (size_t i = 0; i < batch.size(); ++i) batch[i]->result = std::move(links[i]);
  for (const std::string& w : warnings) {
    log::Warn("audit_retention", log::Fields().Add("message", w));
  }
  {
    std::lock_guard lock(mu_);
    last_id_ = std::max(last_id_, last_id);
    ++stats_.transactions;
    stats_.entries += static_cast<int64_t>(batch.size());
    stats_.max_batch = std::max(stats_.max_batch, static_cast<int64_t>(batch.size()));
  }
  appended_.notify_all();
}

size_t AuditLog::QueuedAppends() const {
  std::lock_guard lock(group_mu_);
  return queue_.size();
}

void AuditLog::WaitForAppend(int64_t after_id, std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mu_);
  appended_.wait_until(lock, deadline, [&] { return last_id_ > after_id; });
}

AuditCommitStats AuditLog::CommitStats() const {
  std::lock_guard lock(mu_);
  return stats_;
}

absl::StatusOr<std::vector<AuditRecord>> AuditLog::Query(const AuditQuery& query) {
  if (query.limit < 0 || query.limit > AuditQuery::kMaxLimit) {
    return absl::InvalidArgumentError(
        absl::StrCat("audit_query.limit: ", query.limit, " is outside 0..", AuditQuery::kMaxLimit));
  }
  const int limit = query.limit == 0 ? kDefaultLimit : query.limit;
  std::string sql = absl::StrCat("SELECT ", internal::kAuditColumns, " FROM audit_log");
  const char* glue = " WHERE ";
  int next = 1;
  auto add = [&](const char* condition) {
    absl::StrAppend(&sql, glue, condition, next);
    glue = " AND ";
    return next++;
  };
  const int drive_index = query.drive ? add("drive = ?") : 0;
  const int action_index = query.action ? add("action = ?") : 0;
  const int principal_index = query.principal ? add("principal = ?") : 0;
  const int since_index = query.since ? add("ts >= ?") : 0;
  const int until_index = query.until ? add("ts < ?") : 0;
  const int before_index = query.before_id ? add("id < ?") : 0;
  const int after_index = query.after_id ? add("id > ?") : 0;
  absl::StrAppend(&sql, " ORDER BY id ", query.ascending ? "ASC" : "DESC", " LIMIT ?", next);

  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(sql));
  if (drive_index) DGW_RETURN_IF_ERROR(stmt.Bind(drive_index, std::string_view(*query.drive)));
  if (action_index) DGW_RETURN_IF_ERROR(stmt.Bind(action_index, std::string_view(*query.action)));
  if (principal_index) {
    DGW_RETURN_IF_ERROR(stmt.Bind(principal_index, std::string_view(*query.principal)));
  }
  if (since_index) DGW_RETURN_IF_ERROR(stmt.Bind(since_index, FormatTimestamp(*query.since)));
  if (until_index) DGW_RETURN_IF_ERROR(stmt.Bind(until_index, FormatTimestamp(*query.until)));
  if (before_index) DGW_RETURN_IF_ERROR(stmt.Bind(before_index, *query.before_id));
  if (after_index) DGW_RETURN_IF_ERROR(stmt.Bind(after_index, *query.after_id));
  DGW_RETURN_IF_ERROR(stmt.Bind(next, limit));
  std::vector<AuditRecord> out;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    out.push_back(internal::ReadAuditRecord(stmt));
  }
  return out;
}

absl::StatusOr<int64_t> AuditLog::Count() {
  auto lock = db_->Lock();
  return ScalarInt(*db_, "SELECT COUNT(*) FROM audit_log", 0);
}

absl::StatusOr<int64_t> AuditLog::LastId() {
  auto lock = db_->Lock();
  return ScalarInt(*db_, "SELECT MAX(id) FROM audit_log", 0);
}

}  // namespace drivegw::storage
