// ParameterSetRepo on real WAL files: round trips, etag conflicts, immutable versions, migration
// from a 001 database, apply operations with pre-images, two connections on one file, paging.
#include "storage/parameter_set_repo.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "storage/migrations.h"
#include "tests/storage/set_repo_fixture.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::OpenDb;
using testing::TempDir;

ParameterSet MakeSet(std::string name, std::vector<ParameterValue> values) {
  ParameterSet s;
  s.name = std::move(name);
  s.family = "trinamic";
  s.model = "TMCM-6110";
  s.description = "pick axis, slow ramp";
  s.target_stored = true;
  s.author = "alice";
  s.values = std::move(values);
  return s;
}

const std::vector<ParameterValue> kValues = {
    {"$4.vmax", 4, 300}, {"$5.amax", 5, -7}, {"$6.current", 6, 9'000'000'000'000LL}};

class ParameterSetRepoTest : public testing::SetRepoTest<ParameterSetRepo> {};

TEST_F(ParameterSetRepoTest, Create_ThenGet_RoundTripsEveryField) {
  const auto before = std::chrono::system_clock::now() - std::chrono::milliseconds(1);
  auto created = repo_->Create(MakeSet("pick-axis_1.slow", kValues), "first cut");
  ASSERT_TRUE(created.ok()) << created.status();
  auto got = repo_->Get("pick-axis_1.slow");
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->name, "pick-axis_1.slow");
  EXPECT_EQ(got->family, "trinamic");
  EXPECT_EQ(got->model, "TMCM-6110");
  EXPECT_EQ(got->description, "pick axis, slow ramp");
  EXPECT_TRUE(got->target_stored);
  EXPECT_EQ(got->author, "alice");
  EXPECT_EQ(got->version, 1);
  EXPECT_EQ(got->values, kValues);
  EXPECT_FALSE(got->etag.empty());
  EXPECT_EQ(got->etag, created->etag);
  EXPECT_GE(got->created_at, before);
  EXPECT_EQ(got->created_at, got->updated_at);

  auto v1 = repo_->GetVersion("pick-axis_1.slow", 1);
  ASSERT_TRUE(v1.ok()) << v1.status();
  EXPECT_EQ(v1->version, 1);
  EXPECT_EQ(v1->author, "alice");
  EXPECT_EQ(v1->comment, "first cut");
  EXPECT_EQ(v1->values, kValues);
  EXPECT_EQ(v1->created_at, got->created_at);
}

TEST_F(ParameterSetRepoTest, Create_StoresFixedWidthUtcTimestamps) {
  ASSERT_TRUE(repo_->Create(MakeSet("a", kValues)).ok());
  auto stmt = db_->Prepare("SELECT created_at, updated_at FROM parameter_sets");
  ASSERT_TRUE(stmt.ok() && *stmt->Step());
  for (int c = 0; c < 2; ++c) {
    const std::string ts = stmt->ColumnText(c);
    EXPECT_EQ(ts.size(), 24u) << ts;
    EXPECT_TRUE(ParseTimestamp(ts).ok()) << ts;
  }
}

TEST_F(ParameterSetRepoTest, Create_TakenName_AlreadyExists) {
  ASSERT_TRUE(repo_->Create(MakeSet("a", kValues)).ok());
  auto again = repo_->Create(MakeSet("a", {}));
  EXPECT_EQ(again.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(again.status().message(), HasSubstr("'a'"));
  EXPECT_EQ(Count("parameter_set_versions"), 1);
}

TEST_F(ParameterSetRepoTest, Create_BadNames_InvalidArgumentNamingTheField) {
  for (const std::string& name : {std::string(), std::string(129, 'a'), std::string("a b"),
                                  std::string("a/b"), std::string("ä")}) {
    auto s = repo_->Create(MakeSet(name, kValues));
    EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument) << name;
    EXPECT_THAT(s.status().message(), HasSubstr("parameter_set.name")) << name;
  }
  EXPECT_TRUE(repo_->Create(MakeSet(std::string(128, 'z'), kValues)).ok());
  EXPECT_EQ(Count("parameter_sets"), 1);
}

TEST_F(ParameterSetRepoTest, Create_EmptyFamily_InvalidArgument) {
  ParameterSet s = MakeSet("a", kValues);
  s.family = "";
  auto r = repo_->Create(s);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("parameter_set.family"));
}

TEST_F(ParameterSetRepoTest, Create_DuplicateParameter_NamesItAndBothIndices) {
  auto r = repo_->Create(MakeSet("a", {{"$4.vmax", 4, 1}, {"$5.amax", 5, 2}, {"$4.vmax", 4, 3}}));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("'$4.vmax'"));
  EXPECT_THAT(r.status().message(), HasSubstr("values[0]"));
  EXPECT_THAT(r.status().message(), HasSubstr("values[2]"));
  EXPECT_EQ(Count("parameter_sets"), 0);
}

TEST_F(ParameterSetRepoTest, Update_NewVersionNewEtag_OldVersionKept) {
  auto v1 = repo_->Create(MakeSet("a", kValues), "one");
  ASSERT_TRUE(v1.ok());
  ParameterSet next = MakeSet("a", {{"$4.vmax", 4, 500}});
  next.description = "faster";
  next.model = "";
  next.target_stored = false;
  next.author = "bob";
  auto v2 = repo_->Update(next, v1->etag, "two");
  ASSERT_TRUE(v2.ok()) << v2.status();
  EXPECT_EQ(v2->version, 2);
  EXPECT_NE(v2->etag, v1->etag);
  EXPECT_EQ(v2->description, "faster");
  EXPECT_EQ(v2->model, "");
  EXPECT_FALSE(v2->target_stored);
  EXPECT_EQ(v2->author, "bob");
  EXPECT_EQ(v2->family, "trinamic");
  EXPECT_EQ(v2->created_at, v1->created_at);
  EXPECT_THAT(v2->values, ElementsAre(ParameterValue{"$4.vmax", 4, 500}));

  auto versions = repo_->ListVersions("a");
  ASSERT_TRUE(versions.ok()) << versions.status();
  ASSERT_EQ(versions->size(), 2u);
  EXPECT_EQ((*versions)[0].version, 2);
  EXPECT_EQ((*versions)[0].comment, "two");
  EXPECT_EQ((*versions)[0].author, "bob");
  EXPECT_EQ((*versions)[1].version, 1);
  EXPECT_EQ((*versions)[1].values, kValues);
  EXPECT_EQ((*versions)[1].author, "alice");
}

TEST_F(ParameterSetRepoTest, Update_StaleEtag_FailedPreconditionNamingSetAndVersion) {
  auto v1 = repo_->Create(MakeSet("a", kValues));
  ASSERT_TRUE(v1.ok());
  ASSERT_TRUE(repo_->Update(MakeSet("a", {}), v1->etag).ok());  // first writer wins
  auto second = repo_->Update(MakeSet("a", {{"$5.amax", 5, 1}}), v1->etag);
  EXPECT_EQ(second.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(second.status().message(), HasSubstr("etag mismatch: set 'a' is at version 2"));
  auto got = repo_->Get("a");
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->version, 2);
  EXPECT_TRUE(got->values.empty());
  EXPECT_EQ(Count("parameter_set_versions"), 2);
}

TEST_F(ParameterSetRepoTest, Update_EmptyEtag_InvalidArgument_UnknownSet_NotFound) {
  ASSERT_TRUE(repo_->Create(MakeSet("a", kValues)).ok());
  EXPECT_EQ(repo_->Update(MakeSet("a", {}), "").status().code(),
            absl::StatusCode::kInvalidArgument);
  auto missing = repo_->Update(MakeSet("nope", {}), "x");
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.status().message(), HasSubstr("'nope'"));
}

TEST_F(ParameterSetRepoTest, Update_OtherFamily_InvalidArgument) {
  auto v1 = repo_->Create(MakeSet("a", kValues));
  ASSERT_TRUE(v1.ok());
  ParameterSet other = MakeSet("a", {});
  other.family = "linmot";
  auto r = repo_->Update(other, v1->etag);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("parameter_set.family"));
}

TEST_F(ParameterSetRepoTest, Update_DuplicateParameter_RefusedBeforeWriting) {
  auto v1 = repo_->Create(MakeSet("a", kValues));
  ASSERT_TRUE(v1.ok());
  auto r = repo_->Update(MakeSet("a", {{"I10", 10, 1}, {"I10", 10, 2}}), v1->etag);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("values[0] and values[1]"));
  EXPECT_EQ(repo_->Get("a")->etag, v1->etag);
}

TEST_F(ParameterSetRepoTest, Delete_StaleEtagRefused_CurrentEtagRemovesSetAndVersions) {
  auto v1 = repo_->Create(MakeSet("a", kValues));
  ASSERT_TRUE(v1.ok());
  auto v2 = repo_->Update(MakeSet("a", {}), v1->etag);
  ASSERT_TRUE(v2.ok());
  absl::Status stale = repo_->Delete("a", v1->etag);
  EXPECT_EQ(stale.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(stale.message(), HasSubstr("set 'a' is at version 2"));
  EXPECT_EQ(repo_->Delete("a", "").code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Count("parameter_sets"), 1);

  ApplyOperation op;
  op.set_name = "a";
  op.set_version = 2;
  ASSERT_TRUE(repo_->CreateOperation(op).ok());
  ASSERT_TRUE(repo_->Delete("a", v2->etag).ok());
  EXPECT_EQ(repo_->Get("a").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(repo_->ListVersions("a").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(Count("parameter_sets"), 0);
  EXPECT_EQ(Count("parameter_set_versions"), 0);
  EXPECT_EQ(Count("apply_operations"), 1);  // operations keep their copy
  EXPECT_EQ(repo_->Delete("a", v2->etag).code(), absl::StatusCode::kNotFound);
}

TEST_F(ParameterSetRepoTest, Versions_ImmutableThroughRawSql) {
  ASSERT_TRUE(repo_->Create(MakeSet("a", kValues)).ok());
  absl::Status update = db_->Exec("UPDATE parameter_set_versions SET comment = 'rewritten'");
  EXPECT_EQ(update.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(update.message(), HasSubstr("immutable"));
  absl::Status del = db_->Exec("DELETE FROM parameter_set_versions");
  EXPECT_EQ(del.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(del.message(), HasSubstr("only with their set"));
  EXPECT_EQ(Count("parameter_set_versions"), 1);
  EXPECT_EQ(repo_->GetVersion("a", 1)->comment, "");
}

TEST_F(ParameterSetRepoTest, Schema_ChecksRejectBadRawRows) {
  EXPECT_FALSE(db_->Exec("INSERT INTO parameter_sets VALUES ('a b', 'x', '', '', 0, "
                         "'2024-05-01T12:00:00.000Z', '2024-05-01T12:00:00.000Z', 1, 'e')")
                   .ok());
  EXPECT_FALSE(db_->Exec("INSERT INTO parameter_sets VALUES ('a', '', '', '', 0, "
                         "'2024-05-01T12:00:00.000Z', '2024-05-01T12:00:00.000Z', 1, 'e')")
                   .ok());
  EXPECT_FALSE(db_->Exec("INSERT INTO apply_operations (set_name, set_version, dry_run, state, "
                         "principal, created_at, updated_at, drives_json) VALUES ('a', 1, 0, "
                         "'DONE', 'p', '2024-05-01T12:00:00.000Z', '2024-05-01T12:00:00.000Z', "
                         "'[]')")
                   .ok());
  EXPECT_FALSE(db_->Exec("INSERT INTO apply_operations (set_name, set_version, dry_run, state, "
                         "principal, created_at, updated_at, drives_json) VALUES ('a', 1, 0, "
                         "'RUNNING', 'p', '2024-05-01T12:00:00.000Z', '2024-05-01T12:00:00.000Z', "
                         "'{not json')")
                   .ok());
  EXPECT_EQ(Count("parameter_sets"), 0);
  EXPECT_EQ(Count("apply_operations"), 0);
}

TEST_F(ParameterSetRepoTest, GetVersion_Unknown_NotFoundNamingRange) {
  ASSERT_TRUE(repo_->Create(MakeSet("a", kValues)).ok());
  auto r = repo_->GetVersion("a", 7);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(r.status().message(), HasSubstr("version 7"));
  EXPECT_EQ(repo_->GetVersion("b", 1).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(ParameterSetRepoTest, List_PagesByNameAndFiltersByFamily) {
  for (const char* name : {"d", "b", "a", "e", "c"}) {
    ParameterSet s = MakeSet(name, kValues);
    if (std::string(name) == "c") s.family = "linmot";
    ASSERT_TRUE(repo_->Create(s).ok());
  }
  std::vector<std::string> seen;
  ParameterSetQuery q;
  q.limit = 2;
  while (true) {
    auto page = repo_->List(q);
    ASSERT_TRUE(page.ok()) << page.status();
    EXPECT_LE(page->size(), 2u);
    for (const ParameterSet& s : *page) {
      seen.push_back(s.name);
      EXPECT_EQ(s.values, kValues);
    }
    if (page->size() < 2) break;
    q.after_name = page->back().name;
  }
  EXPECT_THAT(seen, ElementsAre("a", "b", "c", "d", "e"));

  ParameterSetQuery family;
  family.family = "trinamic";
  family.after_name = "b";
  auto trinamic = repo_->List(family);
  ASSERT_TRUE(trinamic.ok());
  ASSERT_EQ(trinamic->size(), 2u);
  EXPECT_EQ((*trinamic)[0].name, "d");
  EXPECT_EQ((*trinamic)[1].name, "e");

  ParameterSetQuery bad;
  bad.limit = ParameterSetQuery::kMaxLimit + 1;
  auto r = repo_->List(bad);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("limit"));
}

ApplyDriveResult Drive(std::string name, std::string state) {
  ApplyDriveResult d;
  d.drive = std::move(name);
  d.state = std::move(state);
  d.pre_image = {{"$4.vmax", 4, 120}, {"$5.amax", 5, -1}};
  return d;
}

TEST_F(ParameterSetRepoTest, Operations_CreateUpdateGet_RoundTripPreImages) {
  ApplyOperation op;
  op.set_name = "a";
  op.set_version = 3;
  op.principal = "alice";
  op.drives = {Drive("x1", "PENDING"), Drive("x2 \"quoted\" \xC3\xA9", "PENDING")};
  auto created = repo_->CreateOperation(op);
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->id, "op-1");
  EXPECT_EQ(created->state, "RUNNING");
  EXPECT_EQ(created->created_at, created->updated_at);

  ApplyOperation progress = *created;
  progress.state = "FAILED";
  progress.drives[0].state = "ROLLED_BACK";
  progress.drives[0].written = {{"$4.vmax", 4, 300}};
  progress.drives[0].failed_parameter = "$5.amax";
  progress.drives[0].error = "read back 120, wrote 300\n\ttab";
  progress.drives[1].state = "UNCHANGED";
  ASSERT_TRUE(repo_->UpdateOperation(progress).ok());

  auto got = repo_->GetOperation("op-1");
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->id, "op-1");
  EXPECT_EQ(got->set_name, "a");
  EXPECT_EQ(got->set_version, 3);
  EXPECT_FALSE(got->dry_run);
  EXPECT_EQ(got->principal, "alice");
  EXPECT_EQ(got->state, "FAILED");
  EXPECT_EQ(got->created_at, created->created_at);
  EXPECT_GE(got->updated_at, created->updated_at);
  ASSERT_EQ(got->drives.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const ApplyDriveResult& want = progress.drives[i];
    const ApplyDriveResult& have = got->drives[i];
    EXPECT_EQ(have.drive, want.drive);
    EXPECT_EQ(have.state, want.state);
    EXPECT_EQ(have.pre_image, want.pre_image);
    EXPECT_EQ(have.written, want.written);
    EXPECT_EQ(have.failed_parameter, want.failed_parameter);
    EXPECT_EQ(have.error, want.error);
  }
}

TEST_F(ParameterSetRepoTest, Operations_ListNewestFirst_NeverDeleted) {
  for (int i = 0; i < 3; ++i) {
    ApplyOperation op;
    op.set_name = absl::StrCat("s", i);
    op.set_version = 1;
    op.dry_run = i == 1;
    ASSERT_TRUE(repo_->CreateOperation(op).ok());
  }
  auto all = repo_->ListOperations();
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].id, "op-3");
  EXPECT_EQ((*all)[2].id, "op-1");
  EXPECT_TRUE((*all)[1].dry_run);
  auto two = repo_->ListOperations(2);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two->size(), 2u);
  EXPECT_EQ(repo_->ListOperations(-1).status().code(), absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(db_->Exec("DELETE FROM apply_operations").code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(db_->Exec("UPDATE apply_operations SET set_version = 9").code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_TRUE(db_->Exec("UPDATE apply_operations SET state = 'SUCCEEDED' WHERE id = 1").ok());
  EXPECT_EQ(Count("apply_operations"), 3);
}

// Decision 1441: start-up turns RUNNING operations INTERRUPTED; the drive that was being
// written (APPLYING) becomes INTERRUPTED with the reason, PENDING ones and finished operations
// stay as they are; the pre-image survives; target_stored and restores round-trip.
TEST_F(ParameterSetRepoTest, InterruptRunning_OnlyRunningOnesWithTheirApplyingDrives) {
  ApplyOperation running;
  running.set_name = "a";
  running.set_version = 2;
  running.target_stored = true;
  running.drives = {Drive("x1", "APPLIED"), Drive("x2", "APPLYING"), Drive("x3", "PENDING")};
  auto r = repo_->CreateOperation(running);
  ASSERT_TRUE(r.ok()) << r.status();
  ApplyOperation done;
  done.set_name = "a";
  done.set_version = 2;
  done.restores = "op-1";
  auto d = repo_->CreateOperation(done);
  ASSERT_TRUE(d.ok()) << d.status();
  done = *d;
  done.state = "SUCCEEDED";
  ASSERT_TRUE(repo_->UpdateOperation(done).ok());

  auto interrupted = repo_->InterruptRunning("the gateway stopped");
  ASSERT_TRUE(interrupted.ok()) << interrupted.status();
  ASSERT_EQ(interrupted->size(), 1u);
  EXPECT_EQ((*interrupted)[0].id, r->id);

  auto got = repo_->GetOperation(r->id);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->state, "INTERRUPTED");
  EXPECT_TRUE(got->target_stored);
  ASSERT_EQ(got->drives.size(), 3u);
  EXPECT_EQ(got->drives[0].state, "APPLIED");
  EXPECT_EQ(got->drives[1].state, "INTERRUPTED");
  EXPECT_EQ(got->drives[1].error, "the gateway stopped");
  EXPECT_EQ(got->drives[1].pre_image, running.drives[1].pre_image);
  EXPECT_EQ(got->drives[2].state, "PENDING");
  auto other = repo_->GetOperation(done.id);
  ASSERT_TRUE(other.ok());
  EXPECT_EQ(other->state, "SUCCEEDED");
  EXPECT_EQ(other->restores, "op-1");
  EXPECT_FALSE(other->target_stored);

  // A second start finds nothing left to interrupt; the fixed columns stay fixed.
  auto again = repo_->InterruptRunning("again");
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->empty());
  EXPECT_EQ(db_->Exec("UPDATE apply_operations SET restores = 'op-9' WHERE id = 1").code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(db_->Exec("UPDATE apply_operations SET target_stored = 0 WHERE id = 1").code(),
            absl::StatusCode::kFailedPrecondition);
  ApplyOperation bad = running;
  bad.restores = "7";
  EXPECT_EQ(repo_->CreateOperation(bad).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(ParameterSetRepoTest, Operations_BadInput_Refused) {
  ApplyOperation op;
  op.set_name = "a";
  op.state = "DONE";
  auto r = repo_->CreateOperation(op);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("apply_operation.state"));

  op.state = "RUNNING";
  op.drives = {Drive("x1", "DONE")};
  r = repo_->CreateOperation(op);
  EXPECT_THAT(r.status().message(), HasSubstr("drives[0].state"));

  op.drives = {Drive("x1\xff", "PENDING")};  // not UTF-8: JSON cannot carry it
  r = repo_->CreateOperation(op);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);

  op.drives = {};
  auto ok = repo_->CreateOperation(op);
  ASSERT_TRUE(ok.ok());
  ApplyOperation moved = *ok;
  moved.set_name = "b";
  EXPECT_EQ(repo_->UpdateOperation(moved).code(), absl::StatusCode::kInvalidArgument);

  for (const char* id : {"op-99", "op-", "op-1x", "1", "op--1"}) {
    ApplyOperation missing = *ok;
    missing.id = id;
    EXPECT_EQ(repo_->UpdateOperation(missing).code(), absl::StatusCode::kNotFound) << id;
    EXPECT_EQ(repo_->GetOperation(id).status().code(), absl::StatusCode::kNotFound) << id;
  }
  EXPECT_EQ(Count("apply_operations"), 1);
}

// A database created by a build that knew only 001 keeps its rows when 002 is applied.
TEST(ParameterSetMigrationTest, From001_DataKept_TablesAdded) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    auto db = OpenDb(path);
    ASSERT_NE(db, nullptr);
    ASSERT_GE(Migrations().size(), 2u);
    ASSERT_EQ(Migrations()[0].version, 1);
    ASSERT_TRUE(db->Transaction([&] {
                    absl::Status s = db->Exec(Migrations()[0].sql);
                    return s.ok() ? db->Exec("PRAGMA user_version=1") : s;
                  }).ok());
    ASSERT_TRUE(db->Exec("INSERT INTO drive_config_snapshots (created_at, source, yaml, "
                         "drive_count) VALUES ('2024-05-01T12:00:00.000Z', 'file:x', 'drives: []', "
                         "0)")
                    .ok());
    // An audit row as that build wrote it (AuditLog now appends to the 005 hash chain).
    ASSERT_TRUE(db->Exec("INSERT INTO audit_log (ts, principal, source_address, drive, action, "
                         "request_json, result_code, result_message) VALUES "
                         "('2024-05-01T12:00:00.000Z', 'alice', '', '', 'Enable', '', 0, '')")
                    .ok());
    EXPECT_FALSE(db->Exec("SELECT 1 FROM parameter_sets").ok());
  }
  auto db = OpenDb(path);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(*SchemaVersion(*db), 1);
  ASSERT_TRUE(Migrate(*db).ok());
  EXPECT_EQ(*SchemaVersion(*db), LatestSchemaVersion());
  EXPECT_GE(LatestSchemaVersion(), 2);
  EXPECT_EQ(*AuditLog(*db).Count(), 1);
  auto snap = db->Prepare("SELECT source FROM drive_config_snapshots");
  ASSERT_TRUE(snap.ok() && *snap->Step());
  EXPECT_EQ(snap->ColumnText(0), "file:x");
  ParameterSetRepo repo(*db);
  ASSERT_TRUE(repo.Create(MakeSet("after-upgrade", kValues)).ok());
  EXPECT_EQ(repo.Get("after-upgrade")->values, kValues);
}

// Two connections (as two processes would hold) on one WAL file: the etag check and the write
// are one BEGIN IMMEDIATE transaction, so exactly one of two writers holding the same etag wins.
TEST(ParameterSetConcurrencyTest, TwoConnections_SameEtag_SecondGetsFailedPrecondition) {
  TempDir dir;
  auto a = OpenDb(dir.File("shared.db"));
  auto b = OpenDb(dir.File("shared.db"));
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  ASSERT_TRUE(Migrate(*a).ok());
  ASSERT_TRUE(Migrate(*b).ok());
  ParameterSetRepo ra(*a), rb(*b);
  ASSERT_TRUE(ra.Create(MakeSet("shared", kValues)).ok());
  auto seen_a = ra.Get("shared");
  auto seen_b = rb.Get("shared");  // b sees a's commit
  ASSERT_TRUE(seen_a.ok() && seen_b.ok()) << seen_b.status();
  EXPECT_EQ(seen_a->etag, seen_b->etag);
  ASSERT_TRUE(ra.Update(MakeSet("shared", {{"$4.vmax", 4, 1}}), seen_a->etag).ok());
  auto lost = rb.Update(MakeSet("shared", {{"$4.vmax", 4, 2}}), seen_b->etag);
  EXPECT_EQ(lost.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(lost.status().message(), HasSubstr("is at version 2"));
  EXPECT_THAT(rb.Get("shared")->values, ElementsAre(ParameterValue{"$4.vmax", 4, 1}));
}

// Threads on two connections race read-modify-write loops: every successful update makes exactly
// one version, none is lost or doubled, and the versions are 1..N without gaps.
TEST(ParameterSetConcurrencyTest, TwoConnections_RacingUpdates_NoLostVersion) {
  TempDir dir;
  auto a = OpenDb(dir.File("race.db"));
  auto b = OpenDb(dir.File("race.db"));
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  ASSERT_TRUE(Migrate(*a).ok());
  ParameterSetRepo ra(*a), rb(*b);
  ASSERT_TRUE(ra.Create(MakeSet("race", {})).ok());
  constexpr int kPerThread = 20;
  std::atomic<int> conflicts{0};
  std::atomic<int> errors{0};
  auto worker = [&](ParameterSetRepo& repo, int who) {
    for (int done = 0; done < kPerThread;) {
      auto cur = repo.Get("race");
      if (!cur.ok()) {
        ++errors;
        return;
      }
      auto r = repo.Update(MakeSet("race", {{"w", 1, who * 1000 + done}}), cur->etag);
      if (r.ok()) {
        ++done;
      } else if (r.status().code() == absl::StatusCode::kFailedPrecondition) {
        ++conflicts;
      } else {
        ADD_FAILURE() << r.status();
        ++errors;
        return;
      }
    }
  };
  std::thread t1(worker, std::ref(ra), 1), t2(worker, std::ref(rb), 2);
  std::thread t3(worker, std::ref(ra), 3), t4(worker, std::ref(rb), 4);
  t1.join();
  t2.join();
  t3.join();
  t4.join();
  EXPECT_EQ(errors.load(), 0);
  ::testing::Test::RecordProperty("etag_conflicts", conflicts.load());  // how hard they raced
  auto versions = ra.ListVersions("race");
  ASSERT_TRUE(versions.ok());
  ASSERT_EQ(versions->size(), 1u + 4 * kPerThread);
  std::set<int64_t> values;
  for (size_t i = 0; i < versions->size(); ++i) {
    EXPECT_EQ((*versions)[i].version, static_cast<int>(versions->size() - i));
    if (!(*versions)[i].values.empty()) values.insert((*versions)[i].values[0].value);
  }
  EXPECT_EQ(values.size(), 4u * kPerThread);  // every write landed once
  EXPECT_EQ(rb.Get("race")->version, 1 + 4 * kPerThread);
}

}  // namespace
}  // namespace drivegw::storage
