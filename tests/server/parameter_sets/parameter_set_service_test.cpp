// ParameterSetServiceCore against a real temp SQLite repo, the real ParameterApplier and map-backed
// fake drives (tests/server/apply/map_drive.h): name resolution through the catalogue, validation
// naming field and limit, etag conflicts, versions, capture, diff, apply operations, import/export
// round trips, and the audit entries of every mutating call (issue 6, decision 011).
#include "server/core/parameter_set_service.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "google/rpc/error_details.pb.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "tests/server/apply/map_drive.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using test_support::MapDrive;
using ::testing::HasSubstr;

// Family "fake": p1..p5 = ids 1..5, range 0..1000, p5 read-only.
class FakeCatalogue final : public ParameterCatalogue {
 public:
  FakeCatalogue() {
    for (uint32_t i = 1; i <= 5; ++i) {
      ParameterDefinition d;
      d.id = i;
      d.name = "p" + std::to_string(i);
      d.title = i == 1 ? "maximal velocity" : "param";
      d.type = "i32";
      d.min = 0;
      d.max = 1000;
      d.writable = i != 5;
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

std::string Msg(const absl::Status& s) { return std::string(s.message()); }

// The google.rpc.BadRequest field names of an error.
std::vector<std::string> Fields(const absl::Status& s) {
  std::vector<std::string> out;
  auto p = s.GetPayload("type.googleapis.com/google.rpc.BadRequest");
  google::rpc::BadRequest br;
  if (p && br.ParseFromString(std::string(*p))) {
    for (const auto& v : br.field_violations()) out.push_back(v.field());
  }
  return out;
}

class ParameterSetServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("gw.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(*std::move(db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    repo_ = std::make_unique<storage::ParameterSetRepo>(*db_);
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    catalogues_.push_back(std::make_shared<FakeCatalogue>());
    applier_ = std::make_unique<ParameterApplier>(*repo_, catalogues_);
    x1_ = std::make_shared<MapDrive>(
        "x1", "fake", std::map<uint32_t, int64_t>{{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}});
    x2_ = std::make_shared<MapDrive>(
        "x2", "fake", std::map<uint32_t, int64_t>{{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}});
    other_ = std::make_shared<MapDrive>("o1", "other", std::map<uint32_t, int64_t>{{1, 1}});
    core_ = std::make_unique<ParameterSetServiceCore>(
        *repo_, *applier_, catalogues_, std::vector<std::shared_ptr<Drive>>{x1_, x2_, other_},
        audit_.get());
    ctx_.principal = "alice";
    ctx_.transport = "grpc";
  }
  void TearDown() override {
    core_.reset();
    applier_.reset();  // waits for running operations
  }

  v1::ParameterSet Create(const std::string& name,
                          std::vector<std::pair<std::string, int64_t>> values) {
    v1::CreateParameterSetRequest r;
    r.mutable_parameter_set()->set_name("parameterSets/" + name);
    r.mutable_parameter_set()->set_family("fake");
    for (auto& [p, v] : values) {
      auto* pv = r.mutable_parameter_set()->add_parameters();
      pv->set_parameter(p);
      pv->set_value(v);
    }
    auto s = core_->CreateParameterSet(r, ctx_);
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *s : v1::ParameterSet();
  }
  std::vector<storage::AuditRecord> Audit(const std::string& action) {
    storage::AuditQuery q;
    q.action = action;
    auto r = audit_->Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<storage::AuditRecord>{};
  }
  // The finished-operation entry is written by the applier's on_done, which runs just after the
  // stored operation turns done: poll for it.
  std::vector<storage::AuditRecord> WaitAudit(const std::string& action, size_t n) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    auto records = Audit(action);
    while (records.size() < n && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      records = Audit(action);
    }
    return records;
  }
  v1::Operation WaitDone(const std::string& name) {
    v1::GetOperationRequest g;
    g.set_name(name);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline) {
      auto op = core_->GetOperation(g, ctx_);
      EXPECT_TRUE(op.ok()) << op.status();
      if (!op.ok() || op->done()) return op.ok() ? *op : v1::Operation();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // polling, not a timing assert
    }
    ADD_FAILURE() << name << " not done within 10 s";
    return {};
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::ParameterSetRepo> repo_;
  std::unique_ptr<storage::AuditLog> audit_;
  CatalogueList catalogues_;
  std::unique_ptr<ParameterApplier> applier_;
  std::shared_ptr<MapDrive> x1_, x2_, other_;
  std::unique_ptr<ParameterSetServiceCore> core_;
  CallContext ctx_;
};

TEST_F(ParameterSetServiceTest, ListDefinitionsFiltersAndNamesUnknownFamily) {
  v1::ListParameterDefinitionsRequest r;
  r.set_family("fake");
  auto all = core_->ListParameterDefinitions(r, ctx_);
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->definitions_size(), 5);
  r.set_filter("VELOCITY");
  auto some = core_->ListParameterDefinitions(r, ctx_);
  ASSERT_TRUE(some.ok());
  ASSERT_EQ(some->definitions_size(), 1);
  EXPECT_EQ(some->definitions(0).name(), "p1");
  EXPECT_EQ(some->definitions(0).max(), 1000);
  r.set_family("nope");
  auto bad = core_->ListParameterDefinitions(r, ctx_);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Msg(bad.status()), HasSubstr("unknown family 'nope' (known: fake)"));
}

TEST_F(ParameterSetServiceTest, CreateResolvesCanonicalNameAndIdAndAudits) {
  v1::ParameterSet s = Create("tuning", {{"3", 30}, {"p1", 10}});
  EXPECT_EQ(s.name(), "parameterSets/tuning");
  EXPECT_EQ(s.version(), 1);
  EXPECT_FALSE(s.etag().empty());
  ASSERT_EQ(s.parameters_size(), 2);
  EXPECT_EQ(s.parameters(0).parameter(), "p3");
  EXPECT_EQ(s.parameters(0).id(), 3u);
  EXPECT_EQ(s.author(), "alice");
  auto audit = Audit("CreateParameterSet");
  ASSERT_EQ(audit.size(), 1u);
  EXPECT_EQ(audit[0].result_code, 0);
  EXPECT_THAT(audit[0].request_json, HasSubstr("\"after\""));
  EXPECT_THAT(audit[0].request_json, HasSubstr("p3"));
}

TEST_F(ParameterSetServiceTest, CreateValidationNamesFieldParameterAndLimit) {
  v1::CreateParameterSetRequest r;
  r.mutable_parameter_set()->set_name("bad");
  r.mutable_parameter_set()->set_family("fake");
  auto* a = r.mutable_parameter_set()->add_parameters();
  a->set_parameter("p1");
  a->set_value(1001);
  auto* b = r.mutable_parameter_set()->add_parameters();
  b->set_parameter("p9");
  auto* c = r.mutable_parameter_set()->add_parameters();
  c->set_parameter("p5");
  auto* d = r.mutable_parameter_set()->add_parameters();
  d->set_parameter("1");
  auto s = core_->CreateParameterSet(r, ctx_);
  ASSERT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Msg(s.status()), HasSubstr("p1: 1001 is outside 0..1000"));
  EXPECT_THAT(Fields(s.status()), ::testing::ElementsAre("parameter_set.parameters[0].value",
                                                         "parameter_set.parameters[1].parameter",
                                                         "parameter_set.parameters[2].value",
                                                         "parameter_set.parameters[3].parameter"));
  // Refused creates are audited too, with the error.
  auto audit = Audit("CreateParameterSet");
  ASSERT_EQ(audit.size(), 1u);
  EXPECT_EQ(audit[0].result_code, static_cast<int>(absl::StatusCode::kInvalidArgument));

  r.mutable_parameter_set()->clear_parameters();
  r.mutable_parameter_set()->set_name("a/b");
  EXPECT_THAT(Fields(core_->CreateParameterSet(r, ctx_).status()),
              ::testing::ElementsAre("parameter_set.name"));
}

TEST_F(ParameterSetServiceTest, UpdateNeedsCurrentEtagAndNamesTheVersion) {
  v1::ParameterSet s = Create("tuning", {{"p1", 10}});
  v1::UpdateParameterSetRequest u;
  *u.mutable_parameter_set() = s;
  u.mutable_parameter_set()->mutable_parameters(0)->set_value(20);
  // No etag: InvalidArgument naming the field.
  EXPECT_THAT(Fields(core_->UpdateParameterSet(u, ctx_).status()), ::testing::ElementsAre("etag"));
  u.set_etag(s.etag());
  auto v2 = core_->UpdateParameterSet(u, ctx_);
  ASSERT_TRUE(v2.ok()) << v2.status();
  EXPECT_EQ(v2->version(), 2);
  EXPECT_NE(v2->etag(), s.etag());
  // The old etag again: stale.
  auto stale = core_->UpdateParameterSet(u, ctx_);
  ASSERT_EQ(stale.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(Msg(stale.status()), HasSubstr("version 2"));
  auto pf = stale.status().GetPayload("type.googleapis.com/google.rpc.PreconditionFailure");
  ASSERT_TRUE(pf.has_value());
  google::rpc::PreconditionFailure detail;
  ASSERT_TRUE(detail.ParseFromString(std::string(*pf)));
  EXPECT_EQ(detail.violations(0).type(), "ETAG");
  EXPECT_EQ(detail.violations(0).subject(), "parameterSets/tuning");
  // Out of range on update names the field too.
  u.set_etag(v2->etag());
  u.mutable_parameter_set()->mutable_parameters(0)->set_value(-1);
  EXPECT_THAT(Fields(core_->UpdateParameterSet(u, ctx_).status()),
              ::testing::ElementsAre("parameter_set.parameters[0].value"));

  auto audit = Audit("UpdateParameterSet");
  ASSERT_EQ(audit.size(), 4u);
  // Newest first: the successful one is the third from the top.
  EXPECT_EQ(audit[2].result_code, 0);
  EXPECT_THAT(audit[2].request_json, HasSubstr("\"before\""));
  EXPECT_THAT(audit[2].request_json, HasSubstr("\"after\""));

  v1::ListParameterSetVersionsRequest lv;
  lv.set_name("tuning");
  auto versions = core_->ListParameterSetVersions(lv, ctx_);
  ASSERT_TRUE(versions.ok()) << versions.status();
  ASSERT_EQ(versions->versions_size(), 2);
  EXPECT_EQ(versions->versions(0).version(), 2);
  v1::GetParameterSetVersionRequest gv;
  gv.set_name("parameterSets/tuning");
  gv.set_version(1);
  auto v1r = core_->GetParameterSetVersion(gv, ctx_);
  ASSERT_TRUE(v1r.ok()) << v1r.status();
  EXPECT_EQ(v1r->parameters(0).value(), 10);
}

TEST_F(ParameterSetServiceTest, DeleteNeedsEtag) {
  v1::ParameterSet s = Create("gone", {{"p1", 10}});
  v1::DeleteParameterSetRequest d;
  d.set_name(s.name());
  EXPECT_THAT(Fields(core_->DeleteParameterSet(d, ctx_).status()), ::testing::ElementsAre("etag"));
  d.set_etag("stale");
  EXPECT_EQ(core_->DeleteParameterSet(d, ctx_).status().code(),
            absl::StatusCode::kFailedPrecondition);
  d.set_etag(s.etag());
  ASSERT_TRUE(core_->DeleteParameterSet(d, ctx_).ok());
  v1::GetParameterSetRequest g;
  g.set_name(s.name());
  EXPECT_EQ(core_->GetParameterSet(g, ctx_).status().code(), absl::StatusCode::kNotFound);
  auto audit = Audit("DeleteParameterSet");
  ASSERT_EQ(audit.size(), 3u);
  EXPECT_EQ(audit[0].result_code, 0);
  EXPECT_THAT(audit[0].request_json, HasSubstr("\"before\""));
}

TEST_F(ParameterSetServiceTest, ListPagesByName) {
  for (const char* n : {"c", "a", "b"}) Create(n, {{"p1", 1}});
  v1::ListParameterSetsRequest r;
  r.set_page_size(2);
  auto p1 = core_->ListParameterSets(r, ctx_);
  ASSERT_TRUE(p1.ok()) << p1.status();
  ASSERT_EQ(p1->parameter_sets_size(), 2);
  EXPECT_EQ(p1->parameter_sets(0).name(), "parameterSets/a");
  EXPECT_EQ(p1->next_page_token(), "b");
  r.set_page_token(p1->next_page_token());
  auto p2 = core_->ListParameterSets(r, ctx_);
  ASSERT_TRUE(p2.ok());
  ASSERT_EQ(p2->parameter_sets_size(), 1);
  EXPECT_EQ(p2->parameter_sets(0).name(), "parameterSets/c");
  EXPECT_TRUE(p2->next_page_token().empty());
  r.set_page_size(1001);
  EXPECT_THAT(Msg(core_->ListParameterSets(r, ctx_).status()), HasSubstr("0..1000"));
}

// Gap 14 (decision 1494): a page token List cannot have handed out is refused naming page_token
// and the rule, instead of paging from wherever the bytes sort.
TEST_F(ParameterSetServiceTest, ListMalformedPageToken_InvalidArgumentNamingTheRule) {
  for (const char* n : {"a", "b"}) Create(n, {{"p1", 1}});
  v1::ListParameterSetsRequest r;
  r.set_page_token("a' OR 1=1 --");
  auto bad = core_->ListParameterSets(r, ctx_);
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(bad.status()),
            "page_token: 'a' OR 1=1 --' is not a token this service handed out (character at "
            "index 1; a token is the last set name of a page: 1..128 characters of "
            "[A-Za-z0-9._-])");
  r.set_page_token(std::string(129, 'a'));
  EXPECT_EQ(Msg(core_->ListParameterSets(r, ctx_).status()),
            "page_token: 129 bytes exceed 128 (a token is the last set name of a page: 1..128 "
            "characters of [A-Za-z0-9._-])");
  r.set_page_token(std::string("a\0b", 3));
  EXPECT_EQ(core_->ListParameterSets(r, ctx_).status().code(), absl::StatusCode::kInvalidArgument);
  // A well-formed token of a set deleted since is still a position: the page after it.
  r.set_page_token("a0");
  auto after = core_->ListParameterSets(r, ctx_);
  ASSERT_TRUE(after.ok()) << after.status();
  ASSERT_EQ(after->parameter_sets_size(), 1);
  EXPECT_EQ(after->parameter_sets(0).name(), "parameterSets/b");
}

// Gap 14: a negative version names its own field and the limit, whether the set exists or not.
TEST_F(ParameterSetServiceTest, NegativeVersions_InvalidArgumentNamingFieldAndLimit) {
  Create("a", {{"p1", 1}});
  v1::ExportParameterSetRequest e;
  e.set_name("a");
  e.set_version(-3);
  e.set_format(v1::PARAMETER_SET_FORMAT_JSON);
  EXPECT_EQ(Msg(core_->ExportParameterSet(e, ctx_).status()), "version: -3 is below 0");
  e.set_name("missing");
  EXPECT_EQ(Msg(core_->ExportParameterSet(e, ctx_).status()), "version: -3 is below 0");
  v1::DiffParameterSetRequest d;
  d.set_name("a");
  d.set_other_version(-1);
  auto diff = core_->DiffParameterSet(d, ctx_);
  EXPECT_EQ(diff.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(diff.status()), "other_version: -1 is below 0");
  v1::GetParameterSetVersionRequest g;
  g.set_name("a");
  g.set_version(-1);
  EXPECT_EQ(Msg(core_->GetParameterSetVersion(g, ctx_).status()), "version: -1 is below 1");
  v1::ApplyParameterSetRequest a;
  a.set_name("a");
  a.add_drives("x1");
  a.set_version(-2);
  auto applied = core_->ApplyParameterSet(a, ctx_);
  EXPECT_EQ(applied.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(applied.status()), "version: -2 is below 0");
}

TEST_F(ParameterSetServiceTest, CaptureNewSetThenNewVersion) {
  x1_->WriteParameter(ParameterRef{2, false}, 222).IgnoreError();
  v1::CaptureParameterSetRequest c;
  c.set_name("captured");
  c.set_drive("drives/x1");
  c.add_parameters("p2");
  c.add_parameters("4");
  auto s = core_->CaptureParameterSet(c, ctx_);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->family(), "fake");
  ASSERT_EQ(s->parameters_size(), 2);
  EXPECT_EQ(s->parameters(0).value(), 222);
  EXPECT_EQ(s->parameters(1).parameter(), "p4");
  EXPECT_EQ(s->parameters(1).value(), 4);
  // Existing set: etag required, then the same parameters again as version 2.
  x1_->WriteParameter(ParameterRef{4, false}, 444).IgnoreError();
  c.clear_parameters();
  EXPECT_THAT(Fields(core_->CaptureParameterSet(c, ctx_).status()), ::testing::ElementsAre("etag"));
  c.set_etag(s->etag());
  auto v2 = core_->CaptureParameterSet(c, ctx_);
  ASSERT_TRUE(v2.ok()) << v2.status();
  EXPECT_EQ(v2->version(), 2);
  EXPECT_EQ(v2->parameters(1).value(), 444);
  // A drive of another family is refused naming the field.
  c.set_drive("o1");
  EXPECT_THAT(Fields(core_->CaptureParameterSet(c, ctx_).status()),
              ::testing::ElementsAre("drive"));
  c.set_drive("drives/zz");
  EXPECT_EQ(core_->CaptureParameterSet(c, ctx_).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(ParameterSetServiceTest, DiffAgainstDriveAndVersions) {
  v1::ParameterSet s = Create("tuning", {{"p1", 10}, {"p2", 2}});
  v1::DiffParameterSetRequest d;
  d.set_name(s.name());
  d.set_drive("x1");
  auto vs_drive = core_->DiffParameterSet(d, ctx_);
  ASSERT_TRUE(vs_drive.ok()) << vs_drive.status();
  ASSERT_EQ(vs_drive->parameters_size(), 2);
  EXPECT_EQ(vs_drive->differing(), 1);
  EXPECT_EQ(vs_drive->parameters(0).a(), 10);
  EXPECT_EQ(vs_drive->parameters(0).b(), 1);
  EXPECT_TRUE(vs_drive->parameters(0).differs());
  EXPECT_FALSE(vs_drive->parameters(1).differs());

  v1::UpdateParameterSetRequest u;
  *u.mutable_parameter_set() = s;
  u.mutable_parameter_set()->clear_parameters();
  auto* p = u.mutable_parameter_set()->add_parameters();
  p->set_parameter("p1");
  p->set_value(10);
  p = u.mutable_parameter_set()->add_parameters();
  p->set_parameter("p3");
  p->set_value(33);
  u.set_etag(s.etag());
  ASSERT_TRUE(core_->UpdateParameterSet(u, ctx_).ok());
  v1::DiffParameterSetRequest dv;
  dv.set_name(s.name());
  dv.set_other_version(1);  // newest (2) vs 1
  auto vs_version = core_->DiffParameterSet(dv, ctx_);
  ASSERT_TRUE(vs_version.ok()) << vs_version.status();
  ASSERT_EQ(vs_version->parameters_size(), 3);  // p1 same, p3 only in a, p2 only in b
  EXPECT_EQ(vs_version->differing(), 2);
  EXPECT_FALSE(vs_version->parameters(0).differs());
  EXPECT_EQ(vs_version->parameters(1).parameter(), "p3");
  EXPECT_TRUE(vs_version->parameters(1).in_a());
  EXPECT_FALSE(vs_version->parameters(1).in_b());
  EXPECT_EQ(vs_version->parameters(2).parameter(), "p2");
  EXPECT_FALSE(vs_version->parameters(2).in_a());

  v1::DiffParameterSetRequest none;
  none.set_name(s.name());
  EXPECT_THAT(Fields(core_->DiffParameterSet(none, ctx_).status()),
              ::testing::ElementsAre("other"));
}

TEST_F(ParameterSetServiceTest, ApplyDryRunThenRealReturnsOperationAtOnceAndAudits) {
  v1::ParameterSet s = Create("tuning", {{"p1", 10}, {"p3", 30}});
  v1::ApplyParameterSetRequest a;
  a.set_name(s.name());
  a.add_drives("x1");
  a.add_drives("drives/x2");
  a.set_dry_run(true);
  auto dry = core_->ApplyParameterSet(a, ctx_);
  ASSERT_TRUE(dry.ok()) << dry.status();
  EXPECT_THAT(dry->name(), ::testing::StartsWith("operations/op-"));
  v1::Operation dry_done = WaitDone(dry->name());
  EXPECT_EQ(dry_done.state(), "SUCCEEDED");
  EXPECT_TRUE(dry_done.dry_run());
  EXPECT_EQ(x1_->write_calls(), 0);

  a.set_dry_run(false);
  auto op = core_->ApplyParameterSet(a, ctx_);
  ASSERT_TRUE(op.ok()) << op.status();
  v1::Operation done = WaitDone(op->name());
  EXPECT_EQ(done.state(), "SUCCEEDED");
  ASSERT_EQ(done.drives_size(), 2);
  EXPECT_EQ(done.drives(0).drive(), "drives/x1");
  EXPECT_EQ(done.drives(0).state(), "APPLIED");
  ASSERT_EQ(done.drives(0).pre_image_size(), 2);
  EXPECT_EQ(done.drives(0).pre_image(0).value(), 1);
  EXPECT_EQ(x1_->Value(1), 10);
  EXPECT_EQ(x2_->Value(3), 30);

  v1::ListOperationsRequest l;
  auto ops = core_->ListOperations(l, ctx_);
  ASSERT_TRUE(ops.ok());
  EXPECT_EQ(ops->operations_size(), 2);

  // Started and finished entries for both applies.
  EXPECT_EQ(Audit("ApplyParameterSet").size(), 2u);
  const auto finished = WaitAudit("ApplyParameterSet.done", 2);
  ASSERT_EQ(finished.size(), 2u);
  EXPECT_EQ(finished[0].drive, "x1,x2");
  EXPECT_THAT(finished[0].request_json, HasSubstr("pre_image"));
}

TEST_F(ParameterSetServiceTest, ApplyRefusesWrongFamilyUnknownDriveAndNoDrives) {
  v1::ParameterSet s = Create("tuning", {{"p1", 10}});
  v1::ApplyParameterSetRequest a;
  a.set_name(s.name());
  EXPECT_THAT(Fields(core_->ApplyParameterSet(a, ctx_).status()), ::testing::ElementsAre("drives"));
  a.add_drives("x1");
  a.add_drives("o1");
  auto wrong = core_->ApplyParameterSet(a, ctx_);
  EXPECT_THAT(Fields(wrong.status()), ::testing::ElementsAre("drives[1]"));
  EXPECT_THAT(Msg(wrong.status()), HasSubstr("is a other drive; set 'tuning' is for fake"));
  a.set_drives(1, "nope");
  EXPECT_EQ(core_->ApplyParameterSet(a, ctx_).status().code(), absl::StatusCode::kNotFound);
  a.set_version(7);
  a.clear_drives();
  a.add_drives("x1");
  EXPECT_EQ(core_->ApplyParameterSet(a, ctx_).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(x1_->write_calls(), 0);
  EXPECT_EQ(Audit("ApplyParameterSet").size(), 4u);
}

TEST_F(ParameterSetServiceTest, ImportExportRoundTripJsonAndCsv) {
  v1::ImportParameterSetRequest im;
  im.set_format(v1::PARAMETER_SET_FORMAT_JSON);
  im.set_content(R"({"name": "imported", "family": "fake", "description": "from file",
    "parameters": [{"parameter": "p2", "value": 20}, {"parameter": "4", "value": 40}]})");
  auto s = core_->ImportParameterSet(im, ctx_);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->parameters(1).parameter(), "p4");
  EXPECT_EQ(s->description(), "from file");

  v1::ExportParameterSetRequest ex;
  ex.set_name(s->name());
  ex.set_format(v1::PARAMETER_SET_FORMAT_CSV);
  auto csv = core_->ExportParameterSet(ex, ctx_);
  ASSERT_TRUE(csv.ok()) << csv.status();
  EXPECT_EQ(csv->content_type(), "text/csv");
  EXPECT_THAT(csv->content(), HasSubstr("parameter,value\np2,20\np4,40\n"));

  // The CSV back in as a new version of the same set: etag required.
  v1::ImportParameterSetRequest back;
  back.set_format(v1::PARAMETER_SET_FORMAT_CSV);
  back.set_content(csv->content() + "p1,5\n");
  back.set_name("imported");
  back.set_family("fake");
  EXPECT_THAT(Fields(core_->ImportParameterSet(back, ctx_).status()),
              ::testing::ElementsAre("etag"));
  back.set_etag(s->etag());
  auto v2 = core_->ImportParameterSet(back, ctx_);
  ASSERT_TRUE(v2.ok()) << v2.status();
  EXPECT_EQ(v2->version(), 2);
  EXPECT_EQ(v2->parameters_size(), 3);
  EXPECT_EQ(v2->description(), "from file");  // CSV carries values only

  ex.set_format(v1::PARAMETER_SET_FORMAT_JSON);
  ex.set_version(1);
  auto json = core_->ExportParameterSet(ex, ctx_);
  ASSERT_TRUE(json.ok()) << json.status();
  v1::ImportParameterSetRequest again;
  again.set_format(v1::PARAMETER_SET_FORMAT_JSON);
  again.set_content(json->content());
  again.set_name("copy");
  auto copy = core_->ImportParameterSet(again, ctx_);
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ(copy->family(), "fake");
  ASSERT_EQ(copy->parameters_size(), 2);
  EXPECT_EQ(copy->parameters(0).value(), 20);

  auto audit = Audit("ImportParameterSet");
  ASSERT_EQ(audit.size(), 4u);
  EXPECT_EQ(audit[0].result_code, 0);
}

TEST_F(ParameterSetServiceTest, ImportErrorsNameLineFieldParameterAndLimit) {
  v1::ImportParameterSetRequest im;
  im.set_format(v1::PARAMETER_SET_FORMAT_CSV);
  im.set_name("x");
  im.set_family("fake");
  im.set_content("parameter,value\np1,1\n\n# c\n\n\np2,abc\n");
  auto bad = core_->ImportParameterSet(im, ctx_);
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(bad.status()), "content: line 7, field value: 'abc' is not an integer");
  EXPECT_THAT(Fields(bad.status()), ::testing::ElementsAre("content"));

  im.set_content("parameter,value\np1,5000\n");
  auto range = core_->ImportParameterSet(im, ctx_);
  EXPECT_THAT(Msg(range.status()), HasSubstr("p1: 5000 is outside 0..1000"));
  EXPECT_THAT(Fields(range.status()), ::testing::ElementsAre("content.parameters[0].value"));

  im.set_content("parameter,value\np1,5\n");
  im.set_family("");
  EXPECT_THAT(Fields(core_->ImportParameterSet(im, ctx_).status()),
              ::testing::ElementsAre("family"));
  im.set_format(v1::PARAMETER_SET_FORMAT_UNSPECIFIED);
  EXPECT_THAT(Fields(core_->ImportParameterSet(im, ctx_).status()),
              ::testing::ElementsAre("format"));
  EXPECT_EQ(Audit("ImportParameterSet").size(), 4u);
}

TEST_F(ParameterSetServiceTest, OperationNamesAreChecked) {
  v1::GetOperationRequest g;
  g.set_name("operations/op-999");
  EXPECT_EQ(core_->GetOperation(g, ctx_).status().code(), absl::StatusCode::kNotFound);
  g.set_name("operations/a/b");
  EXPECT_THAT(Fields(core_->GetOperation(g, ctx_).status()), ::testing::ElementsAre("name"));
}

}  // namespace
}  // namespace drivegw::server
