// CurveSetRepo on real WAL files: round trips of both curve kinds, etag conflicts, immutable
// versions, invalid curves refused before storing, malformed stored JSON reported, migration from
// a version-2 (parameter sets) database keeping its data (decision 411).
#include "storage/curve_set_repo.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <memory>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "tests/storage/set_repo_fixture.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;
using testing::OpenDb;
using testing::TempDir;
using LM = LinMotParametricCurve;

Curve Lift() {
  Curve c;
  c.name = "lift";
  c.description = "raise the gripper";
  // Decimal steps that binary doubles cannot hold exactly: the JSON must still round-trip.
  c.shape = PositionTimeCurve{0.001, {10.0, 10.1, 10.3, 10.6, 0.1 + 0.2, 1e-7}};
  return c;
}

Curve Cut() {
  LM lm;
  lm.curve_id = 42;
  lm.x_length_s = 0.25;
  lm.points = {std::numeric_limits<int32_t>::min(), -1, 0, 12345,
               std::numeric_limits<int32_t>::max()};
  lm.offset_mm = -12.5;
  lm.amplitude_scale_pct = -150.5;
  lm.time_scale_pct = 99.99;
  Curve c;
  c.name = "cut";
  c.shape = lm;
  return c;
}

CurveSet MakeSet(std::string name) {
  return CurveSet{std::move(name), "press line, product A", {Lift(), Cut()}};
}

class CurveSetRepoTest : public testing::SetRepoTest<CurveSetRepo> {};

TEST_F(CurveSetRepoTest, Create_Get_RoundTripsBothKindsExactly) {
  auto created = repo_->Create(MakeSet("press-a"), "alice", "first");
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->version, 1);
  EXPECT_EQ(created->author, "alice");
  EXPECT_EQ(created->etag.size(), 32u);
  EXPECT_EQ(created->created_at, created->updated_at);
  auto got = repo_->Get("press-a");
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->set, MakeSet("press-a"));  // doubles, SInt32 extremes, scales: bit-exact
  EXPECT_EQ(got->etag, created->etag);
  EXPECT_EQ(got->created_at, created->created_at);
  // The summary of the stored LinMot curve equals the original's.
  EXPECT_EQ(SummarizeCurve(got->set.curves[1])->end_mm, SummarizeCurve(Cut())->end_mm);
}

TEST_F(CurveSetRepoTest, Create_Duplicate_AlreadyExists) {
  ASSERT_TRUE(repo_->Create(MakeSet("a"), "alice").ok());
  auto again = repo_->Create(MakeSet("a"), "bob");
  EXPECT_EQ(again.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(again.status().message(), HasSubstr("curve_set.name: 'a' already exists"));
}

TEST_F(CurveSetRepoTest, Create_BadNameOrInvalidCurve_InvalidArgumentNothingStored) {
  auto bad_name = repo_->Create(MakeSet("has space"), "alice");
  EXPECT_EQ(bad_name.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad_name.status().message(),
              HasSubstr("character outside [A-Za-z0-9._-] at index 3"));

  CurveSet set = MakeSet("ok-name");
  std::get<LM>(set.curves[1].shape).curve_id = 101;
  auto bad_id = repo_->Create(set, "alice");
  EXPECT_EQ(bad_id.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad_id.status().message(),
              HasSubstr("curves[1] 'cut': curve_id: 101 is outside 1..100"));

  set = MakeSet("ok-name");
  std::get<PositionTimeCurve>(set.curves[0].shape).time_step_s = 0;
  EXPECT_THAT(repo_->Create(set, "alice").status().message(),
              HasSubstr("curves[0] 'lift': time_step_s: 0 is not a finite value > 0"));
  EXPECT_EQ(Count("curve_sets"), 0);
  EXPECT_EQ(Count("curve_set_versions"), 0);
}

TEST_F(CurveSetRepoTest, Update_WithEtag_NewVersionOldOneKept) {
  auto v1 = repo_->Create(MakeSet("s"), "alice", "first");
  ASSERT_TRUE(v1.ok());
  CurveSet changed = MakeSet("s");
  changed.description = "slower";
  std::get<PositionTimeCurve>(changed.curves[0].shape).time_step_s = 0.002;
  changed.curves.pop_back();
  auto v2 = repo_->Update(changed, v1->etag, "bob", "slower lift");
  ASSERT_TRUE(v2.ok()) << v2.status();
  EXPECT_EQ(v2->version, 2);
  EXPECT_NE(v2->etag, v1->etag);
  EXPECT_EQ(v2->author, "bob");
  EXPECT_EQ(v2->set, changed);
  EXPECT_EQ(v2->created_at, v1->created_at);

  auto versions = repo_->ListVersions("s");
  ASSERT_TRUE(versions.ok());
  ASSERT_EQ(versions->size(), 2u);
  EXPECT_EQ((*versions)[0].version, 2);
  EXPECT_EQ((*versions)[0].comment, "slower lift");
  EXPECT_EQ((*versions)[1].version, 1);
  EXPECT_EQ((*versions)[1].author, "alice");
  EXPECT_EQ((*versions)[1].curves, MakeSet("s").curves);
  auto old = repo_->GetVersion("s", 1);
  ASSERT_TRUE(old.ok());
  EXPECT_EQ(old->curves, MakeSet("s").curves);
  EXPECT_EQ(old->comment, "first");
  auto missing = repo_->GetVersion("s", 3);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.status().message(), HasSubstr("has no version 3 (versions 1..2)"));
}

TEST_F(CurveSetRepoTest, Update_StaleOrEmptyEtag_RefusedNothingWritten) {
  auto v1 = repo_->Create(MakeSet("s"), "alice");
  ASSERT_TRUE(v1.ok());
  ASSERT_TRUE(repo_->Update(MakeSet("s"), v1->etag, "bob").ok());
  auto stale = repo_->Update(MakeSet("s"), v1->etag, "carol");
  EXPECT_EQ(stale.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(stale.status().message(), HasSubstr("etag mismatch: curve set 's' is at version 2"));
  auto empty = repo_->Update(MakeSet("s"), "", "carol");
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(empty.status().message(), HasSubstr("etag: empty"));
  EXPECT_EQ(Count("curve_set_versions"), 2);
  EXPECT_EQ(repo_->Get("s")->version, 2);
  EXPECT_EQ(repo_->Update(MakeSet("nope"), "x", "a").status().code(), absl::StatusCode::kNotFound);
}

TEST_F(CurveSetRepoTest, Delete_EtagRule_ThenGone_VersionsCascade) {
  auto v1 = repo_->Create(MakeSet("s"), "alice");
  ASSERT_TRUE(v1.ok());
  ASSERT_TRUE(repo_->Update(MakeSet("s"), v1->etag, "bob").ok());
  EXPECT_EQ(repo_->Delete("s", v1->etag).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo_->Delete("s", "").code(), absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(repo_->Delete("s", repo_->Get("s")->etag).ok());
  EXPECT_EQ(repo_->Get("s").status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(repo_->Get("s").status().message(), HasSubstr("curve set 's' not found"));
  EXPECT_EQ(repo_->ListVersions("s").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(Count("curve_set_versions"), 0);
  // A new set under the old name never matches the old etag.
  auto again = repo_->Create(MakeSet("s"), "carol");
  ASSERT_TRUE(again.ok());
  EXPECT_NE(again->etag, v1->etag);
  EXPECT_EQ(again->version, 1);
}

TEST_F(CurveSetRepoTest, Versions_ImmutableThroughRawSql) {
  ASSERT_TRUE(repo_->Create(MakeSet("s"), "alice").ok());
  absl::Status update = db_->Exec("UPDATE curve_set_versions SET comment = 'x'");
  EXPECT_FALSE(update.ok());
  EXPECT_THAT(update.message(), HasSubstr("curve_set_versions are immutable"));
  absl::Status del = db_->Exec("DELETE FROM curve_set_versions");
  EXPECT_FALSE(del.ok());
  EXPECT_THAT(del.message(), HasSubstr("removed only with their set"));
  EXPECT_EQ(Count("curve_set_versions"), 1);
}

TEST_F(CurveSetRepoTest, List_SortedPagedAndLimitChecked) {
  for (const char* n : {"c", "a", "b"}) ASSERT_TRUE(repo_->Create(MakeSet(n), "alice").ok());
  auto all = repo_->List();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].set.name, "a");
  EXPECT_EQ((*all)[2].set.name, "c");
  CurveSetQuery q;
  q.limit = 1;
  q.after_name = "a";
  auto page = repo_->List(q);
  ASSERT_TRUE(page.ok());
  ASSERT_EQ(page->size(), 1u);
  EXPECT_EQ((*page)[0].set.name, "b");
  EXPECT_EQ((*page)[0].set.curves, MakeSet("b").curves);
  q.limit = 1001;
  EXPECT_THAT(repo_->List(q).status().message(),
              HasSubstr("curve_set_query.limit: 1001 is outside 0..1000"));
}

TEST_F(CurveSetRepoTest, MalformedStoredCurves_DataLossNamingRowAndField) {
  ASSERT_TRUE(repo_->Create(MakeSet("s"), "alice").ok());
  // Bypass the immutability trigger the only way a corrupt row could appear: a new version row.
  ASSERT_TRUE(db_->Exec("INSERT INTO curve_set_versions VALUES ('s', 2, 'x', '', "
                        "'2024-05-01T12:00:00.000Z', '[{\"name\":\"n\",\"kind\":\"linmot\","
                        "\"curve_id\":1,\"y_unit\":\"position_0.1um\",\"x_length_s\":1,"
                        "\"offset_mm\":0,\"amplitude_scale_pct\":100,\"time_scale_pct\":100,"
                        "\"points\":[0,4294967296]}]'); UPDATE curve_sets SET version = 2")
                  .ok());
  auto got = repo_->Get("s");
  EXPECT_EQ(got.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(got.status().message(),
              HasSubstr("curve set 's' version 2 are malformed: curves[0].points[1] is not a "
                        "32-bit integer"));
}

TEST(CurvesJsonTest, FromJson_EveryMissingFieldNamed) {
  EXPECT_THAT(CurvesFromJson("{", "x").status().message(), HasSubstr("not JSON"));
  EXPECT_THAT(CurvesFromJson("{}", "x").status().message(), HasSubstr("not an array"));
  EXPECT_THAT(CurvesFromJson("[1]", "x").status().message(),
              HasSubstr("curves[0] is not an object"));
  EXPECT_THAT(CurvesFromJson(R"([{"kind":"linmot"}])", "x").status().message(),
              HasSubstr("curves[0].name is missing"));
  EXPECT_THAT(CurvesFromJson(R"([{"name":"a","kind":"spline"}])", "x").status().message(),
              HasSubstr("curves[0].kind 'spline' is not position_time or linmot"));
  EXPECT_THAT(CurvesFromJson(R"([{"name":"a","kind":"position_time","time_step_s":1,
                                  "positions_mm":[1,"2"]}])",
                             "x")
                  .status()
                  .message(),
              HasSubstr("curves[0].positions_mm[1] is not a number"));
  EXPECT_THAT(CurvesFromJson(R"([{"name":"a","kind":"linmot","curve_id":1,"y_unit":"mm"}])", "x")
                  .status()
                  .message(),
              HasSubstr("curves[0].y_unit is not 'position_0.1um'"));
  EXPECT_THAT(CurvesFromJson(R"([{"name":"a","kind":"linmot","curve_id":1,
                                  "y_unit":"position_0.1um","x_length_s":1}])",
                             "x")
                  .status()
                  .message(),
              HasSubstr("curves[0].offset_mm is missing or not a number"));
}

// A database created by a build that knew 001 and 002 keeps its parameter sets, snapshots and
// audit entries when 003 is applied, and then stores curve sets.
TEST(CurveSetMigrationTest, FromVersion2_DataKept_TablesAdded) {
  TempDir dir;
  const std::string path = dir.File("v2.db");
  ParameterSet ps;
  ps.name = "feeder";
  ps.family = "linmot";
  ps.author = "alice";
  ps.values = {{"0x14BE", 0x14BE, 300}};
  {
    auto db = OpenDb(path);
    ASSERT_NE(db, nullptr);
    ASSERT_GE(Migrations().size(), 3u);
    for (int i = 0; i < 2; ++i) {
      ASSERT_EQ(Migrations()[i].version, i + 1);
      ASSERT_TRUE(db->Transaction([&] {
                      absl::Status s = db->Exec(Migrations()[i].sql);
                      return s.ok() ? db->Exec(absl::StrCat("PRAGMA user_version=", i + 1)) : s;
                    }).ok());
    }
    ASSERT_TRUE(ParameterSetRepo(*db).Create(ps).ok());
    // An audit row as that build wrote it (AuditLog now appends to the 005 hash chain).
    ASSERT_TRUE(db->Exec("INSERT INTO audit_log (ts, principal, source_address, drive, action, "
                         "request_json, result_code, result_message) VALUES "
                         "('2024-05-01T12:00:00.000Z', 'alice', '', '', 'CreateParameterSet', '', 0, '')")
                    .ok());
    EXPECT_FALSE(db->Exec("SELECT 1 FROM curve_sets").ok());
  }
  auto db = OpenDb(path);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(*SchemaVersion(*db), 2);
  ASSERT_TRUE(Migrate(*db).ok());
  EXPECT_EQ(*SchemaVersion(*db), LatestSchemaVersion());
  EXPECT_GE(LatestSchemaVersion(), 3);
  EXPECT_EQ(*AuditLog(*db).Count(), 1);
  auto kept = ParameterSetRepo(*db).Get("feeder");
  ASSERT_TRUE(kept.ok()) << kept.status();
  EXPECT_EQ(kept->values, ps.values);
  CurveSetRepo repo(*db);
  ASSERT_TRUE(repo.Create(MakeSet("after-upgrade"), "bob").ok());
  EXPECT_EQ(repo.Get("after-upgrade")->set, MakeSet("after-upgrade"));
  EXPECT_TRUE(Migrate(*db).ok());  // idempotent
}

}  // namespace
}  // namespace drivegw::storage
