// Every statement the audit log runs uses an index (issue 10 P6, decision 1351): the statements
// are captured from the real calls (SQLite trace on every connection, the verifier's own
// included) and each one's EXPLAIN QUERY PLAN is checked; an append (triggers and retention
// included) costs the same number of VM steps whatever the table holds.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::storage {
namespace {

using testing::AuditDbTest;
using testing::kAuditT0;
using testing::MakeEntry;

// Statements seen on any connection (sqlite3_sql text) and the VM steps they took.
struct Captured {
  std::mutex mu;
  std::set<std::string> sql;
  int64_t vm_steps = 0;
};
Captured& Capture() {
  static Captured c;
  return c;
}

int OnTrace(unsigned type, void*, void* p, void*) {
  if (type != SQLITE_TRACE_PROFILE) return 0;
  auto* stmt = static_cast<sqlite3_stmt*>(p);
  const char* sql = sqlite3_sql(stmt);
  std::lock_guard lock(Capture().mu);
  if (sql != nullptr) Capture().sql.insert(sql);
  // Trigger programs run inside their statement's VM, so their steps count here too.
  Capture().vm_steps += sqlite3_stmt_status(stmt, SQLITE_STMTSTATUS_VM_STEP, /*reset=*/1);
  return 0;
}

int TraceEveryConnection(sqlite3* db, const char**, const sqlite3_api_routines*) {
  sqlite3_trace_v2(db, SQLITE_TRACE_PROFILE, OnTrace, nullptr);
  return SQLITE_OK;
}

class AuditQueryPlanTest : public AuditDbTest {
 protected:
  static void SetUpTestSuite() {
    sqlite3_auto_extension(reinterpret_cast<void (*)()>(TraceEveryConnection));
  }
  static void TearDownTestSuite() {
    sqlite3_cancel_auto_extension(reinterpret_cast<void (*)()>(TraceEveryConnection));
  }
  void SetUp() override {
    AuditDbTest::SetUp();  // the connection opened here is traced already
    std::lock_guard lock(Capture().mu);
    Capture().sql.clear();
    Capture().vm_steps = 0;
  }

  std::vector<std::string> Plan(const std::string& sql) {
    auto stmt = db_->Prepare(absl::StrCat("EXPLAIN QUERY PLAN ", sql));
    EXPECT_TRUE(stmt.ok()) << stmt.status() << " in " << sql;
    std::vector<std::string> out;
    while (stmt.ok() && *stmt->Step()) out.push_back(stmt->ColumnText(3));
    return out;
  }

  int64_t VmStepsOfOneAppend(const AuditEntry& e) {
    {
      std::lock_guard lock(Capture().mu);
      Capture().vm_steps = 0;
    }
    AppendOrDie(e);
    std::lock_guard lock(Capture().mu);
    return Capture().vm_steps;
  }
};

// Reads that walk the table in id order on purpose (the table's own b-tree, no other index
// applies): the unfiltered listing/export page, the verifier's walk, the retention cut.
bool WalksTheTableById(const std::string& sql) {
  return absl::StrContains(sql, "FROM audit_log ORDER BY id") ||
         absl::StrContains(sql, "FROM audit_log WHERE seq IS NOT NULL ORDER BY id");
}

// A single time bound and nothing else: SQLite walks the table in id order and stops at LIMIT
// instead of reading the whole open-ended range from audit_log_ts and sorting it (the same
// plan as before migration 006; "since" newest first stops after one page).
bool OneSidedTimeBound(const std::string& sql) {
  return absl::StrContains(sql, "FROM audit_log WHERE ts >= ?1 ORDER BY id") ||
         absl::StrContains(sql, "FROM audit_log WHERE ts < ?1 ORDER BY id");
}

TEST_F(AuditQueryPlanTest, EveryStatementOfAppendQueryVerifyAndRetention_UsesAnIndex) {
  AuditRetention r;
  r.max_entries = 20;
  r.warn_at_percent = 80;
  r.prune_to_percent = 50;
  ASSERT_TRUE(log_->SetRetention(r).ok());
  for (int i = 0; i < 30; ++i) {  // warning, prune, anchor
    AppendOrDie(MakeEntry("x1", "MoveAbsolute", kAuditT0 + std::chrono::seconds(i)));
  }
  ASSERT_TRUE(log_->Verify().ok());
  // Every filter alone and together, both directions, both paging cursors (ListAuditEvents,
  // WatchAuditEvents and ExportAuditEvents build their reads from these).
  for (int mask = 0; mask < (1 << 7); ++mask) {
    AuditQuery q;
    if (mask & 1) q.drive = "x1";
    if (mask & 2) q.action = "MoveAbsolute";
    if (mask & 4) q.principal = "alice";
    if (mask & 8) q.since = kAuditT0;
    if (mask & 16) q.until = kAuditT0 + std::chrono::seconds(20);
    if (mask & 32) q.before_id = 25;
    if (mask & 64) q.after_id = 3;
    q.ascending = (mask % 3) == 0;
    auto rows = log_->Query(q);
    ASSERT_TRUE(rows.ok()) << rows.status();
  }
  ASSERT_TRUE(log_->LastId().ok());

  std::set<std::string> statements;
  {
    std::lock_guard lock(Capture().mu);
    statements = Capture().sql;
  }
  int checked = 0;
  for (const std::string& sql : statements) {
    if (!absl::StrContains(sql, "audit_log") || absl::StrContains(sql, "audit_prune_guard") ||
        absl::StartsWith(sql, "INSERT")) {
      continue;  // inserts carry no plan; their triggers are checked by VM steps below
    }
    ++checked;
    for (const std::string& line : Plan(sql)) {
      const bool search = absl::StartsWith(line, "SEARCH ");
      const bool index_scan =
          absl::StartsWith(line, "SCAN audit_log USING ") && absl::StrContains(line, "INDEX");
      const bool id_walk =
          line == "SCAN audit_log" && (WalksTheTableById(sql) || OneSidedTimeBound(sql));
      const bool helper = absl::StartsWith(line, "USE TEMP B-TREE FOR ORDER BY") ||
                          absl::StartsWith(line, "SCALAR SUBQUERY");
      EXPECT_TRUE(search || index_scan || id_walk || helper)
          << "plan line '" << line << "' of: " << sql;
    }
  }
  EXPECT_GE(checked, 10) << "the trace captured too few statements";
  // The shapes that must have been among them.
  auto seen = [&](const std::string& part) {
    for (const std::string& s : statements) {
      if (s.find(part) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_TRUE(seen("drive = ?"));
  EXPECT_TRUE(seen("action = ?"));
  EXPECT_TRUE(seen("principal = ?"));
  EXPECT_TRUE(seen("ts >= ?"));
  EXPECT_TRUE(seen("ts < ?"));
  EXPECT_TRUE(seen("WHERE seq IS NOT NULL ORDER BY id"));  // the verifier's walk
  EXPECT_TRUE(seen("DELETE FROM audit_log"));              // the prune
}

TEST_F(AuditQueryPlanTest, Append_CostsTheSameVmStepsAt20And3000Rows) {
  // Legacy rows (seq NULL) too: counting them and finding the oldest chained row must not scan.
  // The chain triggers are lifted for this setup only and put back exactly as migrated.
  std::vector<std::string> triggers;
  {
    auto stmt = db_->Prepare(
        "SELECT sql FROM sqlite_schema WHERE type = 'trigger' AND name LIKE 'audit_log_chain_%'");
    ASSERT_TRUE(stmt.ok());
    while (*stmt->Step()) triggers.push_back(stmt->ColumnText(0));
  }
  ASSERT_EQ(triggers.size(), 2u);
  ExecOrDie("DROP TRIGGER audit_log_chain_append");
  ExecOrDie("DROP TRIGGER audit_log_chain_position");
  for (int i = 0; i < 5; ++i) {
    ExecOrDie(absl::StrCat(
        "INSERT INTO audit_log (ts, principal, source_address, drive, action, request_json, "
        "result_code, result_message) VALUES ('2024-05-01T11:00:00.00",
        i, "Z', 'bob', '', 'x1', 'Enable', '{}', 0, '')"));
  }
  for (const std::string& t : triggers) ExecOrDie(t);
  AuditRetention r;
  r.max_entries = 1'000'000;  // counted on every append, never reached
  ASSERT_TRUE(log_->SetRetention(r).ok());
  for (int i = 0; i < 20; ++i) AppendOrDie(MakeEntry("x1", "MoveAbsolute"));
  const int64_t small = VmStepsOfOneAppend(MakeEntry("x2", "MoveAbsolute"));
  for (int i = 0; i < 3000; ++i) AppendOrDie(MakeEntry(absl::StrCat("x", i % 7), "MoveAbsolute"));
  const int64_t large = VmStepsOfOneAppend(MakeEntry("x2", "MoveAbsolute"));
  EXPECT_GT(small, 0);
  // A scan anywhere (a trigger's sub-select, the retention count) would add ~3000 steps.
  EXPECT_LE(large, small + 10) << "small table " << small << " steps, large " << large;
}

}  // namespace
}  // namespace drivegw::storage
