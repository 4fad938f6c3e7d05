// ConfigRepo: snapshots saved with UTC time, listed newest first.
#include "storage/config_repo.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;
using testing::TempDir;

class ConfigRepoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = Db::Open(dir_.File("config.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<Db>(std::move(*db));
    ASSERT_TRUE(Migrate(*db_).ok());
  }
  TempDir dir_;
  std::unique_ptr<Db> db_;
};

TEST_F(ConfigRepoTest, Latest_Empty_ReturnsNullopt) {
  ConfigRepo repo(*db_);
  auto latest = repo.Latest();
  ASSERT_TRUE(latest.ok()) << latest.status();
  EXPECT_FALSE(latest->has_value());
}

TEST_F(ConfigRepoTest, SaveSnapshot_ThenLatest_ReturnsItWithCurrentTime) {
  ConfigRepo repo(*db_);
  const auto before =
      std::chrono::floor<std::chrono::milliseconds>(std::chrono::system_clock::now());
  auto id = repo.SaveSnapshot("file:/etc/drivegw.yaml", "drives:\n  - name: x1\n", 1);
  const auto after = std::chrono::system_clock::now();
  ASSERT_TRUE(id.ok()) << id.status();
  auto latest = repo.Latest();
  ASSERT_TRUE(latest.ok() && latest->has_value());
  const Snapshot& s = **latest;
  EXPECT_EQ(s.id, *id);
  EXPECT_EQ(s.source, "file:/etc/drivegw.yaml");
  EXPECT_EQ(s.yaml, "drives:\n  - name: x1\n");
  EXPECT_EQ(s.drive_count, 1);
  EXPECT_GE(s.created_at, before);
  EXPECT_LE(s.created_at, after);

  auto stmt = db_->Prepare("SELECT created_at FROM drive_config_snapshots");
  ASSERT_TRUE(stmt.ok() && *stmt->Step());
  EXPECT_THAT(
      stmt->ColumnText(0),
      ::testing::MatchesRegex("[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\\.[0-9]{3}Z"));
}

TEST_F(ConfigRepoTest, List_NewestFirstAndLimited) {
  ConfigRepo repo(*db_);
  std::vector<int64_t> ids;
  for (int i = 0; i < 5; ++i) {
    auto id = repo.SaveSnapshot("test", absl::StrCat("# v", i), i);
    ASSERT_TRUE(id.ok());
    ids.push_back(*id);
  }
  auto list = repo.List(3);
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 3u);
  EXPECT_EQ((*list)[0].id, ids[4]);
  EXPECT_EQ((*list)[1].yaml, "# v3");
  EXPECT_EQ((*list)[2].drive_count, 2);
  EXPECT_EQ((*repo.Latest())->id, ids[4]);
}

TEST_F(ConfigRepoTest, InvalidArguments_Rejected) {
  ConfigRepo repo(*db_);
  EXPECT_EQ(repo.SaveSnapshot("t", "", -1).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(repo.List(0).status().code(), absl::StatusCode::kInvalidArgument);
  auto s = repo.List(ConfigRepo::kMaxListLimit + 1).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("config_snapshot.limit: 1001 is outside 1..1000"));
}

}  // namespace
}  // namespace drivegw::storage
