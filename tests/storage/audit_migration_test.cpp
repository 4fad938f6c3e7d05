// Migration 006 (decision 1351): a database at schema version 5 with data — rows from before
// the chain, a chain, a retention prune — keeps every row, id, seq and hash, verifies with the
// same head afterwards, and appends continue the same chain.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/storage/audit_fixture.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using testing::kAuditT0;
using testing::MakeEntry;
using ::testing::Not;
using testing::TempDir;

constexpr int kChainBySeqIndex = 5;  // the last schema with the unique index on seq

// Applies the embedded migrations above the current schema up to `version` only, as a build of
// that version did.
void MigrateUpTo(Db& db, int version) {
  const int current = *SchemaVersion(db);
  for (const Migration& m : Migrations()) {
    if (m.version <= current) continue;
    if (m.version > version) break;
    absl::Status s = db.Transaction([&]() -> absl::Status {
      absl::Status e = db.Exec(m.sql);
      if (!e.ok()) return e;
      return db.Exec(absl::StrCat("PRAGMA user_version=", m.version));
    });
    ASSERT_TRUE(s.ok()) << m.name << ": " << s;
  }
}

// Every column of every row in id order, as text (id and seq included; seq NULL as "NULL").
std::vector<std::string> Dump(Db& db) {
  auto stmt = db.Prepare(
      "SELECT id, ts, principal, source_address, drive, action, request_json, result_code, "
      "result_message, COALESCE(seq, 'NULL'), role, before_json, after_json, prev_hash, hash "
      "FROM audit_log ORDER BY id");
  EXPECT_TRUE(stmt.ok()) << stmt.status();
  std::vector<std::string> out;
  while (stmt.ok() && *stmt->Step()) {
    std::string row;
    for (int c = 0; c < stmt->ColumnCount(); ++c) absl::StrAppend(&row, stmt->ColumnText(c), "|");
    out.push_back(std::move(row));
  }
  return out;
}

std::vector<std::string> IndexNames(Db& db) {
  auto stmt = db.Prepare(
      "SELECT name FROM sqlite_schema WHERE type = 'index' AND tbl_name = 'audit_log' ORDER BY "
      "name");
  EXPECT_TRUE(stmt.ok());
  std::vector<std::string> out;
  while (stmt.ok() && *stmt->Step()) out.push_back(stmt->ColumnText(0));
  return out;
}

class AuditMigrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<Db>(std::move(*db));
  }

  // Schema 4 (before the chain) with `legacy` rows, then schema 5 and `chained` appends (the
  // genesis anchor first) under `retention`.
  void BuildVersion5(int legacy, int chained, const AuditRetention& retention) {
    MigrateUpTo(*db_, 4);
    ASSERT_EQ(*SchemaVersion(*db_), 4);
    for (int i = 0; i < legacy; ++i) {
      ASSERT_TRUE(db_->Exec(absl::StrCat("INSERT INTO audit_log (ts, principal, source_address, "
                                         "drive, action, request_json, result_code, "
                                         "result_message) VALUES ('2024-05-01T11:00:00.00",
                                         i, "Z', 'bob', '', 'x1', 'Enable', '{}', 0, '')"))
                      .ok());
    }
    MigrateUpTo(*db_, kChainBySeqIndex);
    ASSERT_EQ(*SchemaVersion(*db_), kChainBySeqIndex);
    ASSERT_THAT(IndexNames(*db_), Contains("audit_log_seq"));
    // Appended through today's AuditLog: its rows are byte for byte what a version-5 build
    // wrote (same columns, same canonical form), and the version-5 triggers check each one.
    AuditLog log(*db_);
    ASSERT_TRUE(log.SetRetention(retention).ok());
    for (int i = 0; i < chained; ++i) {
      const auto t = kAuditT0 + std::chrono::milliseconds(i);
      ASSERT_TRUE(log.Append(MakeEntry(absl::StrCat("x", i % 3), "MoveAbsolute", t)).ok());
    }
    before_rows_ = Dump(*db_);
    auto v = log.Verify();
    ASSERT_TRUE(v.ok() && v->ok) << (v.ok() ? v->broken->message : v.status().ToString());
    before_ = *v;
  }

  // Migrates to the latest schema and checks that nothing changed but the schema.
  void MigrateAndCompare() {
    absl::Status m = Migrate(*db_);
    ASSERT_TRUE(m.ok()) << m;
    EXPECT_EQ(*SchemaVersion(*db_), LatestSchemaVersion());
    EXPECT_THAT(IndexNames(*db_), Not(Contains("audit_log_seq")));
    EXPECT_THAT(IndexNames(*db_), Contains("audit_log_legacy_id"));
    EXPECT_EQ(Dump(*db_), before_rows_);
    AuditLog log(*db_);
    auto v = log.Verify();
    ASSERT_TRUE(v.ok()) << v.status();
    ASSERT_TRUE(v->ok) << v->broken->message;
    EXPECT_EQ(v->head_hash, before_.head_hash);
    EXPECT_EQ(v->first_seq, before_.first_seq);
    EXPECT_EQ(v->last_seq, before_.last_seq);
    EXPECT_EQ(v->verified_entries, before_.verified_entries);
    EXPECT_EQ(v->legacy_entries, before_.legacy_entries);
    EXPECT_EQ(v->anchor, before_.anchor);

    // The chain goes on from the same head.
    auto link = log.AppendLinked(MakeEntry("x1", "Disable"));
    ASSERT_TRUE(link.ok()) << link.status();
    EXPECT_EQ(link->seq, before_.last_seq + 1);
    AuditQuery q;
    q.limit = 1;
    const AuditRecord newest = log.Query(q)->front();
    EXPECT_EQ(newest.prev_hash, before_.head_hash);
    v = log.Verify();
    ASSERT_TRUE(v.ok() && v->ok);
    EXPECT_EQ(v->last_seq, before_.last_seq + 1);
    EXPECT_EQ(v->verified_entries, before_.verified_entries + 1);
  }

  TempDir dir_;
  std::unique_ptr<Db> db_;
  std::vector<std::string> before_rows_;
  AuditVerifyReport before_;
};

TEST_F(AuditMigrationTest, Version5WithLegacyRowsAndChain_KeepsEveryRowAndTheHead) {
  BuildVersion5(/*legacy=*/3, /*chained=*/12, AuditRetention{});
  EXPECT_EQ(before_.legacy_entries, 3);
  EXPECT_EQ(before_.anchor, "genesis");
  ASSERT_EQ(before_rows_.size(), 3u + 13u);
  MigrateAndCompare();

  // The legacy digest is still checked after the migration: change a legacy row.
  ASSERT_TRUE(db_->Exec("DROP TRIGGER audit_log_no_update").ok());
  ASSERT_TRUE(db_->Exec("UPDATE audit_log SET principal = 'mallory' WHERE id = 2").ok());
  AuditLog log(*db_);
  auto v = log.Verify();
  ASSERT_TRUE(v.ok());
  ASSERT_FALSE(v->ok);
  EXPECT_EQ(v->broken->field, "legacy_digest");
}

TEST_F(AuditMigrationTest, Version5PrunedByRetention_KeepsTheAnchorAndRetentionGoesOn) {
  AuditRetention r;
  r.max_entries = 20;
  r.warn_at_percent = 90;
  r.prune_to_percent = 50;
  BuildVersion5(/*legacy=*/2, /*chained=*/30, r);
  EXPECT_THAT(before_.anchor, HasSubstr("pruned through seq"));
  EXPECT_EQ(before_.legacy_entries, 0);  // the oldest rows, legacy ones first, were pruned
  MigrateAndCompare();

  // Retention keeps counting and pruning on the new schema; the chain still verifies.
  AuditLog log(*db_);
  ASSERT_TRUE(log.SetRetention(r).ok());
  for (int i = 0; i < 40; ++i) ASSERT_TRUE(log.Append(MakeEntry("x2", "Poll")).ok());
  EXPECT_LE(*log.Count(), r.max_entries);
  auto v = log.Verify();
  ASSERT_TRUE(v.ok());
  EXPECT_TRUE(v->ok) << v->broken->message;
  EXPECT_GT(v->last_seq, before_.last_seq + 40);  // + the warning and prune anchors
}

TEST_F(AuditMigrationTest, Version5WithOnlyLegacyRows_FirstAppendWritesGenesis) {
  BuildVersion5(/*legacy=*/4, /*chained=*/0, AuditRetention{});
  ASSERT_TRUE(Migrate(*db_).ok());
  EXPECT_EQ(Dump(*db_), before_rows_);
  AuditLog log(*db_);
  auto link = log.AppendLinked(MakeEntry("x1", "Enable"));
  ASSERT_TRUE(link.ok()) << link.status();
  EXPECT_EQ(link->seq, 2);  // the genesis anchor is seq 1
  auto v = log.Verify();
  ASSERT_TRUE(v.ok() && v->ok);
  EXPECT_EQ(v->legacy_entries, 4);
  EXPECT_EQ(v->anchor, "genesis");
}

}  // namespace
}  // namespace drivegw::storage
