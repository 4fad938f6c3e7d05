// AuditLog: append/query round trip, filters, append-only triggers, concurrent appends.
#include "storage/audit_log.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using std::chrono::milliseconds;
using std::chrono::system_clock;
using ::testing::HasSubstr;
using testing::TempDir;

// 2024-05-01T12:00:00.000Z
const system_clock::time_point kT0 = system_clock::time_point(std::chrono::seconds(1714564800));

AuditEntry Entry(std::string drive, std::string action, system_clock::time_point t, int code = 0) {
  AuditEntry e;
  e.time = t;
  e.principal = "alice";
  e.source_address = "ipv4:127.0.0.1:5000";
  e.drive = std::move(drive);
  e.action = std::move(action);
  e.request_json = R"({"position_mm":12.5})";
  e.result_code = code;
  e.result_message = code == 0 ? "" : "axis limit";
  return e;
}

class AuditLogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<Db>(std::move(*db));
    ASSERT_TRUE(Migrate(*db_).ok());
    log_ = std::make_unique<AuditLog>(*db_);
  }

  TempDir dir_;
  std::unique_ptr<Db> db_;
  std::unique_ptr<AuditLog> log_;
};

TEST_F(AuditLogTest, Append_ThenQuery_RoundTripsEveryField) {
  AuditEntry e = Entry("x1", "MoveAbsolute", kT0 + milliseconds(123), 11);
  e.request_json = "{\"s\":\"quote ' and \\\" and \\u00e9\"}";
  ASSERT_TRUE(log_->Append(e).ok());
  auto records = log_->Query({});
  ASSERT_TRUE(records.ok()) << records.status();
  ASSERT_EQ(records->size(), 2u);  // and the chain's genesis anchor before it (decision 017)
  const AuditRecord& r = records->front();
  EXPECT_GT(r.id, 0);
  EXPECT_EQ(r.time, e.time);
  EXPECT_EQ(r.principal, e.principal);
  EXPECT_EQ(r.source_address, e.source_address);
  EXPECT_EQ(r.drive, "x1");
  EXPECT_EQ(r.action, "MoveAbsolute");
  EXPECT_EQ(r.request_json, e.request_json);
  EXPECT_EQ(r.result_code, 11);
  EXPECT_EQ(r.result_message, "axis limit");
}

TEST_F(AuditLogTest, Append_StoresUtcIsoTimestampWithMilliseconds) {
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0 + std::chrono::microseconds(45678))).ok());
  auto stmt = db_->Prepare("SELECT ts FROM audit_log WHERE action = 'Enable'");
  ASSERT_TRUE(stmt.ok() && *stmt->Step());
  EXPECT_EQ(stmt->ColumnText(0), "2024-05-01T12:00:00.045Z");
}

TEST_F(AuditLogTest, Update_RejectedByTrigger) {
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0)).ok());
  absl::Status s = db_->Exec("UPDATE audit_log SET principal = 'mallory'");
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("audit_log is append-only"));
  auto records = log_->Query({});
  ASSERT_TRUE(records.ok());
  EXPECT_EQ(records->front().principal, "alice");
}

TEST_F(AuditLogTest, Delete_RejectedByTrigger) {
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0)).ok());
  ASSERT_TRUE(log_->Append(Entry("x2", "Enable", kT0)).ok());
  absl::Status s = db_->Exec("DELETE FROM audit_log WHERE drive = 'x1'");
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("audit_log is append-only"));
  EXPECT_EQ(*log_->Count(), 3);  // with the genesis anchor
}

TEST_F(AuditLogTest, Query_NoFilter_NewestFirst) {
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(log_->Append(Entry("x1", absl::StrCat("a", i), kT0 + milliseconds(i))).ok());
  }
  AuditQuery q;
  q.principal = "alice";  // not the genesis anchor
  auto records = log_->Query(q);
  ASSERT_TRUE(records.ok());
  ASSERT_EQ(records->size(), 5u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ((*records)[i].action, absl::StrCat("a", 4 - i));
  EXPECT_GT((*records)[0].id, (*records)[4].id);
}

TEST_F(AuditLogTest, Query_FilterByDriveActionSince_CombinesWithAnd) {
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0)).ok());
  ASSERT_TRUE(log_->Append(Entry("x2", "Enable", kT0 + milliseconds(1))).ok());
  ASSERT_TRUE(log_->Append(Entry("x1", "MoveAbsolute", kT0 + milliseconds(2))).ok());
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0 + milliseconds(3))).ok());

  AuditQuery by_drive;
  by_drive.drive = "x2";
  auto r = log_->Query(by_drive);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ(r->front().drive, "x2");

  AuditQuery by_action;
  by_action.action = "Enable";
  r = log_->Query(by_action);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->size(), 3u);

  AuditQuery since;
  since.since = kT0 + milliseconds(2);  // inclusive
  r = log_->Query(since);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].time, kT0 + milliseconds(3));
  EXPECT_EQ((*r)[1].time, kT0 + milliseconds(2));

  AuditQuery all;
  all.drive = "x1";
  all.action = "Enable";
  all.since = kT0 + milliseconds(1);
  r = log_->Query(all);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ(r->front().time, kT0 + milliseconds(3));

  AuditQuery none;
  none.drive = "x9";
  r = log_->Query(none);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->empty());
}

TEST_F(AuditLogTest, Query_LimitAndBeforeId_PageBackwards) {
  for (int i = 0; i < 25; ++i) ASSERT_TRUE(log_->Append(Entry("x1", "Poll", kT0)).ok());
  AuditQuery q;
  q.drive = "x1";
  q.limit = 10;
  std::vector<int64_t> seen;
  while (true) {
    auto page = log_->Query(q);
    ASSERT_TRUE(page.ok());
    if (page->empty()) break;
    EXPECT_LE(page->size(), 10u);
    for (const auto& r : *page) seen.push_back(r.id);
    q.before_id = page->back().id;
  }
  ASSERT_EQ(seen.size(), 25u);
  EXPECT_TRUE(std::is_sorted(seen.rbegin(), seen.rend()));
  EXPECT_EQ(std::set<int64_t>(seen.begin(), seen.end()).size(), 25u);
}

TEST_F(AuditLogTest, Query_LimitBounds_ZeroMeansDefaultAndAboveMaxIsRejected) {
  for (int i = 0; i < 150; ++i) ASSERT_TRUE(log_->Append(Entry("x1", "Poll", kT0)).ok());
  AuditQuery q;
  q.drive = "x1";
  q.limit = 0;
  auto r = log_->Query(q);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->size(), 100u);

  q.limit = AuditQuery::kMaxLimit;
  r = log_->Query(q);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->size(), 150u);

  q.limit = AuditQuery::kMaxLimit + 1;
  r = log_->Query(q);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("audit_query.limit: 1001 is outside 0..1000"));

  q.limit = -1;
  EXPECT_EQ(log_->Query(q).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(AuditLogTest, Append_FourThreadsConcurrently_LosesNothing) {
  constexpr int kThreads = 4;
  constexpr int kPerThread = 250;
  std::vector<std::thread> threads;
  std::atomic<int> failures{0};
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        AuditEntry e = Entry(absl::StrCat("t", t), "Poll", kT0 + milliseconds(i));
        e.request_json = absl::StrCat("{\"i\":", i, "}");
        if (!log_->Append(e).ok()) ++failures;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(*log_->Count(), kThreads * kPerThread + 1);  // with the genesis anchor
  for (int t = 0; t < kThreads; ++t) {
    AuditQuery q;
    q.drive = absl::StrCat("t", t);
    q.limit = AuditQuery::kMaxLimit;
    auto r = log_->Query(q);
    ASSERT_TRUE(r.ok());
    std::set<std::string> bodies;
    for (const auto& rec : *r) bodies.insert(rec.request_json);
    EXPECT_EQ(bodies.size(), static_cast<size_t>(kPerThread)) << "thread " << t;
  }
}

TEST_F(AuditLogTest, Append_SurvivesReopen) {
  ASSERT_TRUE(log_->Append(Entry("x1", "Enable", kT0)).ok());
  log_.reset();
  db_.reset();
  auto db = Db::Open(dir_.File("audit.db"));
  ASSERT_TRUE(db.ok());
  AuditLog log(*db);
  EXPECT_EQ(*log.Count(), 2);  // with the genesis anchor
}

TEST(TimestampTest, Format_FixedWidthUtcWithMilliseconds) {
  EXPECT_EQ(FormatTimestamp(kT0 + milliseconds(7)), "2024-05-01T12:00:00.007Z");
  EXPECT_EQ(FormatTimestamp(system_clock::time_point{}), "1970-01-01T00:00:00.000Z");
  // Before the epoch rounds down, not toward zero.
  EXPECT_EQ(FormatTimestamp(system_clock::time_point{} - milliseconds(1)),
            "1969-12-31T23:59:59.999Z");
}

TEST(TimestampTest, Parse_RoundTripsAndRejectsGarbage) {
  const auto t = kT0 + milliseconds(999);
  EXPECT_EQ(*ParseTimestamp(FormatTimestamp(t)), t);
  EXPECT_EQ(*ParseTimestamp("2024-05-01T12:00:00Z"), kT0);
  for (const char* bad :
       {"", "2024-05-01", "2024-05-01 12:00:00.000Z", "2024-02-30T00:00:00Z",
        "2024-05-01T24:00:00Z", "2024-05-01T12:00:00.000", "x024-05-01T12:00:00Z"}) {
    EXPECT_EQ(ParseTimestamp(bad).status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
}

}  // namespace
}  // namespace drivegw::storage
