// AuditLog::Verify: recomputes the hash chain from its anchor (genesis or the latest prune
// anchor) to its head and reports the first link that does not hold (decision 017).
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "nlohmann/json.hpp"
#include "storage/audit_log.h"
#include "storage/audit_log_hash.h"
#include "storage/audit_log_row.h"

namespace drivegw::storage {
namespace {

// A read transaction: one WAL snapshot for the whole walk, writers carry on meanwhile.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(Db& db) : db_(db) {}
  ~ReadSnapshot() {
    if (open_) db_.Exec("COMMIT").IgnoreError();
  }
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;
  absl::Status Begin() {
    DGW_RETURN_IF_ERROR(db_.Exec("BEGIN"));
    open_ = true;
    return absl::OkStatus();
  }

 private:
  Db& db_;
  bool open_ = false;
};

struct PruneAnchor {
  int64_t seq = 0;
  int64_t pruned_through = 0;
  std::string last_hash;
};

absl::StatusOr<std::optional<PruneAnchor>> LatestPruneAnchor(Db& db) {
  DGW_ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare("SELECT seq, request_json FROM audit_log WHERE action = ?1 AND seq IS NOT NULL "
                 "ORDER BY id DESC LIMIT 1"));
  DGW_RETURN_IF_ERROR(stmt.Bind(1, AuditLog::kPrunedAction));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return std::optional<PruneAnchor>();
  PruneAnchor a;
  a.seq = stmt.ColumnInt64(0);
  // A tampered anchor fails its own hash during the walk; here it only must not throw.
  const auto j = nlohmann::json::parse(stmt.ColumnText(1), nullptr, false);
  if (j.is_object()) {
    a.pruned_through = j.value("pruned_through_seq", int64_t{-1});
    a.last_hash = j.value("last_pruned_hash", std::string());
  }
  return std::optional<PruneAnchor>(std::move(a));
}

// Digest over the legacy rows as the genesis anchor computed it; nullopt when the genesis row
// names a different count (pruned since) or cannot be read.
absl::StatusOr<std::optional<AuditBrokenLink>> CheckLegacy(Db& db, const AuditRecord& genesis,
                                                           int64_t legacy_now) {
  const auto j = nlohmann::json::parse(genesis.request_json, nullptr, false);
  if (!j.is_object()) return std::optional<AuditBrokenLink>();
  const int64_t rows = j.value("legacy_rows", int64_t{-1});
  if (rows != legacy_now) return std::optional<AuditBrokenLink>();  // the oldest were pruned
  DGW_ASSIGN_OR_RETURN(Statement stmt,
                       db.Prepare(absl::StrCat("SELECT ", internal::kAuditColumns,
                                               " FROM audit_log WHERE seq IS NULL ORDER BY id")));
  Sha256 digest;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    digest.Update(CanonicalAuditForm(0, internal::ReadAuditRecord(stmt), ""));
  }
  const std::string expected = j.value("legacy_digest", std::string());
  std::string actual = digest.HexDigest();
  if (actual == expected) return std::optional<AuditBrokenLink>();
  AuditBrokenLink b;
  b.seq = genesis.seq;
  b.field = "legacy_digest";
  b.expected = expected;
  b.actual = std::move(actual);
  b.message = "a row written before the hash chain was changed";
  return std::optional<AuditBrokenLink>(std::move(b));
}

absl::StatusOr<AuditVerifyReport> Walk(Db& db) {
  AuditVerifyReport report;
  ReadSnapshot snapshot(db);
  DGW_RETURN_IF_ERROR(snapshot.Begin());
  {
    DGW_ASSIGN_OR_RETURN(Statement legacy,
                         db.Prepare("SELECT COUNT(*) FROM audit_log WHERE seq IS NULL"));
    DGW_ASSIGN_OR_RETURN(const bool row, legacy.Step());
    report.legacy_entries = row ? legacy.ColumnInt64(0) : 0;
  }
  DGW_ASSIGN_OR_RETURN(const std::optional<PruneAnchor> anchor, LatestPruneAnchor(db));
  // In id order, the table's own b-tree (migration 006 dropped the seq index): the triggers
  // append every chained row at the highest id, so id order is seq order, and any row out of
  // place shows as a broken "seq" or "anchor" link below.
  DGW_ASSIGN_OR_RETURN(Statement rows, db.Prepare(absl::StrCat(
                                           "SELECT ", internal::kAuditColumns,
                                           " FROM audit_log WHERE seq IS NOT NULL ORDER BY id")));
  auto fail = [&](int64_t seq, std::string field, std::string expected, std::string actual,
                  std::string message) {
    report.ok = false;
    report.broken = AuditBrokenLink{seq, std::move(field), std::move(expected), std::move(actual),
                                    std::move(message)};
    return report;
  };
  std::string expected_prev;
  int64_t prev_seq = 0;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, rows.Step());
    if (!row) break;
    const AuditRecord r = internal::ReadAuditRecord(rows);
    if (prev_seq == 0) {
      report.first_seq = r.seq;
      if (r.seq == 1) {
        expected_prev = std::string(kGenesisPrevHash);
        report.anchor = "genesis";
      } else if (anchor && anchor->pruned_through == r.seq - 1) {
        expected_prev = anchor->last_hash;
        report.anchor = absl::StrCat("pruned through seq ", anchor->pruned_through);
      } else {
        return fail(r.seq, "anchor", absl::StrCat("seq ", anchor ? anchor->pruned_through + 1 : 1),
                    absl::StrCat("seq ", r.seq),
                    absl::StrCat("the oldest row is seq ", r.seq,
                                 ": rows before it were removed without an audit.pruned anchor"));
      }
    } else if (r.seq != prev_seq + 1) {
      return fail(prev_seq + 1, "seq", absl::StrCat(prev_seq + 1), absl::StrCat(r.seq),
                  r.seq > prev_seq
                      ? absl::StrCat("rows seq ", prev_seq + 1, "..", r.seq - 1, " are missing")
                      : absl::StrCat("seq ", r.seq, " follows seq ", prev_seq,
                                     " in row id order: a row was put out of place"));
    }
    if (r.prev_hash != expected_prev) {
      return fail(r.seq, "prev_hash", expected_prev, r.prev_hash,
                  absl::StrCat("seq ", r.seq, " does not link to ",
                               prev_seq == 0 ? report.anchor : absl::StrCat("seq ", prev_seq)));
    }
    std::string recomputed = AuditEntryHash(r.seq, r, r.prev_hash);
    if (recomputed != r.hash) {
      return fail(r.seq, "hash", std::move(recomputed), r.hash,
                  absl::StrCat("seq ", r.seq, ": the row no longer matches its hash"));
    }
    if (r.seq == 1 && r.action == AuditLog::kGenesisAction) {
      DGW_ASSIGN_OR_RETURN(std::optional<AuditBrokenLink> legacy,
                           CheckLegacy(db, r, report.legacy_entries));
      if (legacy) {
        report.ok = false;
        report.broken = std::move(legacy);
        return report;
      }
    }
    expected_prev = r.hash;
    prev_seq = r.seq;
    report.last_seq = r.seq;
    ++report.verified_entries;
  }
  report.head_hash = expected_prev;
  return report;
}

}  // namespace

absl::StatusOr<AuditVerifyReport> AuditLog::Verify() {
  // A connection of its own, so the walk is one snapshot without holding appends up; an
  // in-memory or unopenable path falls back to the shared connection under its lock.
  if (db_->path() != ":memory:" && !db_->path().empty()) {
    auto own = Db::Open(db_->path());
    if (own.ok()) return Walk(*own);
  }
  auto lock = db_->Lock();
  return Walk(*db_);
}

}  // namespace drivegw::storage
