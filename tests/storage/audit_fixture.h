// Test support for the audit tests: a migrated temp database, entries, raw-SQL helpers.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>

#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage::testing {

// 2024-05-01T12:00:00.000Z
inline const std::chrono::system_clock::time_point kAuditT0{std::chrono::seconds(1714564800)};

inline AuditEntry MakeEntry(std::string drive, std::string action,
                            std::chrono::system_clock::time_point t = kAuditT0, int code = 0) {
  AuditEntry e;
  e.time = t;
  e.principal = "alice";
  e.role = "operator";
  e.source_address = "ipv4:127.0.0.1:5000";
  e.drive = std::move(drive);
  e.action = std::move(action);
  e.request_json = R"({"position_mm":12.5})";
  e.result_code = code;
  e.result_message = code == 0 ? "" : "axis limit";
  return e;
}

class AuditDbTest : public ::testing::Test {
 protected:
  void SetUp() override { Open(); }

  void Open() {
    auto db = Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<Db>(std::move(*db));
    absl::Status m = Migrate(*db_);
    ASSERT_TRUE(m.ok()) << m;
    log_ = std::make_unique<AuditLog>(*db_);
  }

  void AppendOrDie(const AuditEntry& e) {
    absl::Status s = log_->Append(e);
    ASSERT_TRUE(s.ok()) << s;
  }

  // Every row, oldest first.
  std::vector<AuditRecord> All() {
    AuditQuery q;
    q.ascending = true;
    q.limit = AuditQuery::kMaxLimit;
    auto r = log_->Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<AuditRecord>{};
  }

  AuditVerifyReport VerifyOrDie() {
    auto r = log_->Verify();
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : AuditVerifyReport{};
  }

  void ExecOrDie(const std::string& sql) {
    absl::Status s = db_->Exec(sql);
    ASSERT_TRUE(s.ok()) << s << " in " << sql;
  }

  TempDir dir_;
  std::unique_ptr<Db> db_;
  std::unique_ptr<AuditLog> log_;
};

}  // namespace drivegw::storage::testing
