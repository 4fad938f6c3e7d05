// The fixture ParameterSetRepoTest and CurveSetRepoTest share: a migrated WAL database in a fresh
// temp dir and one repo of type `Repo` on it (both repos take a Db& and nothing else).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage::testing {

// nullptr (and a test failure naming the status) when the file cannot be opened.
inline std::unique_ptr<Db> OpenDb(const std::string& path) {
  auto db = Db::Open(path);
  EXPECT_TRUE(db.ok()) << db.status();
  if (!db.ok()) return nullptr;
  return std::make_unique<Db>(std::move(*db));
}

template <class Repo>
class SetRepoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = OpenDb(dir_.File("sets.db"));
    ASSERT_NE(db_, nullptr);
    ASSERT_TRUE(Migrate(*db_).ok());
    repo_ = std::make_unique<Repo>(*db_);
  }

  int64_t Count(const std::string& table) {
    auto stmt = db_->Prepare(absl::StrCat("SELECT COUNT(*) FROM ", table));
    EXPECT_TRUE(stmt.ok() && *stmt->Step());
    return stmt->ColumnInt64(0);
  }

  TempDir dir_;
  std::unique_ptr<Db> db_;
  std::unique_ptr<Repo> repo_;
};

}  // namespace drivegw::storage::testing
