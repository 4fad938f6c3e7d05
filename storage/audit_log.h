// Append-only audit log of operator actions and drive events (table audit_log, guarded by
// triggers): every row after migration 005 is a link of a SHA-256 hash chain (decision 017).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/audit_log_hash.h"
#include "storage/db.h"

namespace drivegw::storage {

// The fields IEC 62443-4-2 CR 2.8 asks of an audit record (issue 7).
struct AuditEntry {
  std::chrono::system_clock::time_point time;  // stored as UTC ISO-8601 with milliseconds
  std::string principal;                       // who: peer identity, "anonymous", "drive:<name>"
  std::string role;                            // the principal's role ("" before authentication)
  std::string source_address;                  // e.g. "ipv4:127.0.0.1:53122"
  std::string drive;                           // "" when the action is not about one drive
  std::string action;                          // e.g. "MoveAbsolute", "drive.fault"
  std::string request_json;
  int result_code = 0;  // absl::StatusCode as int
  std::string result_message;
  std::string before_json;  // state before / after where the call changed one; "" otherwise
  std::string after_json;
};

struct AuditRecord : AuditEntry {
  int64_t id = 0;   // ascending in append order
  int64_t seq = 0;  // chain sequence number 1, 2, ...; 0 = written before the chain (legacy)
  std::string prev_hash;
  std::string hash;
};

struct AuditQuery {
  static constexpr int kMaxLimit = 1000;
  std::optional<std::string> drive;                            // exact match
  std::optional<std::string> action;                           // exact match
  std::optional<std::string> principal;                        // exact match
  std::optional<std::chrono::system_clock::time_point> since;  // time >= since (ms resolution)
  std::optional<std::chrono::system_clock::time_point> until;  // time < until
  std::optional<int64_t> before_id;  // id < before_id: pages backwards from the last record seen
  std::optional<int64_t> after_id;   // id > after_id: pages forwards
  bool ascending = false;            // oldest first (export, watch); default newest first
  int limit = 100;                   // 1..kMaxLimit; 0 means the default 100
};

// Size limit (decision 017). max_entries 0 = unlimited.
struct AuditRetention {
  static constexpr int64_t kMinEntries = 10;
  int64_t max_entries = 0;
  int warn_at_percent = 90;   // an "audit.retention_warning" entry once the log holds this many
  int prune_to_percent = 80;  // at max_entries the oldest rows go until this many remain
};

// The first link that does not hold, as VerifyAuditLog reports it.
struct AuditBrokenLink {
  int64_t seq = 0;
  std::string field;  // "hash" (row content changed), "prev_hash", "seq" (rows missing),
                      // "anchor" (rows removed without a prune anchor), "legacy_digest"
  std::string expected;
  std::string actual;
  std::string message;
};

struct AuditVerifyReport {
  bool ok = true;
  int64_t verified_entries = 0;  // chained rows whose hash was recomputed
  int64_t first_seq = 0;         // 0 when the chain is empty
  int64_t last_seq = 0;
  std::string head_hash;       // hash of the newest row: keep it elsewhere to detect truncation
  int64_t legacy_entries = 0;  // rows from before the chain (not hashed one by one)
  std::string anchor;          // "genesis" or "pruned through seq N"
  std::optional<AuditBrokenLink> broken;
};

// Where an appended entry landed in the chain.
struct AuditLink {
  int64_t id = 0;
  int64_t seq = 0;
  std::string hash;
};

// Appends and the transactions that committed them (group commit batches appends; the
// benchmark derives its baseline's rows per transaction from these).
struct AuditCommitStats {
  int64_t transactions = 0;  // committed append transactions
  int64_t entries = 0;       // caller entries they held (anchors and warnings not counted)
  int64_t max_batch = 0;     // most caller entries in one transaction (<= AuditLog::kMaxBatch)
};

class AuditLog {
 public:
  static constexpr std::string_view kWarningAction = "audit.retention_warning";
  static constexpr std::string_view kPrunedAction = "audit.pruned";
  static constexpr std::string_view kGenesisAction = "audit.genesis";
  static constexpr std::string_view kSystemPrincipal = "drivegw";

  // Keeps `db`, which must outlive this object and stay migrated to the latest schema.
  explicit AuditLog(Db& db) : db_(&db) {}

  // InvalidArgument naming the field for a limit below kMinEntries or percentages out of order
  // (0 < prune_to < warn_at <= 100).
  absl::Status SetRetention(const AuditRetention& retention);

  // Appends `entry` as the next link of the chain and returns once the transaction holding it
  // committed (group commit, decision 017 "Group commit"): concurrent calls are written by one of
  // the callers, the leader, in one IMMEDIATE transaction of at most kMaxBatch entries, chained
  // in the order they were queued; a failed batch is rolled back as a whole and every one of its
  // callers gets the error. The first append writes the genesis anchor first; retention adds a
  // warning or prunes (with its anchor) in the same transaction. Safe from any thread; the chain
  // stays linear across processes too (the transaction reads the head from disk). Must not be
  // called by a thread holding db.Lock(): the writer may be another thread waiting for it.
  absl::Status Append(const AuditEntry& entry);
  // The same, returning where the entry landed.
  absl::StatusOr<AuditLink> AppendLinked(const AuditEntry& entry);
  static constexpr size_t kMaxBatch = 256;

  // Newest first (by id) unless query.ascending. InvalidArgument for limit < 0 or > kMaxLimit.
  absl::StatusOr<std::vector<AuditRecord>> Query(const AuditQuery& query);
  absl::StatusOr<int64_t> Count();
  // The highest row id (0 for an empty log).
  absl::StatusOr<int64_t> LastId();

  // Recomputes the chain from its anchor to its head inside one read transaction on a
  // connection of its own (appends go on meanwhile), and checks the legacy digest.
  absl::StatusOr<AuditVerifyReport> Verify();

  // Blocks until this object appended a row with id > after_id or `deadline` passes. Rows
  // appended by other processes are seen by the caller's next Query, not signalled here.
  void WaitForAppend(int64_t after_id, std::chrono::steady_clock::time_point deadline);

  AuditCommitStats CommitStats() const;
  // Appends queued behind the current writer (not yet in a transaction).
  size_t QueuedAppends() const;

 private:
  struct Head {
    int64_t seq = 0;  // 0: no chained row yet
    std::string hash;
  };
  // One caller's entry on its way through the group commit; lives on the caller's stack.
  struct Pending {
    const AuditEntry* entry = nullptr;
    PreparedAuditEntry prepared;  // built by the caller before it queued
    absl::StatusOr<AuditLink> result = absl::UnknownError("audit: not written");
    bool done = false;  // guarded by group_mu_: result is final
    bool lead = false;  // guarded by group_mu_: this caller writes the next batch
    std::condition_variable cv;
  };
  // The leader's part: one transaction for `batch`; fills every result.
  void CommitBatch(const std::vector<Pending*>& batch);
  absl::StatusOr<Head> ReadHeadLocked();
  absl::StatusOr<AuditLink> InsertLocked(const AuditEntry& entry,
                                         const PreparedAuditEntry& prepared, Head& head);
  absl::StatusOr<AuditLink> InsertLocked(const AuditEntry& entry, Head& head);
  absl::Status WriteGenesisLocked(std::chrono::system_clock::time_point time, Head& head);
  absl::Status ApplyRetentionLocked(const AuditRetention& r,
                                    std::chrono::system_clock::time_point time, Head& head,
                                    std::vector<std::string>& warnings);
  absl::StatusOr<int64_t> CountLocked(const Head& head);

  Db* db_;
  Statement insert_;          // prepared on first use, guarded by db_->Lock()
  Statement head_;            // likewise
  Statement count_legacy_;    // likewise (retention)
  Statement oldest_chained_;  // likewise (retention)

  mutable std::mutex group_mu_;  // queue_, leader_active_, Pending::done and ::lead
  std::deque<Pending*> queue_;
  bool leader_active_ = false;

  mutable std::mutex mu_;  // retention_, last_id_, stats_
  std::condition_variable appended_;
  AuditRetention retention_;
  int64_t last_id_ = 0;
  AuditCommitStats stats_;
};

// UTC ISO-8601 with milliseconds, "2024-05-01T12:00:00.123Z" (fixed width for 0000..9999, so
// text order is time order).
std::string FormatTimestamp(std::chrono::system_clock::time_point time);
absl::StatusOr<std::chrono::system_clock::time_point> ParseTimestamp(std::string_view text);

}  // namespace drivegw::storage
