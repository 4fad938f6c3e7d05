// Group commit of the audit log (decision 017 "Group commit", issue 10 P6): concurrent appends
// share transactions yet stay one verified chain, every caller gets its own link, a failed batch
// reaches all of its callers and the next batch works, batches are bounded.
//
// Batches are formed deterministically: the test holds the connection (Db::Lock) so the leader
// waits for it while the other callers queue (AuditLog::QueuedAppends), then lets go.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "storage/audit_log_hash.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::storage {
namespace {

using testing::AuditDbTest;
using ::testing::HasSubstr;
using testing::MakeEntry;

class AuditGroupCommitTest : public AuditDbTest {
 protected:
  // Blocks until `n` appends are queued behind the (blocked) writer, or fails after 60 s.
  void WaitQueued(size_t n) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (log_->QueuedAppends() < n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::yield();
    }
    ASSERT_EQ(log_->QueuedAppends(), n);
  }

  // The row with this id.
  AuditRecord Row(int64_t id) {
    AuditQuery q;
    q.after_id = id - 1;
    q.ascending = true;
    q.limit = 1;
    auto r = log_->Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() && !r->empty() ? r->front() : AuditRecord{};
  }

  // Starts `entries.size()` callers while the connection is held, waits until all of them
  // queued, then releases the connection: they are written as one batch. Returns each caller's
  // result in the order of `entries`.
  std::vector<absl::StatusOr<AuditLink>> AppendAsOneBatch(const std::vector<AuditEntry>& entries) {
    std::vector<absl::StatusOr<AuditLink>> results(entries.size(), absl::UnknownError("not run"));
    std::vector<std::thread> callers;
    {
      auto held = db_->Lock();
      for (size_t i = 0; i < entries.size(); ++i) {
        callers.emplace_back([&, i] { results[i] = log_->AppendLinked(entries[i]); });
      }
      WaitQueued(entries.size());
    }
    for (auto& c : callers) c.join();
    return results;
  }
};

TEST_F(AuditGroupCommitTest, AppendLinked_ReturnsTheLinkOfItsOwnRow) {
  auto first = log_->AppendLinked(MakeEntry("x1", "Enable"));
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->seq, 2);  // after the genesis anchor
  auto second = log_->AppendLinked(MakeEntry("x1", "Disable"));
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->seq, 3);
  const AuditRecord row = Row(second->id);
  EXPECT_EQ(row.seq, 3);
  EXPECT_EQ(row.action, "Disable");
  EXPECT_EQ(row.hash, second->hash);
  EXPECT_EQ(row.prev_hash, first->hash);
}

TEST_F(AuditGroupCommitTest, ManyThreads_OneVerifiedChainAndEveryCallerGetsItsOwnEntry) {
  constexpr int kThreads = 16;
  constexpr int kPerThread = 40;
  std::vector<std::vector<absl::StatusOr<AuditLink>>> links(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        AuditEntry e = MakeEntry(absl::StrCat("t", t), "MoveAbsolute");
        e.request_json = absl::StrCat("{\"t\":", t, ",\"i\":", i, "}");
        links[t].push_back(log_->AppendLinked(e));
      }
    });
  }
  for (auto& th : threads) th.join();

  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.verified_entries, kThreads * kPerThread + 1);  // with the genesis anchor
  EXPECT_EQ(v.last_seq, kThreads * kPerThread + 1);

  // Every returned seq is distinct, together they are 2..N+1, and each names its caller's row.
  std::set<int64_t> seqs;
  std::map<int64_t, AuditRecord> by_id;
  for (const AuditRecord& r : All()) by_id[r.id] = r;
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(links[t].size(), static_cast<size_t>(kPerThread));
    int64_t last_seq = 0;
    for (int i = 0; i < kPerThread; ++i) {
      ASSERT_TRUE(links[t][i].ok()) << links[t][i].status();
      const AuditLink& link = *links[t][i];
      EXPECT_TRUE(seqs.insert(link.seq).second) << "seq " << link.seq << " returned twice";
      EXPECT_GT(link.seq, last_seq) << "one caller's entries are chained in call order";
      last_seq = link.seq;
      ASSERT_EQ(by_id.count(link.id), 1u) << "id " << link.id;
      const AuditRecord& row = by_id[link.id];
      EXPECT_EQ(row.seq, link.seq);
      EXPECT_EQ(row.hash, link.hash);
      EXPECT_EQ(row.request_json, absl::StrCat("{\"t\":", t, ",\"i\":", i, "}"));
    }
  }
  ASSERT_EQ(seqs.size(), static_cast<size_t>(kThreads * kPerThread));
  EXPECT_EQ(*seqs.begin(), 2);
  EXPECT_EQ(*seqs.rbegin(), kThreads * kPerThread + 1);
  const AuditCommitStats stats = log_->CommitStats();
  EXPECT_EQ(stats.entries, kThreads * kPerThread);
  EXPECT_LE(stats.max_batch, static_cast<int64_t>(AuditLog::kMaxBatch));
}

TEST_F(AuditGroupCommitTest, QueuedCallers_ShareOneTransaction) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  const AuditCommitStats before = log_->CommitStats();
  std::vector<AuditEntry> entries;
  for (int i = 0; i < 6; ++i) entries.push_back(MakeEntry(absl::StrCat("x", i), "MoveAbsolute"));
  const auto results = AppendAsOneBatch(entries);
  std::set<int64_t> seqs;
  for (size_t i = 0; i < results.size(); ++i) {
    ASSERT_TRUE(results[i].ok()) << results[i].status();
    seqs.insert(results[i]->seq);
    EXPECT_EQ(Row(results[i]->id).drive, entries[i].drive);
  }
  EXPECT_EQ(seqs, (std::set<int64_t>{3, 4, 5, 6, 7, 8}));
  const AuditCommitStats after = log_->CommitStats();
  EXPECT_EQ(after.transactions - before.transactions, 1);
  EXPECT_EQ(after.entries - before.entries, 6);
  EXPECT_TRUE(VerifyOrDie().ok);
}

TEST_F(AuditGroupCommitTest, FailedBatch_ReachesEveryCallerAndTheNextBatchWorks) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  const AuditVerifyReport before = VerifyOrDie();
  // The seam: a trigger on this connection only (TEMP) refuses one action, as a CHECK would.
  ExecOrDie(
      "CREATE TEMP TRIGGER inject_failure BEFORE INSERT ON main.audit_log "
      "WHEN NEW.action = 'poison' BEGIN SELECT RAISE(ABORT, 'injected failure'); END");
  std::vector<AuditEntry> entries;
  for (int i = 0; i < 4; ++i) entries.push_back(MakeEntry("x1", "MoveAbsolute"));
  entries.push_back(MakeEntry("x1", "poison"));
  const auto results = AppendAsOneBatch(entries);
  for (const auto& r : results) {
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition) << r.status();
    EXPECT_THAT(r.status().message(), HasSubstr("batch of 5 entries rolled back"));
    EXPECT_THAT(r.status().message(), HasSubstr("injected failure"));
  }
  // Nothing of the batch is in the log; the chain goes on from where it was.
  const AuditVerifyReport unchanged = VerifyOrDie();
  EXPECT_TRUE(unchanged.ok);
  EXPECT_EQ(unchanged.last_seq, before.last_seq);

  std::vector<AuditEntry> next(3, MakeEntry("x2", "MoveAbsolute"));
  for (const auto& r : AppendAsOneBatch(next)) EXPECT_TRUE(r.ok()) << r.status();
  const AuditVerifyReport after = VerifyOrDie();
  EXPECT_TRUE(after.ok);
  EXPECT_EQ(after.last_seq, before.last_seq + 3);
}

TEST_F(AuditGroupCommitTest, MoreCallersThanMaxBatch_AreSplitIntoBoundedBatches) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  const AuditCommitStats before = log_->CommitStats();
  const size_t n = AuditLog::kMaxBatch + 10;
  std::vector<AuditEntry> entries(n, MakeEntry("x1", "MoveAbsolute"));
  for (const auto& r : AppendAsOneBatch(entries)) ASSERT_TRUE(r.ok()) << r.status();
  const AuditCommitStats after = log_->CommitStats();
  EXPECT_EQ(after.transactions - before.transactions, 2);
  EXPECT_EQ(after.entries - before.entries, static_cast<int64_t>(n));
  EXPECT_EQ(after.max_batch, static_cast<int64_t>(AuditLog::kMaxBatch));
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.last_seq, static_cast<int64_t>(n) + 2);
}

TEST_F(AuditGroupCommitTest, RetentionInsideABatch_KeepsTheChainAndEveryCallersLink) {
  ASSERT_TRUE(
      log_->SetRetention({.max_entries = 20, .warn_at_percent = 90, .prune_to_percent = 50}).ok());
  AppendOrDie(MakeEntry("x1", "Enable"));
  std::vector<AuditEntry> entries;
  for (int i = 0; i < 30; ++i) {
    AuditEntry e = MakeEntry("x1", "MoveAbsolute");
    e.request_json = absl::StrCat("{\"i\":", i, "}");
    entries.push_back(e);
  }
  const auto results = AppendAsOneBatch(entries);
  for (size_t i = 0; i < results.size(); ++i) {
    ASSERT_TRUE(results[i].ok()) << results[i].status();
  }
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok) << (v.broken ? v.broken->message : "");
  EXPECT_THAT(v.anchor, HasSubstr("pruned through seq"));
  // The newest caller's row is still there, at the seq it was told. The newest is the one with
  // the highest seq, not entries.back(): the callers queue in the order their threads run (a CI
  // run under load queued caller 29 eleventh, and its row was pruned).
  size_t newest = 0;
  for (size_t i = 1; i < results.size(); ++i) {
    if (results[i]->seq > results[newest]->seq) newest = i;
  }
  const AuditLink& last = *results[newest];
  EXPECT_EQ(Row(last.id).request_json, absl::StrCat("{\"i\":", newest, "}"));
  EXPECT_EQ(Row(last.id).seq, last.seq);
}

}  // namespace
}  // namespace drivegw::storage
