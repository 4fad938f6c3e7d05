// CurveSetServiceCore against a real temp SQLite repo and curve-recording test drives
// (curve_drive.h): CRUD and versions, etag conflicts, every shape violation named at once, plots
// of a known curve (p = t² -> v = 2t, a = 2), validation against a drive's axis naming field and
// limit, download to the LinMot wire form, runs, the FailedPrecondition mapping of families without
// curve support, and the audit entries of every mutating call (issue 6, decision 014).
#include "server/core/curve_set_service.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "google/rpc/error_details.pb.h"
#include "server/core/curve_set_io.h"
#include "storage/audit_log.h"
#include "storage/curve_set_repo.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/server/curve_sets/curve_drive.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using test_support::CurveDrive;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;

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

// p = t² mm at t = 0, 0.1, ..., 2 s: v = 2t mm/s, a = 2 mm/s² (decision 012: central differences
// are exact for a parabola inside).
v1::Curve Parabola(const std::string& name) {
  v1::Curve c;
  c.set_name(name);
  c.set_description("p = t^2");
  c.mutable_position_time()->set_time_step_s(0.1);
  for (int i = 0; i <= 20; ++i) {
    const double t = 0.1 * i;
    c.mutable_position_time()->add_positions_mm(t * t);
  }
  return c;
}

// LinMot curve ID `id`: 0, 1, 2 mm in 0.1 um, 0.2 s.
v1::Curve LinMot(const std::string& name, int id) {
  v1::Curve c;
  c.set_name(name);
  auto* l = c.mutable_linmot();
  l->set_curve_id(id);
  l->set_x_length_s(0.2);
  l->add_points(0);
  l->add_points(10000);
  l->add_points(20000);
  return c;
}

// Two points 81.24 mm apart in 0.1 s: 812.4 mm/s everywhere, beyond the 500 mm/s test axis.
v1::Curve TooFast(const std::string& name) {
  v1::Curve c;
  c.set_name(name);
  c.mutable_position_time()->set_time_step_s(0.1);
  c.mutable_position_time()->add_positions_mm(0);
  c.mutable_position_time()->add_positions_mm(81.24);
  return c;
}

class CurveSetServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("gw.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(*std::move(db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    repo_ = std::make_unique<storage::CurveSetRepo>(*db_);
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    x1_ = std::make_shared<CurveDrive>("x1", "linmot", true, true);
    s1_ = std::make_shared<CurveDrive>("s1", "stober", false, true);
    t1_ = std::make_shared<CurveDrive>("t1", "trinamic", false, false);
    core_ = std::make_unique<CurveSetServiceCore>(
        *repo_, std::vector<std::shared_ptr<Drive>>{x1_, s1_, t1_}, audit_.get());
    ctx_.principal = "alice";
    ctx_.transport = "grpc";
  }

  v1::CurveSet Create(const std::string& name, std::vector<v1::Curve> curves) {
    v1::CreateCurveSetRequest r;
    r.mutable_curve_set()->set_name("curveSets/" + name);
    r.mutable_curve_set()->set_description("press line");
    for (auto& c : curves) *r.mutable_curve_set()->add_curves() = std::move(c);
    auto s = core_->CreateCurveSet(r, ctx_);
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *s : v1::CurveSet();
  }
  std::vector<storage::AuditRecord> Audit(const std::string& action) {
    storage::AuditQuery q;
    q.action = action;
    auto r = audit_->Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<storage::AuditRecord>{};
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::CurveSetRepo> repo_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::shared_ptr<CurveDrive> x1_, s1_, t1_;
  std::unique_ptr<CurveSetServiceCore> core_;
  CallContext ctx_;
};

TEST_F(CurveSetServiceTest, CreateGetListUpdateVersions_RoundTripAndNewVersion) {
  const v1::CurveSet created = Create("press", {Parabola("lift"), LinMot("cam", 5)});
  EXPECT_EQ(created.name(), "curveSets/press");
  EXPECT_EQ(created.version(), 1);
  EXPECT_EQ(created.author(), "alice");
  EXPECT_EQ(created.etag().size(), 32u);
  ASSERT_EQ(created.curves_size(), 2);
  EXPECT_EQ(created.curves(0).position_time().positions_mm_size(), 21);
  // Absent LinMot scales are 100 % and come back explicit.
  EXPECT_EQ(created.curves(1).linmot().amplitude_scale_pct().value(), 100);
  EXPECT_EQ(created.curves(1).linmot().time_scale_pct().value(), 100);
  EXPECT_EQ(created.curves(1).linmot().y_unit(), v1::LINMOT_Y_UNIT_POSITION_0P1UM);

  v1::GetCurveSetRequest g;
  g.set_name("press");  // the short name is accepted
  auto got = core_->GetCurveSet(g, ctx_);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->SerializeAsString(), created.SerializeAsString());

  Create("other", {Parabola("lift")});
  v1::ListCurveSetsRequest l;
  l.set_page_size(1);
  auto page = core_->ListCurveSets(l, ctx_);
  ASSERT_TRUE(page.ok()) << page.status();
  ASSERT_EQ(page->curve_sets_size(), 1);
  EXPECT_EQ(page->curve_sets(0).name(), "curveSets/other");
  l.set_page_token(page->next_page_token());
  auto page2 = core_->ListCurveSets(l, ctx_);
  ASSERT_TRUE(page2.ok()) << page2.status();
  ASSERT_EQ(page2->curve_sets_size(), 1);
  EXPECT_EQ(page2->curve_sets(0).name(), "curveSets/press");
  EXPECT_EQ(page2->next_page_token(), "");

  v1::UpdateCurveSetRequest u;
  *u.mutable_curve_set() = created;
  u.mutable_curve_set()->mutable_curves()->RemoveLast();
  u.mutable_curve_set()->set_description("lift only");
  u.set_etag(created.etag());
  u.set_comment("drop the cam");
  auto updated = core_->UpdateCurveSet(u, ctx_);
  ASSERT_TRUE(updated.ok()) << updated.status();
  EXPECT_EQ(updated->version(), 2);
  EXPECT_NE(updated->etag(), created.etag());
  EXPECT_EQ(updated->curves_size(), 1);

  v1::ListCurveSetVersionsRequest lv;
  lv.set_name("curveSets/press");
  auto versions = core_->ListCurveSetVersions(lv, ctx_);
  ASSERT_TRUE(versions.ok()) << versions.status();
  ASSERT_EQ(versions->versions_size(), 2);
  EXPECT_EQ(versions->versions(0).version(), 2);  // newest first
  EXPECT_EQ(versions->versions(0).comment(), "drop the cam");
  v1::GetCurveSetVersionRequest gv;
  gv.set_name("curveSets/press");
  gv.set_version(1);
  auto v1_ = core_->GetCurveSetVersion(gv, ctx_);
  ASSERT_TRUE(v1_.ok()) << v1_.status();
  EXPECT_EQ(v1_->curves_size(), 2);  // versions are immutable
  gv.set_version(0);
  EXPECT_EQ(core_->GetCurveSetVersion(gv, ctx_).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// Gap 14 (decision 1494): a page token List cannot have handed out is refused naming page_token.
TEST_F(CurveSetServiceTest, ListMalformedPageToken_InvalidArgumentNamingTheRule) {
  Create("a", {Parabola("lift")});
  Create("b", {Parabola("lift")});
  v1::ListCurveSetsRequest r;
  r.set_page_token("curveSets/a");
  auto bad = core_->ListCurveSets(r, ctx_);
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Fields(bad.status()), ElementsAre("page_token"));
  EXPECT_THAT(Msg(bad.status()), HasSubstr("'curveSets/a' is not a token this service handed out "
                                           "(character at index 9;"));
  r.set_page_token(std::string(300, 'z'));
  EXPECT_THAT(Msg(core_->ListCurveSets(r, ctx_).status()),
              HasSubstr("page_token: 300 bytes exceed 128"));
  r.set_page_size(1);
  r.clear_page_token();
  auto first = core_->ListCurveSets(r, ctx_);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->next_page_token(), "a");
  r.set_page_token(first->next_page_token());
  auto second = core_->ListCurveSets(r, ctx_);
  ASSERT_TRUE(second.ok()) << second.status();
  ASSERT_EQ(second->curve_sets_size(), 1);
  EXPECT_EQ(second->curve_sets(0).name(), "curveSets/b");
}

TEST_F(CurveSetServiceTest, UpdateDelete_StaleOrMissingEtag_RefusedWithEtagDetail) {
  const v1::CurveSet created = Create("press", {Parabola("lift")});
  v1::UpdateCurveSetRequest u;
  *u.mutable_curve_set() = created;
  auto missing = core_->UpdateCurveSet(u, ctx_);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Fields(missing.status()), ElementsAre("etag"));

  u.set_etag(created.etag());
  ASSERT_TRUE(core_->UpdateCurveSet(u, ctx_).ok());
  // The first etag is stale now.
  auto stale = core_->UpdateCurveSet(u, ctx_);
  ASSERT_EQ(stale.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(Msg(stale.status()), HasSubstr("version 2"));
  auto pf = stale.status().GetPayload("type.googleapis.com/google.rpc.PreconditionFailure");
  ASSERT_TRUE(pf.has_value());
  google::rpc::PreconditionFailure detail;
  ASSERT_TRUE(detail.ParseFromString(std::string(*pf)));
  ASSERT_EQ(detail.violations_size(), 1);
  EXPECT_EQ(detail.violations(0).type(), "ETAG");
  EXPECT_EQ(detail.violations(0).subject(), "curveSets/press");

  v1::DeleteCurveSetRequest d;
  d.set_name("curveSets/press");
  d.set_etag(created.etag());
  EXPECT_EQ(core_->DeleteCurveSet(d, ctx_).status().code(), absl::StatusCode::kFailedPrecondition);
  v1::GetCurveSetRequest g;
  g.set_name("curveSets/press");
  auto current = core_->GetCurveSet(g, ctx_);
  ASSERT_TRUE(current.ok());
  d.set_etag(current->etag());
  ASSERT_TRUE(core_->DeleteCurveSet(d, ctx_).ok());
  EXPECT_EQ(core_->GetCurveSet(g, ctx_).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(CurveSetServiceTest, Create_InvalidCurves_EveryViolationNamedNothingStored) {
  v1::Curve bad_step = Parabola("lift");
  bad_step.mutable_position_time()->set_time_step_s(-1);
  v1::Curve bad_id = LinMot("cam", 101);
  bad_id.mutable_linmot()->mutable_time_scale_pct()->set_value(0);
  v1::Curve dup = Parabola("lift");
  v1::CreateCurveSetRequest r;
  r.mutable_curve_set()->set_name("bad");
  *r.mutable_curve_set()->add_curves() = bad_step;
  *r.mutable_curve_set()->add_curves() = bad_id;
  *r.mutable_curve_set()->add_curves() = dup;
  auto s = core_->CreateCurveSet(r, ctx_);
  ASSERT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Msg(s.status()), HasSubstr("curves[0] 'lift': time_step_s: -1"));
  EXPECT_THAT(Fields(s.status()),
              ElementsAre("curve_set.curves[0].time_step_s", "curve_set.curves[1].curve_id",
                          "curve_set.curves[1].time_scale_pct", "curve_set.curves[2].name"));
  v1::GetCurveSetRequest g;
  g.set_name("bad");
  EXPECT_EQ(core_->GetCurveSet(g, ctx_).status().code(), absl::StatusCode::kNotFound);
  // The refused create is audited with its error.
  auto entries = Audit("CreateCurveSet");
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].result_code, static_cast<int>(absl::StatusCode::kInvalidArgument));

  // A curve without a shape names the curve.
  v1::CreateCurveSetRequest none;
  none.mutable_curve_set()->set_name("none");
  none.mutable_curve_set()->add_curves()->set_name("empty");
  auto e = core_->CreateCurveSet(none, ctx_);
  EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Fields(e.status()), ElementsAre("curve_set.curves[0]"));
  EXPECT_THAT(Msg(e.status()), HasSubstr("'empty' needs a shape"));
}

TEST_F(CurveSetServiceTest, GetCurvePlot_Parabola_VelocityTwoTAccelerationTwo) {
  const v1::CurveSet created = Create("press", {Parabola("lift"), LinMot("cam", 5)});
  v1::GetCurvePlotRequest r;
  r.set_name("curveSets/press");
  r.set_curve("lift");
  auto plot = core_->GetCurvePlot(r, ctx_);
  ASSERT_TRUE(plot.ok()) << plot.status();
  EXPECT_EQ(plot->name(), "curveSets/press");
  EXPECT_EQ(plot->version(), 1);
  EXPECT_DOUBLE_EQ(plot->time_step_s(), 0.1);
  ASSERT_EQ(plot->t_s_size(), 21);
  ASSERT_EQ(plot->acceleration_mm_s2_size(), 21);
  for (int i = 1; i < 20; ++i) {
    const double t = plot->t_s(i);
    EXPECT_NEAR(plot->position_mm(i), t * t, 1e-12) << i;
    EXPECT_NEAR(plot->velocity_mm_s(i), 2 * t, 1e-9) << i;
    EXPECT_NEAR(plot->acceleration_mm_s2(i), 2, 1e-9) << i;
  }
  EXPECT_NEAR(plot->summary().duration_s(), 2, 1e-12);
  EXPECT_NEAR(plot->summary().min_mm(), 0, 1e-12);
  EXPECT_NEAR(plot->summary().max_mm(), 4, 1e-12);
  EXPECT_NEAR(plot->summary().end_mm(), 4, 1e-12);
  EXPECT_NEAR(plot->summary().peak_acceleration_mm_s2(), 2, 1e-9);
  // The last segment's slope (4 - 3.61) / 0.1 is the peak velocity.
  EXPECT_NEAR(plot->summary().peak_velocity_mm_s(), 3.9, 1e-9);

  // A LinMot curve plots as D-29 replays it: 0.1 um points, step x_length / (N - 1).
  r.set_curve("cam");
  auto cam = core_->GetCurvePlot(r, ctx_);
  ASSERT_TRUE(cam.ok()) << cam.status();
  EXPECT_DOUBLE_EQ(cam->time_step_s(), 0.1);
  ASSERT_EQ(cam->position_mm_size(), 3);
  EXPECT_NEAR(cam->position_mm(2), 2, 1e-12);
  EXPECT_NEAR(cam->velocity_mm_s(1), 10, 1e-9);

  // An older version still plots; an unknown curve names the set's curves.
  v1::UpdateCurveSetRequest u;
  *u.mutable_curve_set() = created;
  u.mutable_curve_set()->mutable_curves()->DeleteSubrange(0, 1);
  u.set_etag(created.etag());
  ASSERT_TRUE(core_->UpdateCurveSet(u, ctx_).ok());
  r.set_curve("lift");
  EXPECT_EQ(core_->GetCurvePlot(r, ctx_).status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(Msg(core_->GetCurvePlot(r, ctx_).status()), HasSubstr("curves: 'cam'"));
  r.set_version(1);
  auto old = core_->GetCurvePlot(r, ctx_);
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_EQ(old->version(), 1);
}

TEST_F(CurveSetServiceTest, ValidateCurveSet_AgainstAxis_NamesFieldValueAndLimit) {
  Create("press", {Parabola("lift"), TooFast("fast")});
  v1::ValidateCurveSetRequest r;
  r.set_name("curveSets/press");
  r.set_drive("drives/x1");
  auto v = core_->ValidateCurveSet(r, ctx_);
  ASSERT_TRUE(v.ok()) << v.status();
  EXPECT_FALSE(v->valid());
  EXPECT_EQ(v->axis().max_velocity_mm_s(), 500);
  ASSERT_EQ(v->violations_size(), 2);
  EXPECT_EQ(v->violations(0).curve(), "fast");
  EXPECT_EQ(v->violations(0).field(), "curves[1].points[0]");
  EXPECT_EQ(v->violations(0).description(),
            "curves[1] 'fast': points[0]: velocity 812.4 mm/s exceeds axis.max_velocity_mm_s 500");
  EXPECT_EQ(v->violations(1).field(), "curves[1].points[1]");

  r.set_drive("drives/nope");
  EXPECT_EQ(core_->ValidateCurveSet(r, ctx_).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(CurveSetServiceTest, RunCurve_BeyondAxis_OutOfRangeNothingRunAudited) {
  Create("press", {Parabola("lift"), TooFast("fast")});
  v1::RunCurveRequest r;
  r.set_drive("x1");
  r.set_name("curveSets/press");
  r.set_curve("fast");
  auto run = core_->RunCurve(r, ctx_);
  ASSERT_EQ(run.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(Msg(run.status()),
            "curves[1] 'fast': points[0]: velocity 812.4 mm/s exceeds axis.max_velocity_mm_s 500 "
            "(and 1 more)");
  EXPECT_THAT(Fields(run.status()), ElementsAre("curves[1].points[0]", "curves[1].points[1]"));
  EXPECT_TRUE(x1_->runs().empty());
  auto entries = Audit("RunCurve");
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].drive, "x1");
  EXPECT_EQ(entries[0].result_code, static_cast<int>(absl::StatusCode::kOutOfRange));
  EXPECT_THAT(entries[0].request_json, HasSubstr("\"curve\":\"fast\""));
}

TEST_F(CurveSetServiceTest, RunCurve_OnRunner_HandleOptionsAndAuditWithCommand) {
  Create("press", {Parabola("lift")});
  v1::RunCurveRequest r;
  r.set_drive("drives/s1");
  r.set_name("press");
  r.set_curve("lift");
  auto run = core_->RunCurve(r, ctx_);
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_EQ(run->name(), "drives/s1/commands/41");
  EXPECT_EQ(run->kind(), "RunCurve");
  EXPECT_EQ(run->state(), v1::ACTIVE);
  ASSERT_TRUE(run->has_progress());
  ASSERT_EQ(s1_->runs().size(), 1u);
  EXPECT_EQ(s1_->runs()[0].curve.name, "lift");
  EXPECT_DOUBLE_EQ(s1_->runs()[0].options.start_tolerance_mm, 0.1);  // 0 = default
  EXPECT_EQ(s1_->runs()[0].options.linmot_scratch_curve_id, 100);

  r.set_start_tolerance_mm(2.5);
  r.set_linmot_scratch_curve_id(42);
  ASSERT_TRUE(core_->RunCurve(r, ctx_).ok());
  ASSERT_EQ(s1_->runs().size(), 2u);
  EXPECT_DOUBLE_EQ(s1_->runs()[1].options.start_tolerance_mm, 2.5);
  EXPECT_EQ(s1_->runs()[1].options.linmot_scratch_curve_id, 42);

  r.set_linmot_scratch_curve_id(101);
  auto bad = core_->RunCurve(r, ctx_);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Fields(bad.status()), ElementsAre("linmot_scratch_curve_id"));

  auto entries = Audit("RunCurve");
  ASSERT_EQ(entries.size(), 3u);
  // Newest first: the refused one, then the two runs with their command.
  EXPECT_EQ(entries[2].drive, "s1");
  EXPECT_EQ(entries[2].result_code, 0);
  EXPECT_THAT(entries[2].request_json, HasSubstr("\"command\":\"drives/s1/commands/41\""));
  EXPECT_THAT(entries[2].request_json, HasSubstr("\"set\":\"curveSets/press\""));
  EXPECT_THAT(entries[2].request_json, HasSubstr("\"request\":{"));
}

TEST_F(CurveSetServiceTest, RunAndDownload_FamilyWithout_FailedPreconditionNamingFamily) {
  Create("press", {Parabola("lift")});
  v1::RunCurveRequest r;
  r.set_drive("t1");
  r.set_name("press");
  r.set_curve("lift");
  auto run = core_->RunCurve(r, ctx_);
  ASSERT_EQ(run.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(Msg(run.status()),
              HasSubstr("drives/t1 (family trinamic) does not support RunCurve"));
  auto info = run.status().GetPayload("type.googleapis.com/google.rpc.ErrorInfo");
  ASSERT_TRUE(info.has_value());
  google::rpc::ErrorInfo ei;
  ASSERT_TRUE(ei.ParseFromString(std::string(*info)));
  EXPECT_EQ(ei.reason(), "CURVE_OPERATION_UNSUPPORTED");
  EXPECT_EQ(ei.metadata().at("family"), "trinamic");

  v1::DownloadCurveRequest d;
  d.set_drive("drives/s1");
  d.set_name("press");
  d.set_curve("lift");
  d.set_linmot_curve_id(7);
  auto dl = core_->DownloadCurve(d, ctx_);
  ASSERT_EQ(dl.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(Msg(dl.status()),
              HasSubstr("drives/s1 (family stober) does not support DownloadCurve"));
  EXPECT_THAT(Msg(dl.status()), HasSubstr("RunCurve"));
  auto entries = Audit("DownloadCurve");
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].result_code, static_cast<int>(absl::StatusCode::kFailedPrecondition));
}

// Decision 1491: a DOWN drive refuses a curve run (it moves the axis) and a download (it writes
// the drive) with the UNAVAILABLE of decision 1431, before the family is called; both audited.
TEST_F(CurveSetServiceTest, RunAndDownload_DriveDown_UnavailableNothingSentAudited) {
  Create("press", {Parabola("lift")});
  HealthInfo down;
  down.state = HealthState::kDown;
  down.since = std::chrono::sys_days{std::chrono::year{2026} / 12 / 7} + std::chrono::hours(5);
  down.consecutive_failures = 3;
  down.reason = "3 consecutive time-outs";
  x1_->SetHealthInfo(down);
  v1::RunCurveRequest r;
  r.set_drive("x1");
  r.set_name("press");
  r.set_curve("lift");
  auto run = core_->RunCurve(r, ctx_);
  ASSERT_EQ(run.status().code(), absl::StatusCode::kUnavailable) << run.status();
  EXPECT_EQ(Msg(run.status()),
            "drive 'x1' is DOWN since 2026-12-07T05:00:00Z (3 consecutive time-outs): run_curve "
            "refused");
  v1::DownloadCurveRequest d;
  d.set_drive("x1");
  d.set_name("press");
  d.set_curve("lift");
  d.set_linmot_curve_id(7);
  auto dl = core_->DownloadCurve(d, ctx_);
  ASSERT_EQ(dl.status().code(), absl::StatusCode::kUnavailable) << dl.status();
  EXPECT_THAT(Msg(dl.status()), HasSubstr(": download_curve refused"));
  EXPECT_TRUE(x1_->runs().empty());
  EXPECT_TRUE(x1_->downloads().empty());
  auto runs = Audit("RunCurve");
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].result_code, static_cast<int>(absl::StatusCode::kUnavailable));
  auto downloads = Audit("DownloadCurve");
  ASSERT_EQ(downloads.size(), 1u);
  EXPECT_EQ(downloads[0].result_code, static_cast<int>(absl::StatusCode::kUnavailable));

  // A request that can never be valid is named as such even on a DOWN drive.
  r.set_start_tolerance_mm(-1);
  EXPECT_EQ(core_->RunCurve(r, ctx_).status().code(), absl::StatusCode::kInvalidArgument);

  down.state = HealthState::kDemoted;  // recovering: calls go through again
  x1_->SetHealthInfo(down);
  r.set_start_tolerance_mm(0);
  EXPECT_TRUE(core_->RunCurve(r, ctx_).ok());
  EXPECT_TRUE(core_->DownloadCurve(d, ctx_).ok());
  EXPECT_EQ(x1_->runs().size(), 1u);
  EXPECT_EQ(x1_->downloads().size(), 1u);
}

// Gap 14 (docs/reliability.md): a negative start tolerance or version names the field, the value
// and the limit; nothing runs.
TEST_F(CurveSetServiceTest,
       RunCurve_NegativeToleranceOrVersion_InvalidArgumentNamingFieldAndLimit) {
  Create("press", {Parabola("lift")});
  v1::RunCurveRequest r;
  r.set_drive("s1");
  r.set_name("press");
  r.set_curve("lift");
  r.set_start_tolerance_mm(-0.5);
  auto run = core_->RunCurve(r, ctx_);
  ASSERT_EQ(run.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(run.status()), "start_tolerance_mm: -0.5 is not a finite value >= 0");
  EXPECT_THAT(Fields(run.status()), ElementsAre("start_tolerance_mm"));
  r.set_start_tolerance_mm(std::nan(""));
  EXPECT_EQ(core_->RunCurve(r, ctx_).status().code(), absl::StatusCode::kInvalidArgument);

  r.set_start_tolerance_mm(0);
  r.set_version(-2);
  run = core_->RunCurve(r, ctx_);
  ASSERT_EQ(run.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(run.status()), "version: -2 is below 0");
  EXPECT_THAT(Fields(run.status()), ElementsAre("version"));
  EXPECT_TRUE(s1_->runs().empty());

  v1::GetCurveSetVersionRequest g;
  g.set_name("press");
  g.set_version(-1);
  auto v = core_->GetCurveSetVersion(g, ctx_);
  ASSERT_EQ(v.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Msg(v.status()), "version: -1 is below 1");
  v1::GetCurvePlotRequest p;
  p.set_name("press");
  p.set_curve("lift");
  p.set_version(-1);
  EXPECT_EQ(Msg(core_->GetCurvePlot(p, ctx_).status()), "version: -1 is below 0");
}

TEST_F(CurveSetServiceTest, DownloadCurve_PositionTime_LinMotWireFormHashAudited) {
  Create("press", {Parabola("lift"), LinMot("cam", 5)});
  v1::DownloadCurveRequest d;
  d.set_drive("x1");
  d.set_name("press");
  d.set_curve("lift");
  auto missing_id = core_->DownloadCurve(d, ctx_);
  EXPECT_EQ(missing_id.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Fields(missing_id.status()), ElementsAre("linmot_curve_id"));

  d.set_linmot_curve_id(7);
  auto dl = core_->DownloadCurve(d, ctx_);
  ASSERT_TRUE(dl.ok()) << dl.status();
  EXPECT_EQ(dl->drive(), "drives/x1");
  EXPECT_EQ(dl->curve_id(), 7);
  EXPECT_EQ(dl->point_count(), 21);
  EXPECT_NEAR(dl->x_length_s(), 2, 1e-12);
  ASSERT_EQ(x1_->downloads().size(), 1u);
  const LinMotParametricCurve wire = x1_->downloads()[0];
  EXPECT_EQ(wire.curve_id, 7);
  EXPECT_EQ(wire.points[20], 40000);  // 4 mm in 0.1 um
  EXPECT_EQ(dl->hash(), LinMotCurveHash(wire));
  EXPECT_THAT(dl->hash(), ::testing::MatchesRegex("fnv1a64:[0-9a-f]{16}"));

  // A LinMot curve keeps its own ID; another ID is refused.
  d.set_curve("cam");
  d.set_linmot_curve_id(9);
  EXPECT_EQ(core_->DownloadCurve(d, ctx_).status().code(), absl::StatusCode::kInvalidArgument);
  d.set_linmot_curve_id(0);
  auto cam = core_->DownloadCurve(d, ctx_);
  ASSERT_TRUE(cam.ok()) << cam.status();
  EXPECT_EQ(cam->curve_id(), 5);
  EXPECT_NE(cam->hash(), dl->hash());

  // A read-back mismatch on the drive is returned as it is.
  x1_->FailNext(absl::DataLossError("curve 5 read back differs at point 2"));
  EXPECT_EQ(core_->DownloadCurve(d, ctx_).status().code(), absl::StatusCode::kDataLoss);

  auto entries = Audit("DownloadCurve");
  ASSERT_EQ(entries.size(), 5u);
  // entries[3]: the first successful download (newest first).
  EXPECT_EQ(entries[3].drive, "x1");
  EXPECT_EQ(entries[3].result_code, 0);
  EXPECT_THAT(entries[3].request_json, HasSubstr("\"curve_id\":7"));
  EXPECT_THAT(entries[3].request_json, HasSubstr("\"hash\":\"" + dl->hash() + "\""));
  EXPECT_EQ(entries[0].result_code, static_cast<int>(absl::StatusCode::kDataLoss));
  EXPECT_THAT(entries[0].request_json, HasSubstr("\"curve_id\":5"));
}

TEST_F(CurveSetServiceTest, Audit_CreateUpdateDelete_BeforeAndAfter) {
  const v1::CurveSet created = Create("press", {Parabola("lift")});
  v1::UpdateCurveSetRequest u;
  *u.mutable_curve_set() = created;
  u.mutable_curve_set()->set_description("v2");
  u.set_etag(created.etag());
  auto updated = core_->UpdateCurveSet(u, ctx_);
  ASSERT_TRUE(updated.ok()) << updated.status();
  v1::DeleteCurveSetRequest d;
  d.set_name("press");
  d.set_etag(updated->etag());
  ASSERT_TRUE(core_->DeleteCurveSet(d, ctx_).ok());

  auto c = Audit("CreateCurveSet");
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].principal, "alice");
  EXPECT_THAT(c[0].request_json, HasSubstr("{\"after\":{"));
  EXPECT_THAT(c[0].request_json, Not(HasSubstr("\"before\"")));
  auto up = Audit("UpdateCurveSet");
  ASSERT_EQ(up.size(), 1u);
  EXPECT_THAT(up[0].request_json, HasSubstr("\"before\":{"));
  EXPECT_THAT(up[0].request_json, HasSubstr("\"description\":\"press line\""));
  EXPECT_THAT(up[0].request_json, HasSubstr("\"after\":{"));
  EXPECT_THAT(up[0].request_json, HasSubstr("\"description\":\"v2\""));
  auto del = Audit("DeleteCurveSet");
  ASSERT_EQ(del.size(), 1u);
  EXPECT_EQ(del[0].result_code, 0);
  EXPECT_THAT(del[0].request_json, HasSubstr("\"before\":{"));
  EXPECT_THAT(del[0].request_json, HasSubstr("\"version\":2"));
}

}  // namespace
}  // namespace drivegw::server
