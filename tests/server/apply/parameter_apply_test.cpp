// ParameterApplier against map-backed fake drives (tests/server/apply/map_drive.h) and a real
// SQLite ParameterSetRepo: success, dry run, validation refusal, failure in the middle restoring
// the pre-image, read-back mismatch, rollback failure, stop at the first failing drive, the stored
// operation (issue 6, docs/decisions/010-parameter-apply.md).
#include "server/core/parameter_apply.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "tests/server/apply/map_drive.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using storage::ApplyOperation;
using storage::ParameterSet;
using storage::ParameterValue;
using test_support::MapDrive;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// Family "fake": p1..p5 = ids 1..5, range 0..1000; p5 read-only; only p1 has a stored value.
class FakeCatalogue final : public ParameterCatalogue {
 public:
  FakeCatalogue() {
    for (uint32_t i = 1; i <= 5; ++i) {
      ParameterDefinition d;
      d.id = i;
      d.name = "p" + std::to_string(i);
      d.type = "i32";
      d.min = 0;
      d.max = 1000;
      d.writable = i != 5;
      d.has_stored_value = i == 1;
      defs_.push_back(d);
    }
  }
  std::string family() const override { return "fake"; }
  const std::vector<ParameterDefinition>& Definitions() const override { return defs_; }
  absl::StatusOr<ParameterDefinition> Find(std::string_view name_or_id) const override {
    for (const auto& d : defs_) {
      if (d.name == name_or_id || std::to_string(d.id) == name_or_id) return d;
    }
    return absl::NotFoundError("fake: no parameter '" + std::string(name_or_id) + "'");
  }

 private:
  std::vector<ParameterDefinition> defs_;
};

std::map<uint32_t, int64_t> Initial() { return {{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}}; }

class ParameterApplyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("gw.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(*std::move(db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    repo_ = std::make_unique<storage::ParameterSetRepo>(*db_);
    catalogues_.push_back(std::make_shared<FakeCatalogue>());
    applier_ = std::make_unique<ParameterApplier>(*repo_, catalogues_);
  }
  void TearDown() override { applier_.reset(); }

  MapDrive& AddDrive(const std::string& name, std::string family = "fake") {
    drives_.push_back(std::make_unique<MapDrive>(name, std::move(family), Initial()));
    return *drives_.back();
  }
  static ParameterSet Set(std::vector<ParameterValue> values) {
    ParameterSet s;
    s.name = "tuning";
    s.family = "fake";
    s.version = 3;
    s.values = std::move(values);
    return s;
  }
  ApplyRequest Request(ParameterSet set, bool dry_run = false) {
    ApplyRequest r;
    r.set = std::move(set);
    for (auto& d : drives_) r.drives.push_back(d.get());
    r.dry_run = dry_run;
    r.principal = "alice";
    return r;
  }
  // p1 := 10, p2 := 2 (already so), p3 := 30, p4 := 40.
  static ParameterSet Standard() {
    return Set({{"p1", 1, 10}, {"p2", 2, 2}, {"p3", 3, 30}, {"p4", 4, 40}});
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::ParameterSetRepo> repo_;
  CatalogueList catalogues_;
  std::vector<std::unique_ptr<MapDrive>> drives_;
  std::unique_ptr<ParameterApplier> applier_;
};

TEST_F(ParameterApplyTest, SuccessWritesOnlyDifferingValuesAndStoresTheOperation) {
  MapDrive& a = AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "SUCCEEDED");
  EXPECT_EQ(op->set_name, "tuning");
  EXPECT_EQ(op->set_version, 3);
  EXPECT_EQ(op->principal, "alice");
  ASSERT_EQ(op->drives.size(), 2u);
  for (MapDrive* d : {&a, &b}) {
    EXPECT_EQ(d->Value(1), 10);
    EXPECT_EQ(d->Value(2), 2);
    EXPECT_EQ(d->Value(3), 30);
    EXPECT_EQ(d->Value(4), 40);
    // p2 was already 2: equal values are not written (no waste).
    EXPECT_EQ(d->write_calls(), 3);
  }
  const auto& r = op->drives[0];
  EXPECT_EQ(r.drive, "x1");
  EXPECT_EQ(r.state, "APPLIED");
  const std::vector<ParameterValue> pre = {{"p1", 1, 1}, {"p2", 2, 2}, {"p3", 3, 3}, {"p4", 4, 4}};
  EXPECT_EQ(r.pre_image, pre);
  const std::vector<ParameterValue> written = {{"p1", 1, 10}, {"p3", 3, 30}, {"p4", 4, 40}};
  EXPECT_EQ(r.written, written);
  EXPECT_EQ(r.failed_parameter, "");
  EXPECT_EQ(r.error, "");

  auto stored = repo_->GetOperation(op->id);
  ASSERT_TRUE(stored.ok()) << stored.status();
  EXPECT_EQ(stored->state, "SUCCEEDED");
  ASSERT_EQ(stored->drives.size(), 2u);
  EXPECT_EQ(stored->drives[1].state, "APPLIED");
  EXPECT_EQ(stored->drives[1].pre_image, pre);
}

// Decision 1441: before the first write to a drive its pre-image is in the database with the
// drive APPLYING and the operation RUNNING, so a process killed at any write leaves a record of
// what to restore.
TEST_F(ParameterApplyTest, PreImageIsStoredBeforeTheFirstWrite) {
  MapDrive& a = AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  std::vector<std::string>
      seen;  // "<drive state 0>/<drive state 1>/<pre-image size of the writer>"
  auto look = [&](size_t writer) {
    return [&, writer] {
      auto ops = repo_->ListOperations(1);
      ASSERT_TRUE(ops.ok() && ops->size() == 1u);
      const ApplyOperation& op = ops->front();
      EXPECT_EQ(op.state, "RUNNING");
      seen.push_back(absl::StrCat(op.drives[0].state, "/", op.drives[1].state, "/",
                                  op.drives[writer].pre_image.size()));
    };
  };
  a.before_write = look(0);
  b.before_write = look(1);
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "SUCCEEDED");
  const std::vector<std::string> want = {"APPLYING/PENDING/4", "APPLYING/PENDING/4",
                                         "APPLYING/PENDING/4", "APPLIED/APPLYING/4",
                                         "APPLIED/APPLYING/4", "APPLIED/APPLYING/4"};
  EXPECT_EQ(seen, want);
}

// A restore (decision 1441): each drive gets its own value list, the operation names the one it
// restores and keeps the RAM/ROM choice.
TEST_F(ParameterApplyTest, PerDriveValuesWriteEachDrivesOwnListAndNameTheRestoredOperation) {
  MapDrive& a = AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  ApplyRequest r = Request(Set({}));
  r.per_drive_values = {{{"p1", 1, 11}}, {{"p3", 3, 33}, {"p4", 4, 44}}};
  r.restores = "op-7";
  auto op = applier_->Run(r);
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "SUCCEEDED");
  EXPECT_EQ(op->restores, "op-7");
  EXPECT_EQ(a.Value(1), 11);
  EXPECT_EQ(a.Value(3), 3);
  EXPECT_EQ(b.Value(1), 1);
  EXPECT_EQ(b.Value(3), 33);
  EXPECT_EQ(b.Value(4), 44);
  // Every list is validated before anything is written; a count mismatch is refused.
  r.per_drive_values = {{{"p1", 1, 12}}, {{"p9", 9, 1}}};
  EXPECT_EQ(applier_->Run(r).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(a.Value(1), 11);
  r.per_drive_values = {{{"p1", 1, 12}}};
  EXPECT_EQ(applier_->Run(r).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(ParameterApplyTest, NothingToChangeIsUnchanged) {
  MapDrive& a = AddDrive("x1");
  auto op = applier_->Run(Request(Set({{"p1", 1, 1}, {"p3", 3, 3}})));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "SUCCEEDED");
  EXPECT_EQ(op->drives[0].state, "UNCHANGED");
  EXPECT_EQ(a.write_calls(), 0);
}

TEST_F(ParameterApplyTest, DryRunReportsChangesAndWritesNothing) {
  MapDrive& a = AddDrive("x1");
  auto op = applier_->Run(Request(Standard(), /*dry_run=*/true));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_TRUE(op->dry_run);
  EXPECT_EQ(op->state, "SUCCEEDED");
  EXPECT_EQ(op->drives[0].state, "UNCHANGED");
  EXPECT_EQ(a.write_calls(), 0);
  EXPECT_EQ(a.Value(1), 1);
  // What would be written: the differing values only.
  const std::vector<ParameterValue> would = {{"p1", 1, 10}, {"p3", 3, 30}, {"p4", 4, 40}};
  EXPECT_EQ(op->drives[0].written, would);
  EXPECT_EQ(op->drives[0].pre_image.size(), 4u);

  auto diff = applier_->Diff(Standard(), a);
  ASSERT_TRUE(diff.ok()) << diff.status();
  ASSERT_EQ(diff->size(), 4u);
  EXPECT_EQ((*diff)[0].parameter, "p1");
  EXPECT_EQ((*diff)[0].current, 1);
  EXPECT_EQ((*diff)[0].target, 10);
  EXPECT_TRUE((*diff)[0].differs);
  EXPECT_FALSE((*diff)[1].differs);
}

TEST_F(ParameterApplyTest, ValidationRefusalWritesNothingAndStoresNothing) {
  MapDrive& a = AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  auto bad_range = Standard();
  bad_range.values.push_back({"p2", 2, 2000});
  auto op = applier_->Run(Request(bad_range));
  ASSERT_FALSE(op.ok());
  EXPECT_EQ(op.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(op.status().message(), HasSubstr("p2: 2000 is outside 0..1000"));
  EXPECT_THAT(op.status().message(), HasSubstr("drive 'x1'"));

  auto read_only = applier_->Run(Request(Set({{"p1", 1, 10}, {"p5", 5, 6}})));
  ASSERT_FALSE(read_only.ok());
  EXPECT_THAT(read_only.status().message(), HasSubstr("p5: read-only"));

  auto unknown = applier_->Run(Request(Set({{"p1", 1, 10}, {"p9", 9, 6}})));
  ASSERT_FALSE(unknown.ok());
  EXPECT_THAT(unknown.status().message(), HasSubstr("no parameter 'p9'"));

  auto rom = Standard();
  rom.target_stored = true;  // p2 (the first after p1) has no stored value
  auto no_rom = applier_->Run(Request(rom));
  ASSERT_FALSE(no_rom.ok());
  EXPECT_THAT(no_rom.status().message(), HasSubstr("p2 has no stored (ROM) value"));

  EXPECT_EQ(a.write_calls(), 0);
  EXPECT_EQ(b.write_calls(), 0);
  auto ops = repo_->ListOperations();
  ASSERT_TRUE(ops.ok()) << ops.status();
  EXPECT_THAT(*ops, IsEmpty());
}

TEST_F(ParameterApplyTest, WrongFamilyOrUnknownFamilyIsRefused) {
  AddDrive("x1");
  MapDrive& other = AddDrive("y1", "linmot");
  auto op = applier_->Run(Request(Standard()));
  ASSERT_FALSE(op.ok());
  EXPECT_THAT(op.status().message(), HasSubstr("drive 'y1' is of family 'linmot'"));
  EXPECT_EQ(other.write_calls(), 0);

  auto set = Standard();
  set.family = "nosuch";
  auto none = applier_->Run(Request(set));
  EXPECT_EQ(none.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(applier_->Catalogue("nosuch").status().message(), HasSubstr("'nosuch'"));
  ASSERT_TRUE(applier_->Catalogue("fake").ok());
}

TEST_F(ParameterApplyTest, RefusedWriteInTheMiddleRestoresThePreImage) {
  MapDrive& a = AddDrive("x1");
  a.SetFaults({.refuse_write = 1});  // p1 taken, p3 refused
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED");
  const auto& r = op->drives[0];
  EXPECT_EQ(r.state, "ROLLED_BACK");
  EXPECT_EQ(r.failed_parameter, "p3");
  EXPECT_THAT(r.error, HasSubstr("refused 3"));
  EXPECT_THAT(r.written, IsEmpty());
  EXPECT_EQ(a.Value(1), 1);
  EXPECT_EQ(a.Value(3), 3);
  EXPECT_EQ(a.Value(4), 4);  // never reached
  // p1 := 10, then p1 := 1 (restore); the refused p3 kept its value, so it is not rewritten.
  const std::vector<std::pair<uint32_t, int64_t>> writes = {{1, 10}, {1, 1}};
  EXPECT_EQ(a.writes(), writes);
}

TEST_F(ParameterApplyTest, ReadBackMismatchIsDetectedAndRestored) {
  MapDrive& a = AddDrive("x1");
  a.SetFaults({.mismatch = 1});  // p3 := 30 lands as 37
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED");
  const auto& r = op->drives[0];
  EXPECT_EQ(r.state, "ROLLED_BACK");
  EXPECT_EQ(r.failed_parameter, "p3");
  EXPECT_EQ(r.error, "read back 37, wrote 30");
  EXPECT_EQ(a.Value(1), 1);
  EXPECT_EQ(a.Value(3), 3);
  // Undo order: p3 (the mismatching one) first, then p1.
  const std::vector<std::pair<uint32_t, int64_t>> writes = {{1, 10}, {3, 37}, {3, 3}, {1, 1}};
  EXPECT_EQ(a.writes(), writes);
}

TEST_F(ParameterApplyTest, RollbackFailureNamesWhatCouldNotBeRestored) {
  MapDrive& a = AddDrive("x1");
  a.SetFaults({.refuse_write = 2, .refuse_after_failure = true});  // p4 refused, then offline
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED_ROLLBACK");
  const auto& r = op->drives[0];
  EXPECT_EQ(r.state, "ROLLBACK_FAILED");
  EXPECT_EQ(r.failed_parameter, "p4");
  EXPECT_THAT(r.error, HasSubstr("refused 4"));
  EXPECT_THAT(r.error,
              HasSubstr("not restored: p3 (drive 'x1': offline), p1 (drive 'x1': offline)"));
  // What is still on the drive stays listed.
  const std::vector<ParameterValue> still = {{"p1", 1, 10}, {"p3", 3, 30}};
  EXPECT_EQ(r.written, still);
  EXPECT_EQ(a.Value(1), 10);

  auto stored = repo_->GetOperation(op->id);
  ASSERT_TRUE(stored.ok()) << stored.status();
  EXPECT_EQ(stored->state, "FAILED_ROLLBACK");
  EXPECT_EQ(stored->drives[0].error, r.error);
}

TEST_F(ParameterApplyTest, PreImageReadFailureWritesNothing) {
  MapDrive& a = AddDrive("x1");
  a.SetFaults({.refuse_read = 4});
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED");
  EXPECT_EQ(op->drives[0].failed_parameter, "p4");
  EXPECT_THAT(op->drives[0].error, HasSubstr("reading the pre-image: drive 'x1': no answer"));
  EXPECT_EQ(a.write_calls(), 0);
}

TEST_F(ParameterApplyTest, MultiDriveStopsAtTheFirstFailingDrive) {
  MapDrive& a = AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  MapDrive& c = AddDrive("x3");
  b.SetFaults({.mismatch = 2});
  auto op = applier_->Run(Request(Standard()));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED");
  ASSERT_EQ(op->drives.size(), 3u);
  EXPECT_EQ(op->drives[0].state, "APPLIED");
  EXPECT_EQ(op->drives[1].state, "ROLLED_BACK");
  EXPECT_EQ(op->drives[1].failed_parameter, "p4");
  EXPECT_EQ(op->drives[1].error, "read back 47, wrote 40");
  EXPECT_EQ(op->drives[2].state, "PENDING");
  // The first drive keeps the set (it was applied and verified); the third was never touched.
  EXPECT_EQ(a.Value(4), 40);
  EXPECT_EQ(b.Value(1), 1);
  EXPECT_EQ(b.Value(4), 4);
  EXPECT_EQ(c.write_calls(), 0);
}

TEST_F(ParameterApplyTest, StoredTargetWritesTheRomValue) {
  MapDrive& a = AddDrive("x1");
  a.SetRom(1, 100);
  auto set = Set({{"p1", 1, 200}});
  set.target_stored = true;
  auto op = applier_->Run(Request(set));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->drives[0].state, "APPLIED");
  EXPECT_EQ(op->drives[0].pre_image[0].value, 100);
  EXPECT_EQ(a.Value(1, /*rom=*/true), 200);
  EXPECT_EQ(a.Value(1), 1);  // RAM untouched
}

TEST_F(ParameterApplyTest, StartRunsInTheBackgroundAndStoresProgressPerDrive) {
  AddDrive("x1");
  MapDrive& b = AddDrive("x2");
  // When the second drive is read, the first drive's result is already stored, RUNNING.
  std::vector<ApplyOperation> seen;
  std::promise<std::string> started_id;
  auto id_future = started_id.get_future().share();
  b.before_read = [&] {
    if (!seen.empty()) return;
    auto stored = repo_->GetOperation(id_future.get());
    if (stored.ok()) seen.push_back(*stored);
  };
  std::promise<ApplyOperation> done;
  auto final_op = done.get_future();
  auto op =
      applier_->Start(Request(Standard()), [&](const ApplyOperation& o) { done.set_value(o); });
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "RUNNING");
  EXPECT_EQ(op->drives[0].state, "PENDING");
  started_id.set_value(op->id);
  ASSERT_EQ(final_op.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  ApplyOperation f = final_op.get();
  EXPECT_EQ(f.id, op->id);
  EXPECT_EQ(f.state, "SUCCEEDED");
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].state, "RUNNING");
  EXPECT_EQ(seen[0].drives[0].state, "APPLIED");
  EXPECT_EQ(seen[0].drives[1].state, "PENDING");
  auto stored = repo_->GetOperation(op->id);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, "SUCCEEDED");

  // A refused request is refused synchronously by Start as well.
  auto bad = Standard();
  bad.values[0].value = -1;
  EXPECT_EQ(applier_->Start(Request(bad)).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(ParameterApplyTest, DestructorWaitsForARunningOperation) {
  AddDrive("x1");
  std::atomic<bool> finished{false};
  auto op = applier_->Start(Request(Standard()), [&](const ApplyOperation&) { finished = true; });
  ASSERT_TRUE(op.ok()) << op.status();
  applier_.reset();
  EXPECT_TRUE(finished.load());
}

}  // namespace
}  // namespace drivegw::server
