// End to end over real sockets (issue 6 "Curve sets"): the demo gateway's REST and gRPC front ends
// with the embedded simulators. A curve set is created over REST, plotted over REST and gRPC
// (p = t² -> a = 2), checked against a drive's axis, updated (a stale etag is 412), downloaded to
// the LinMot axis x1 and run to DONE at its end point on x1 (native), the STOBER axis s1 (cyclic
// set points) and the Trinamic axis feeder-x (timed legs); STOBER stores no curves and answers the
// clear FailedPrecondition mapping (decision 014). The audit log holds every mutating call.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/curve.h"
#include "adapters/stober/param_id.h"
#include "drivegw/v1/curve_sets.grpc.pb.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "server/gateway.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "tests/e2e/http_client.h"
#include "tests/support/demo_gateway.h"

namespace drivegw::server {
namespace {

using testing::HttpRequest;

constexpr double kPi = 3.14159265358979323846;

// The first `"key": "text"` (or integer, or boolean) of a JSON body; "" if absent.
std::string Field(const std::string& body, const std::string& key) {
  std::smatch m;
  const std::regex re("\"" + key + "\"\\s*:\\s*(\"([^\"]*)\"|(-?[0-9]+)|(true|false))");
  if (!std::regex_search(body, m, re)) return "";
  if (m[2].matched) return m[2];
  if (m[3].matched) return m[3];
  return m[4];
}

// The numbers of the first `"key": [ ... ]` array of a JSON body.
std::vector<double> Numbers(const std::string& body, const std::string& key) {
  std::smatch m;
  const std::regex re("\"" + key + "\"\\s*:\\s*\\[([^\\]]*)\\]");
  std::vector<double> out;
  if (!std::regex_search(body, m, re)) return out;
  std::stringstream ss(m[1].str());
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
  return out;
}

// A JSON array of numbers.
std::string JsonArray(const std::vector<double>& v) {
  std::ostringstream os;
  os.precision(17);
  os << "[";
  for (size_t i = 0; i < v.size(); ++i) os << (i ? "," : "") << v[i];
  os << "]";
  return os.str();
}

// p = t² mm, t = 0 .. 2 s in 0.1 s.
std::vector<double> ParabolaPoints() {
  std::vector<double> p;
  for (int i = 0; i <= 20; ++i) p.push_back(0.01 * i * i);
  return p;
}

// 10 -> 20 mm as a half cosine over 2 s in 10 ms steps: at rest at both ends, peak 7.9 mm/s and
// 12.3 mm/s², inside every demo axis.
std::vector<double> SmoothPoints() {
  std::vector<double> p;
  for (int i = 0; i <= 200; ++i) p.push_back(15.0 - 5.0 * std::cos(kPi * i / 200.0));
  return p;
}

class CurveSetsE2eTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-cs-e2e-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    GatewayOptions o = test_support::DemoGatewayOptions(data_dir_);
    auto gw = Gateway::Start(o);
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                       grpc::InsecureChannelCredentials());
    drives_ = v1::DriveService::NewStub(channel);
    curves_ = v1::CurveSetService::NewStub(channel);
  }
  void TearDown() override {
    gw_.reset();
    std::filesystem::remove_all(data_dir_);
  }
  int http() const { return gw_->http_port(); }

  // Polls GetDrive until `pred` holds or the deadline passes (generous: ctest -j3 on 2 cores).
  template <typename Pred>
  v1::Drive WaitFor(const std::string& name, Pred pred,
                    std::chrono::seconds timeout = std::chrono::seconds(20)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    v1::Drive d;
    while (std::chrono::steady_clock::now() < deadline) {
      grpc::ClientContext ctx;
      v1::GetDriveRequest req;
      req.set_name(name);
      if (drives_->GetDrive(&ctx, req, &d).ok() && pred(d)) return d;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));  // polling, not a timing assert
    }
    return d;
  }

  // Polls GET /v1/{command} until the handle is final; returns its last body.
  std::string WaitCommandFinal(const std::string& command) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::string body;
    while (std::chrono::steady_clock::now() < deadline) {
      auto r = HttpRequest(http(), "GET", "/v1/" + command);
      EXPECT_EQ(r.status, 200) << r.body;
      body = r.body;
      const std::string state = Field(body, "state");
      if (state == "DONE" || state == "ERROR" || state == "ABORTED") return body;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << command << " not final: " << body;
    return body;
  }

  // Creates curveSets/e2e over REST: "lift" (p = t²), "smooth" (10 -> 20 mm, at rest at both
  // ends) and the LinMot curve "cam" (ID 3). Returns the create response body.
  std::string CreateSet() {
    const std::string body = R"({"name": "e2e", "description": "press line", "curves": [
        {"name": "lift", "position_time": {"time_step_s": 0.1, "positions_mm": )" +
                             JsonArray(ParabolaPoints()) + R"(}},
        {"name": "smooth", "position_time": {"time_step_s": 0.01, "positions_mm": )" +
                             JsonArray(SmoothPoints()) + R"(}},
        {"name": "cam", "linmot": {"curve_id": 3, "x_length_s": 0.2, "points": [0, 10000, 20000]}}]})";
    auto created = HttpRequest(http(), "POST", "/v1/curveSets", body);
    EXPECT_EQ(created.status, 200) << created.body;
    return created.body;
  }

  // Enables `drive` and moves it to the curve's start (10 mm).
  void MoveToStart(const std::string& drive) {
    const v1::Drive online = WaitFor("drives/" + drive, [](const v1::Drive& d) {
      return d.status().state() != v1::OFFLINE && d.status().state() != v1::DRIVE_STATE_UNSPECIFIED;
    });
    ASSERT_NE(online.status().state(), v1::OFFLINE) << online.ShortDebugString();
    auto en = HttpRequest(http(), "POST", "/v1/drives/" + drive + ":enable", "");
    ASSERT_EQ(en.status, 200) << en.body;
    auto mv = HttpRequest(http(), "POST", "/v1/drives/" + drive + ":moveAbsolute",
                          R"({"position_mm": 10, "velocity_mm_s": 20, "acceleration_mm_s2": 100})");
    ASSERT_EQ(mv.status, 200) << mv.body;
    const std::string move = Field(mv.body, "name");
    const v1::Drive at_start = WaitFor("drives/" + drive, [&](const v1::Drive& d) {
      return d.status().last_command().name() == move &&
             d.status().last_command().state() == v1::DONE;
    });
    ASSERT_NEAR(at_start.status().position_mm(), 10, 0.05) << at_start.ShortDebugString();
  }

  // POST :runCurve of "smooth" on `drive`.
  testing::HttpResponse RunSmooth(const std::string& drive) {
    return HttpRequest(
        http(), "POST", "/v1/drives/" + drive + ":runCurve",
        R"({"name": "curveSets/e2e", "curve": "smooth", "start_tolerance_mm": 0.5})");
  }

  // Moves `drive` to the start, runs "smooth" until its handle is final and checks the run's one
  // audit entry names the command. Returns the final handle's JSON.
  std::string RunToFinal(const std::string& drive) {
    MoveToStart(drive);
    auto run = RunSmooth(drive);
    EXPECT_EQ(run.status, 200) << run.body;
    if (run.status != 200) return "";
    EXPECT_EQ(Field(run.body, "kind"), "RunCurve") << run.body;
    const std::string command = Field(run.body, "name");
    EXPECT_EQ(command.rfind("drives/" + drive + "/commands/", 0), 0u) << run.body;
    const std::string final_body = WaitCommandFinal(command);
    auto audited = Audit("RunCurve", drive);
    EXPECT_EQ(audited.size(), 1u);
    if (!audited.empty()) {
      EXPECT_EQ(audited[0].result_code, 0);
      EXPECT_NE(audited[0].request_json.find("\"command\":\"" + command + "\""), std::string::npos)
          << audited[0].request_json;
    }
    return final_body;
  }

  // The curve's end point (20 mm) reached.
  void ExpectAtEnd(const std::string& drive) {
    const v1::Drive end = WaitFor("drives/" + drive, [](const v1::Drive& d) {
      return std::abs(d.status().position_mm() - 20) < 0.1;
    });
    EXPECT_NEAR(end.status().position_mm(), 20, 0.1) << end.ShortDebugString();
  }

  // The audit entries of `action` (for `drive` when not empty), newest first.
  std::vector<storage::AuditRecord> Audit(const std::string& action,
                                          const std::string& drive = "") {
    auto db = storage::Db::Open((std::filesystem::path(data_dir_) / "drivegw.db").string());
    EXPECT_TRUE(db.ok()) << db.status();
    if (!db.ok()) return {};
    storage::AuditLog audit(*db);
    storage::AuditQuery q;
    q.action = action;
    if (!drive.empty()) q.drive = drive;
    auto r = audit.Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<storage::AuditRecord>{};
  }

  std::string data_dir_;
  std::unique_ptr<Gateway> gw_;
  std::unique_ptr<v1::DriveService::Stub> drives_;
  std::unique_ptr<v1::CurveSetService::Stub> curves_;
};

TEST_F(CurveSetsE2eTest, CreatePlotValidateUpdateDownloadRun_OverRestAndGrpc_Audited) {
  // One OpenAPI document carries the curve routes too.
  auto openapi = HttpRequest(http(), "GET", "/openapi.json");
  ASSERT_EQ(openapi.status, 200);
  EXPECT_NE(openapi.body.find("/v1/{name=curveSets/*}/curves/{curve}:plot"), std::string::npos);

  const std::string created = CreateSet();
  EXPECT_EQ(Field(created, "name"), "curveSets/e2e");
  const std::string etag = Field(created, "etag");
  ASSERT_EQ(etag.size(), 32u) << created;

  // Limit violations are refused naming field and limit, and nothing is stored.
  auto bad = HttpRequest(http(), "POST", "/v1/curveSets",
                         R"({"name": "bad", "curves": [{"name": "c", "linmot":
                             {"curve_id": 101, "x_length_s": 0.2, "points": [0, 1]}}]})");
  EXPECT_EQ(bad.status, 400) << bad.body;
  EXPECT_NE(bad.body.find("curve_set.curves[0].curve_id"), std::string::npos) << bad.body;
  EXPECT_NE(bad.body.find("is outside 1..100"), std::string::npos) << bad.body;
  EXPECT_EQ(HttpRequest(http(), "GET", "/v1/curveSets/bad").status, 404);

  // The plot over REST: one entry per point, a = 2 inside.
  auto plot = HttpRequest(http(), "GET", "/v1/curveSets/e2e/curves/lift:plot");
  ASSERT_EQ(plot.status, 200) << plot.body;
  const std::vector<double> t = Numbers(plot.body, "t_s");
  const std::vector<double> a = Numbers(plot.body, "acceleration_mm_s2");
  ASSERT_EQ(t.size(), 21u) << plot.body;
  ASSERT_EQ(a.size(), 21u) << plot.body;
  for (size_t i = 1; i + 1 < a.size(); ++i) EXPECT_NEAR(a[i], 2, 1e-6) << i;
  EXPECT_NE(plot.body.find("\"peak_acceleration_mm_s2\""), std::string::npos) << plot.body;

  // The same over gRPC, typed.
  {
    grpc::ClientContext ctx;
    v1::GetCurvePlotRequest req;
    req.set_name("curveSets/e2e");
    req.set_curve("lift");
    v1::CurvePlot p;
    ASSERT_TRUE(curves_->GetCurvePlot(&ctx, req, &p).ok());
    EXPECT_EQ(p.version(), 1);
    ASSERT_EQ(p.velocity_mm_s_size(), 21);
    EXPECT_NEAR(p.velocity_mm_s(10), 2.0, 1e-9);  // v = 2t at t = 1 s
    EXPECT_NEAR(p.summary().duration_s(), 2, 1e-12);
    EXPECT_NEAR(p.summary().max_mm(), 4, 1e-12);
  }

  // Against the Trinamic feeder's axis (40 mm/s, 190 mm/s²) every curve fits; against a made-up
  // drive there is nothing to check.
  auto valid =
      HttpRequest(http(), "POST", "/v1/curveSets/e2e:validate", R"({"drive": "feeder-x"})");
  ASSERT_EQ(valid.status, 200) << valid.body;
  EXPECT_EQ(Field(valid.body, "valid"), "true") << valid.body;
  EXPECT_EQ(HttpRequest(http(), "POST", "/v1/curveSets/e2e:validate", R"({"drive": "zz"})").status,
            404);

  // Update over gRPC; the first etag is stale afterwards: FAILED_PRECONDITION with the ETAG
  // detail over gRPC, 412 over REST.
  {
    grpc::ClientContext get_ctx;
    v1::GetCurveSetRequest g;
    g.set_name("curveSets/e2e");
    v1::CurveSet current;
    ASSERT_TRUE(curves_->GetCurveSet(&get_ctx, g, &current).ok());
    v1::UpdateCurveSetRequest u;
    *u.mutable_curve_set() = current;
    u.mutable_curve_set()->set_description("press line, v2");
    u.set_etag(etag);
    grpc::ClientContext ctx;
    v1::CurveSet updated;
    ASSERT_TRUE(curves_->UpdateCurveSet(&ctx, u, &updated).ok());
    EXPECT_EQ(updated.version(), 2);
    grpc::ClientContext stale_ctx;
    const grpc::Status stale = curves_->UpdateCurveSet(&stale_ctx, u, &updated);
    EXPECT_EQ(stale.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    google::rpc::Status rich;
    ASSERT_TRUE(rich.ParseFromString(stale.error_details()));
    bool etag_detail = false;
    for (const auto& any : rich.details()) {
      google::rpc::PreconditionFailure pf;
      if (any.UnpackTo(&pf) && pf.violations_size() > 0) {
        etag_detail = pf.violations(0).type() == "ETAG";
      }
    }
    EXPECT_TRUE(etag_detail) << rich.ShortDebugString();
  }
  auto stale = HttpRequest(http(), "PATCH", "/v1/curveSets/e2e?etag=" + etag,
                           R"({"name": "curveSets/e2e", "curves": []})");
  EXPECT_EQ(stale.status, 412) << stale.body;
  EXPECT_NE(stale.body.find("version 2"), std::string::npos) << stale.body;
  auto versions = HttpRequest(http(), "GET", "/v1/curveSets/e2e/versions");
  ASSERT_EQ(versions.status, 200) << versions.body;
  EXPECT_EQ(Field(versions.body, "version"), "2") << versions.body;  // newest first

  // Audit: create (and the refused one), the update and both stale updates.
  EXPECT_EQ(Audit("CreateCurveSet").size(), 2u);
  auto updates = Audit("UpdateCurveSet");
  ASSERT_EQ(updates.size(), 3u);  // gRPC ok, gRPC stale, REST stale (newest first)
  EXPECT_EQ(updates[0].result_code, static_cast<int>(grpc::StatusCode::FAILED_PRECONDITION));
  EXPECT_EQ(updates[2].result_code, 0);
  EXPECT_NE(updates[2].request_json.find("\"before\":{"), std::string::npos);
  EXPECT_NE(updates[2].request_json.find("\"description\":\"press line, v2\""), std::string::npos);
}

// LinMot x1 (committed runner and curve service, decisions 706/707): a position/time curve is
// downloaded under ID 7 (read back by the drive) and runs natively to DONE at its end point.
// Decision 1492: explicit gRPC message limits (kGrpcMaxMessageBytes, 16 MiB) on the network port
// and on REST's in-process channel. A curve set above gRPC's implicit 4 MiB is stored over gRPC
// and read back over gRPC and REST; a request above the limit is RESOURCE_EXHAUSTED naming it,
// and the gateway keeps serving.
TEST_F(CurveSetsE2eTest, GrpcMessageLimit_LargeSetServedOverGrpcAndRest_OversizedRefusedGatewayUp) {
  grpc::ChannelArguments unlimited;  // the client side must not be what refuses
  unlimited.SetMaxReceiveMessageSize(-1);
  unlimited.SetMaxSendMessageSize(-1);
  auto stub = v1::CurveSetService::NewStub(
      grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                grpc::InsecureChannelCredentials(), unlimited));
  // 30 LinMot curves of the most points a curve holds, negative: 10 bytes each as an int32 varint.
  v1::CreateCurveSetRequest big;
  big.mutable_curve_set()->set_name("curveSets/big");
  for (int id = 1; id <= 30; ++id) {
    v1::Curve* c = big.mutable_curve_set()->add_curves();
    c->set_name("c" + std::to_string(id));
    c->mutable_linmot()->set_curve_id(id);
    c->mutable_linmot()->set_x_length_s(1);
    for (int i = 0; i < LinMotParametricCurve::kMaxPoints; ++i) {
      c->mutable_linmot()->add_points(-1 - i);
    }
  }
  ASSERT_GT(big.ByteSizeLong(), size_t{4} << 20);  // above gRPC's implicit receive limit
  ASSERT_LT(big.ByteSizeLong(), static_cast<size_t>(kGrpcMaxMessageBytes));
  {
    grpc::ClientContext ctx;
    v1::CurveSet created;
    const grpc::Status s = stub->CreateCurveSet(&ctx, big, &created);
    ASSERT_TRUE(s.ok()) << s.error_code() << " " << s.error_message();
    EXPECT_EQ(created.curves_size(), 30);
  }
  {
    grpc::ClientContext ctx;
    v1::GetCurveSetRequest get;
    get.set_name("curveSets/big");
    v1::CurveSet got;
    const grpc::Status s = stub->GetCurveSet(&ctx, get, &got);
    ASSERT_TRUE(s.ok()) << s.error_code() << " " << s.error_message();
    ASSERT_EQ(got.curves_size(), 30);
    EXPECT_EQ(got.curves(29).linmot().points_size(), LinMotParametricCurve::kMaxPoints);
  }
  // Through REST the reply crosses the in-process channel, a gRPC client of its own.
  auto rest = HttpRequest(http(), "GET", "/v1/curveSets/big");
  ASSERT_EQ(rest.status, 200) << rest.body.substr(0, 300);
  EXPECT_NE(rest.body.find("\"c30\""), std::string::npos);

  // One position/time curve of 16 MiB of doubles: above the limit.
  v1::CreateCurveSetRequest huge;
  huge.mutable_curve_set()->set_name("curveSets/huge");
  v1::Curve* c = huge.mutable_curve_set()->add_curves();
  c->set_name("long");
  c->mutable_position_time()->set_time_step_s(0.001);
  c->mutable_position_time()->mutable_positions_mm()->Resize(kGrpcMaxMessageBytes / 8, 1.0);
  ASSERT_GT(huge.ByteSizeLong(), static_cast<size_t>(kGrpcMaxMessageBytes));
  {
    grpc::ClientContext ctx;
    v1::CurveSet created;
    const grpc::Status s = stub->CreateCurveSet(&ctx, huge, &created);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
    EXPECT_NE(s.error_message().find(std::to_string(kGrpcMaxMessageBytes)), std::string::npos)
        << s.error_message();
  }
  // Still serving, on both front ends; the oversized set was never stored.
  grpc::ClientContext ctx;
  v1::ListCurveSetsResponse list;
  const grpc::Status listed = stub->ListCurveSets(&ctx, v1::ListCurveSetsRequest(), &list);
  ASSERT_TRUE(listed.ok()) << listed.error_message();
  ASSERT_EQ(list.curve_sets_size(), 1);
  EXPECT_EQ(list.curve_sets(0).name(), "curveSets/big");
  EXPECT_EQ(HttpRequest(http(), "GET", "/v1/drives").status, 200);
}

TEST_F(CurveSetsE2eTest, LinMotX1_DownloadAndRunPositionTimeCurve_DoneAtEndAudited) {
  ASSERT_FALSE(Field(CreateSet(), "etag").empty());
  auto stored = HttpRequest(http(), "POST", "/v1/drives/x1:downloadCurve",
                            R"({"name": "e2e", "curve": "smooth", "linmot_curve_id": 7})");
  ASSERT_EQ(stored.status, 200) << stored.body;
  EXPECT_EQ(Field(stored.body, "curve_id"), "7") << stored.body;
  EXPECT_EQ(Field(stored.body, "point_count"), "201") << stored.body;
  const std::string hash = Field(stored.body, "hash");
  EXPECT_EQ(hash.rfind("fnv1a64:", 0), 0u) << stored.body;

  MoveToStart("x1");
  auto run = RunSmooth("x1");
  ASSERT_EQ(run.status, 200) << run.body;
  EXPECT_EQ(Field(run.body, "kind"), "RunCurve") << run.body;
  const std::string command = Field(run.body, "name");
  ASSERT_EQ(command.rfind("drives/x1/commands/", 0), 0u) << run.body;
  const std::string done = WaitCommandFinal(command);
  EXPECT_EQ(Field(done, "state"), "DONE") << done;
  const v1::Drive end = WaitFor("drives/x1", [](const v1::Drive& d) {
    return std::abs(d.status().position_mm() - 20) < 0.1;
  });
  EXPECT_NEAR(end.status().position_mm(), 20, 0.1) << end.ShortDebugString();

  // Again from the end point: the axis is not at the curve's start, the drive refuses
  // (FailedPrecondition naming the positions, decision 013) and the refusal is audited.
  auto again = RunSmooth("x1");
  EXPECT_EQ(again.status, 400) << again.body;
  EXPECT_EQ(Field(again.body, "code"), "9") << again.body;  // FAILED_PRECONDITION

  auto downloads = Audit("DownloadCurve", "x1");
  ASSERT_EQ(downloads.size(), 1u);
  EXPECT_EQ(downloads[0].result_code, 0);
  EXPECT_NE(downloads[0].request_json.find("\"hash\":\"" + hash + "\""), std::string::npos)
      << downloads[0].request_json;
  EXPECT_NE(downloads[0].request_json.find("\"curve_id\":7"), std::string::npos);
  auto runs = Audit("RunCurve", "x1");
  ASSERT_EQ(runs.size(), 2u);  // newest first
  EXPECT_EQ(runs[0].result_code, static_cast<int>(grpc::StatusCode::FAILED_PRECONDITION));
  EXPECT_EQ(runs[1].result_code, 0);
  EXPECT_NE(runs[1].request_json.find("\"command\":\"" + command + "\""), std::string::npos)
      << runs[1].request_json;
  EXPECT_NE(runs[1].request_json.find("\"curve\":\"smooth\""), std::string::npos);
}

// STOBER s1: no curve storage on the drive, so DownloadCurve is the clear FailedPrecondition
// mapping (decision 014); RunCurve streams the curve as cyclic set points (decision 1208) and ends
// DONE at its end point, audited with its command. The demo axis is commissioned with I423 =
// 100 ms (decision 413), so a loaded host (ctest -j3 on 2 cores) delays set points without the
// motion core cancelling the stream (event 78 cause 3, manual L1344): anything but DONE fails.
TEST_F(CurveSetsE2eTest, StoberS1_DownloadUnsupportedRunStreamedToDoneAudited) {
  ASSERT_FALSE(Field(CreateSet(), "etag").empty());
  auto no_store = HttpRequest(http(), "POST", "/v1/drives/s1:downloadCurve",
                              R"({"name": "e2e", "curve": "smooth", "linmot_curve_id": 7})");
  EXPECT_EQ(no_store.status, 400) << no_store.body;
  EXPECT_NE(no_store.body.find("drives/s1 (family stober) does not support DownloadCurve"),
            std::string::npos)
      << no_store.body;
  EXPECT_NE(no_store.body.find("CURVE_OPERATION_UNSUPPORTED"), std::string::npos) << no_store.body;
  const std::string final_body = RunToFinal("s1");
  EXPECT_EQ(Field(final_body, "state"), "DONE") << final_body;
  EXPECT_NE(final_body.find("end point 20 mm reached"), std::string::npos) << final_body;
  ExpectAtEnd("s1");

  // The commissioned extrapolation time, read back from the axis through the API (I423 at
  // 2000h + group I x 200h + 423, stober-motion.md §7.2).
  const stober::CanOpenAddress i423 = *stober::ToCanOpen(stober::P("I423"));
  const uint32_t id = static_cast<uint32_t>(i423.index) << 8 | i423.sub_index;
  auto param = HttpRequest(http(), "GET", "/v1/drives/s1/parameters/" + std::to_string(id));
  ASSERT_EQ(param.status, 200) << param.body;
  EXPECT_EQ(Field(param.body, "value"), "100") << param.body;
}

// Trinamic feeder-x (timed position-mode legs, decisions 1231+): the same curve to DONE; the
// feeder's axis (40 mm/s, 190 mm/s²) is the tightest of the demo and the curve stays inside it.
TEST_F(CurveSetsE2eTest, TrinamicFeederX_RunToDoneAudited) {
  ASSERT_FALSE(Field(CreateSet(), "etag").empty());
  const std::string final_body = RunToFinal("feeder-x");
  EXPECT_EQ(Field(final_body, "state"), "DONE") << final_body;
  ExpectAtEnd("feeder-x");
}

}  // namespace
}  // namespace drivegw::server
