// Migrate(): versioned by PRAGMA user_version, idempotent, refuses newer databases.
#include "storage/migrations.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "absl/strings/str_cat.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;
using testing::TempDir;

std::vector<std::string> Names(Db& db, const char* type) {
  auto stmt = db.Prepare(
      absl::StrCat("SELECT name FROM sqlite_schema WHERE type = '", type, "' ORDER BY name"));
  EXPECT_TRUE(stmt.ok());
  std::vector<std::string> out;
  while (*stmt->Step()) out.push_back(stmt->ColumnText(0));
  return out;
}

TEST(MigrationsTest, Embedded_MatchFilesOnDiskInOrder) {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(DGW_MIGRATIONS_DIR)) {
    if (e.path().extension() == ".sql") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  const auto& embedded = Migrations();
  ASSERT_EQ(embedded.size(), files.size());
  for (size_t i = 0; i < files.size(); ++i) {
    std::ifstream in(files[i], std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(embedded[i].version, static_cast<int>(i) + 1);
    EXPECT_EQ(embedded[i].name, files[i].filename().string());
    EXPECT_EQ(embedded[i].sql, text.str()) << files[i];
  }
  EXPECT_EQ(LatestSchemaVersion(), static_cast<int>(files.size()));
}

TEST(MigrationsTest, Migrate_FreshDb_CreatesTablesTriggersAndSetsVersion) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  EXPECT_EQ(*SchemaVersion(*db), 0);
  ASSERT_TRUE(Migrate(*db).ok());
  EXPECT_EQ(*SchemaVersion(*db), LatestSchemaVersion());
  EXPECT_GE(LatestSchemaVersion(), 1);
  EXPECT_THAT(Names(*db, "table"),
              ::testing::IsSupersetOf({"audit_log", "drive_config_snapshots", "parameter_sets",
                                       "parameter_set_versions", "apply_operations"}));
  // Later migrations add their own guards (002: versions immutable, operations never deleted).
  EXPECT_THAT(Names(*db, "trigger"),
              ::testing::IsSupersetOf(
                  {"audit_log_no_delete", "audit_log_no_update", "parameter_set_versions_no_update",
                   "parameter_set_versions_no_delete", "apply_operations_no_delete"}));
}

TEST(MigrationsTest, Migrate_Twice_IsIdempotent) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE(Migrate(*db).ok());
  ASSERT_TRUE(db->Exec("INSERT INTO drive_config_snapshots (created_at, source, yaml, "
                       "drive_count) VALUES ('2024-01-01T00:00:00.000Z', 't', '', 0)")
                  .ok());
  const auto tables = Names(*db, "table");
  absl::Status again = Migrate(*db);
  ASSERT_TRUE(again.ok()) << again;
  EXPECT_EQ(Names(*db, "table"), tables);
  EXPECT_EQ(*SchemaVersion(*db), LatestSchemaVersion());
  auto count = db->Prepare("SELECT COUNT(*) FROM drive_config_snapshots");
  ASSERT_TRUE(count.ok() && *count->Step());
  EXPECT_EQ(count->ColumnInt(0), 1);
}

TEST(MigrationsTest, Migrate_ReopenedFile_KeepsVersionAndData) {
  TempDir dir;
  {
    auto db = Db::Open(dir.File("t.db"));
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE(Migrate(*db).ok());
  }
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  EXPECT_EQ(*SchemaVersion(*db), LatestSchemaVersion());
  EXPECT_TRUE(Migrate(*db).ok());
}

TEST(MigrationsTest, Migrate_NewerDatabase_RefusedNamingBothVersionsAndUntouched) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  const int newer = LatestSchemaVersion() + 5;
  ASSERT_TRUE(db->Exec(absl::StrCat("PRAGMA user_version=", newer)).ok());
  absl::Status s = Migrate(*db);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr(absl::StrCat("database schema version ", newer)));
  EXPECT_THAT(s.message(),
              HasSubstr(absl::StrCat("this build's schema version ", LatestSchemaVersion())));
  EXPECT_TRUE(Names(*db, "table").empty());
  EXPECT_EQ(*SchemaVersion(*db), newer);
}

TEST(MigrationsTest, Migrate_FailingStatement_RollsBackAndNamesFile) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  // A table that 001 will try to create makes the migration fail half-way.
  ASSERT_TRUE(db->Exec("CREATE TABLE audit_log (x INTEGER)").ok());
  absl::Status s = Migrate(*db);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.message(), HasSubstr(std::string(Migrations().front().name)));
  EXPECT_THAT(s.message(), HasSubstr("already exists"));
  EXPECT_EQ(*SchemaVersion(*db), 0);
  EXPECT_EQ(Names(*db, "table"), std::vector<std::string>{"audit_log"});
}

TEST(MigrationsTest, Migrate_TwoConnectionsAtOnce_BothSucceedOnce) {
  TempDir dir;
  const std::string path = dir.File("t.db");
  auto a = Db::Open(path);
  auto b = Db::Open(path);
  ASSERT_TRUE(a.ok() && b.ok());
  absl::Status sa, sb;
  std::thread ta([&] { sa = Migrate(*a); });
  std::thread tb([&] { sb = Migrate(*b); });
  ta.join();
  tb.join();
  EXPECT_TRUE(sa.ok()) << sa;
  EXPECT_TRUE(sb.ok()) << sb;
  EXPECT_EQ(*SchemaVersion(*a), LatestSchemaVersion());
}

}  // namespace
}  // namespace drivegw::storage
