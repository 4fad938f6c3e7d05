// The REST direct read path (decision 1331) against the in-process gRPC path it replaces: one
// service core over fake drives, the real DriveServiceGrpc with CallAuth (auth enabled, tokens
// in SQLite, auth.denied audited) and the RPC metrics interceptor on a grpc::Server, and two
// routers on its in-process channel — one plain, one with DriveServiceDirectReads. Every
// request must get the same status, headers and body from both, record the same RPC metrics
// series and the same audit entries.
#include "server/rest/direct_reads.h"

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "adapters/core/clock.h"
#include "google/protobuf/arena.h"
#include "google/protobuf/util/json_util.h"
#include "google/protobuf/util/message_differencer.h"
#include "google/protobuf/util/time_util.h"
#include "server/auth/authenticator.h"
#include "server/core/drive_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/worker_pool.h"
#include "server/ops/metrics.h"
#include "server/ops/rpc_metrics.h"
#include "server/rest/json_cache.h"
#include "server/rest/router.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"
#include "tests/server/core/core_test_support.h"
#include "tests/server/core/fake_drive.h"
#include "tests/server/rest/recording_sink.h"

namespace drivegw::rest {
namespace {

using test_support::RecordingSink;
using ::testing::HasSubstr;

class DirectReadsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-direct-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    auto db = storage::Db::Open((std::filesystem::path(dir_) / "drivegw.db").string());
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    tokens_ = std::make_unique<storage::TokenRepo>(*db_);
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    auth::AuthOptions ao;
    ao.enabled = true;
    authenticator_ = std::make_unique<auth::Authenticator>(std::move(ao), tokens_.get());
    // A manual clock for the refusal rate window: the test advances it so no refusal is
    // suppressed and both paths' audit entries can be compared one by one.
    call_auth_ = std::make_unique<server::CallAuth>(*authenticator_, audit_.get(), clock_);
    for (const char* role : {"viewer", "admin"}) {
      auto t = tokens_->Create(std::string("direct-") + role, role);
      ASSERT_TRUE(t.ok()) << t.status();
      token_[role] = t->token;
    }
    // Drives in every state the core reports, of several families.
    const DriveState states[] = {DriveState::kOffline, DriveState::kDisabled, DriveState::kReady,
                                 DriveState::kEnabled, DriveState::kMoving,   DriveState::kHoming,
                                 DriveState::kFault};
    const char* families[] = {"linudp", "trinamic", "stober", "devicenet"};
    std::map<std::string, std::string> by_family;
    for (size_t i = 0; i < std::size(states); ++i) {
      const std::string name = "x" + std::to_string(i + 1);
      fleet_.Add(name, families[i % std::size(families)], false).SetState(states[i]);
      by_family[name] = families[i % std::size(families)];
    }
    core_ = std::make_unique<server::DriveServiceCore>(fleet_.drives(), audit_.get());
    pool_ = std::make_unique<server::WorkerPool>(2);
    service_ = std::make_unique<server::DriveServiceGrpc>(*core_, *pool_, *call_auth_);
    metrics_ = std::make_unique<ops::RpcMetrics>(registry_, by_family);
    grpc::ServerBuilder builder;
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
    creators.push_back(ops::MakeRpcMetricsFactory(*metrics_));
    builder.experimental().SetInterceptorCreators(std::move(creators));
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    auto channel = server_->InProcessChannel(grpc::ChannelArguments());

    RouterOptions plain;
    plain.channel = channel;
    auto a = Router::Create(plain);
    ASSERT_TRUE(a.ok()) << a.status();
    grpc_router_ = *std::move(a);
    RouterOptions direct = plain;
    direct.direct_unary = DriveServiceDirectReads(*core_, *call_auth_, *metrics_);
    auto b = Router::Create(direct);
    ASSERT_TRUE(b.ok()) << b.status();
    direct_router_ = *std::move(b);
  }

  void TearDown() override {
    direct_router_.reset();
    grpc_router_.reset();
    if (server_) server_->Shutdown();
    server_.reset();
    service_.reset();
    pool_.reset();
    std::filesystem::remove_all(dir_);
  }

  static HttpResponse Ask(Router& router, const HttpRequest& request) {
    auto sink = std::make_shared<RecordingSink>();
    router.Handle(request, sink);
    return sink->Response();
  }

  HttpRequest Get(std::string target, const std::string& token) {
    HttpRequest r;
    r.method = "GET";
    r.target = std::move(target);
    r.peer = "127.0.0.1:40000";
    if (!token.empty()) r.authorization = "Bearer " + token;
    return r;
  }

  // Every RPC metrics sample the registry renders, by series; the latency histogram's buckets
  // and sum are left out (two calls take different times), its count is kept.
  std::map<std::string, double> Samples() const {
    std::map<std::string, double> out;
    const std::string text = registry_.Render();
    size_t start = 0;
    while (start < text.size()) {
      size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      const std::string line = text.substr(start, end - start);
      start = end + 1;
      if (line.empty() || line[0] == '#') continue;
      if (line.find("_bucket{") != std::string::npos || line.find("_sum{") != std::string::npos) {
        continue;
      }
      const size_t space = line.rfind(' ');
      out[line.substr(0, space)] = std::stod(line.substr(space + 1));
    }
    return out;
  }

  // What changed from `before` to `after`, series by series.
  static std::map<std::string, double> Increments(const std::map<std::string, double>& before,
                                                  const std::map<std::string, double>& after) {
    std::map<std::string, double> out;
    for (const auto& [series, value] : after) {
      auto it = before.find(series);
      const double d = value - (it == before.end() ? 0 : it->second);
      if (d != 0) out[series] = d;
    }
    return out;
  }

  // auth.denied entries: everything but time, ids and hashes.
  std::vector<std::string> Denials() {
    storage::AuditQuery q;
    q.action = "auth.denied";
    q.ascending = true;
    q.limit = storage::AuditQuery::kMaxLimit;
    auto records = audit_->Query(q);
    EXPECT_TRUE(records.ok()) << records.status();
    std::vector<std::string> out;
    for (const auto& r : records.value_or(std::vector<storage::AuditRecord>{})) {
      out.push_back(r.principal + "|" + r.role + "|" + r.source_address + "|" + r.drive + "|" +
                    r.action + "|" + r.request_json + "|" + std::to_string(r.result_code) + "|" +
                    r.result_message);
    }
    return out;
  }

  std::string dir_;
  ManualClock clock_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::TokenRepo> tokens_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::unique_ptr<auth::Authenticator> authenticator_;
  std::unique_ptr<server::CallAuth> call_auth_;
  std::map<std::string, std::string> token_;
  server::test_support::FakeFleet fleet_;
  std::unique_ptr<server::DriveServiceCore> core_;
  std::unique_ptr<server::WorkerPool> pool_;
  std::unique_ptr<server::DriveServiceGrpc> service_;
  ops::Registry registry_;
  std::unique_ptr<ops::RpcMetrics> metrics_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<Router> grpc_router_;
  std::unique_ptr<Router> direct_router_;
};

TEST_F(DirectReadsTest, Create_RoutesTheThreeReadsDirectly) {
  std::vector<std::string> direct;
  for (const Route& r : direct_router_->routes()) {
    if (r.direct) direct.push_back(r.grpc_path);
  }
  EXPECT_THAT(direct, ::testing::UnorderedElementsAre("/drivegw.v1.DriveService/ListDrives",
                                                      "/drivegw.v1.DriveService/GetDrive",
                                                      "/drivegw.v1.DriveService/GetCommand"));
  for (const Route& r : grpc_router_->routes()) EXPECT_FALSE(r.direct) << r.grpc_path;
}

TEST_F(DirectReadsTest, Create_HandlerForStreamingOrUnknownMethod_InvalidArgument) {
  RouterOptions o;
  o.channel = server_->InProcessChannel(grpc::ChannelArguments());
  o.direct_unary["/drivegw.v1.DriveService/WatchDrives"] = direct_router_->routes()[0].direct;
  EXPECT_EQ(Router::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o.direct_unary.clear();
  o.direct_unary["/drivegw.v1.DriveService/NoSuchMethod"] = direct_router_->routes()[0].direct;
  EXPECT_EQ(Router::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
}

// The same answer, byte for byte, from both paths: every drive and state, the list, commands,
// and the errors (no token 401, bad token 401, unknown drive 404, bad command name 400, bad
// query 400), for each credential.
TEST_F(DirectReadsTest, Handle_SameResponsesMetricsAndAuditAsGrpcPath) {
  std::vector<std::string> targets = {"/v1/drives",
                                      "/v1/drives?unknown_field=1",
                                      "/v1/drives/nope",
                                      "/v1/drives/x1?name=drives/x2",
                                      "/v1/drives/x1/commands/17",
                                      "/v1/drives/x1/commands/abc",
                                      "/v1/drives/nope/commands/1",
                                      "/v1/drives/x%zz"};
  for (size_t i = 1; i <= 7; ++i) targets.push_back("/v1/drives/x" + std::to_string(i));
  const std::vector<std::string> tokens = {"", "dgw_0000000000000000_not-a-real-token",
                                           token_["viewer"], token_["admin"]};
  std::set<int> statuses;
  std::map<std::string, double> before = Samples();
  size_t denied_before = Denials().size();
  for (const std::string& target : targets) {
    for (const std::string& token : tokens) {
      SCOPED_TRACE(target + " token=" + token.substr(0, 8));
      const HttpRequest request = Get(target, token);
      const HttpResponse via_grpc = Ask(*grpc_router_, request);
      clock_.Advance(std::chrono::seconds(2));  // a fresh refusal window for each call
      const std::map<std::string, double> after_grpc = Samples();
      const std::vector<std::string> denied_grpc = Denials();

      const HttpResponse direct = Ask(*direct_router_, request);
      clock_.Advance(std::chrono::seconds(2));
      EXPECT_EQ(direct.status, via_grpc.status);
      EXPECT_EQ(direct.content_type, via_grpc.content_type);
      EXPECT_EQ(direct.headers, via_grpc.headers);
      EXPECT_EQ(direct.body, via_grpc.body);
      statuses.insert(direct.status);

      // The direct call counted exactly what the gRPC call counted.
      const std::map<std::string, double> after_direct = Samples();
      EXPECT_EQ(Increments(after_grpc, after_direct), Increments(before, after_grpc));
      before = after_direct;

      // Refusals are audited once per path, alike (principal, code, method, source).
      const std::vector<std::string> denied = Denials();
      const size_t n_grpc = denied_grpc.size() - denied_before;
      ASSERT_EQ(denied.size() - denied_grpc.size(), n_grpc);
      for (size_t k = 0; k < n_grpc; ++k) {
        EXPECT_EQ(denied[denied_grpc.size() + k], denied_grpc[denied_before + k]);
      }
      denied_before = denied.size();
    }
  }
  // The cases cover success, the request errors and both refusals.
  EXPECT_THAT(statuses, ::testing::IsSupersetOf({200, 400, 401, 404}));
}

TEST_F(DirectReadsTest, Handle_GetDrive_CountsRestTransportAndDrive) {
  const HttpResponse r = Ask(*direct_router_, Get("/v1/drives/x2", token_["viewer"]));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_THAT(r.body, HasSubstr("\"name\":\"drives/x2\""));
  std::map<std::string, double> m = Samples();
  EXPECT_EQ(m["drivegw_rpc_requests_total{code=\"OK\",method=\"GetDrive\","
              "service=\"drivegw.v1.DriveService\",transport=\"rest\"}"],
            1);
  EXPECT_EQ(m["drivegw_drive_requests_total{drive=\"x2\",family=\"trinamic\",method=\"GetDrive\"}"],
            1);
  EXPECT_EQ(m["drivegw_rpc_duration_seconds_count{method=\"GetDrive\","
              "service=\"drivegw.v1.DriveService\",transport=\"rest\"}"],
            1);
}

TEST_F(DirectReadsTest, Handle_AfterCancelAll_503LikeGrpcPath) {
  grpc_router_->CancelAll();
  direct_router_->CancelAll();
  const HttpRequest request = Get("/v1/drives/x1", token_["viewer"]);
  const HttpResponse a = Ask(*grpc_router_, request);
  const HttpResponse b = Ask(*direct_router_, request);
  EXPECT_EQ(b.status, 503);
  EXPECT_EQ(b.status, a.status);
  EXPECT_EQ(b.body, a.body);
}

// A drive whose whole status snapshot, link counters and endpoint the test sets, without moving
// the sequence unless the test does: the JSON cache must not rely on it (decision 1361).
class ScriptedDrive final : public Drive {
 public:
  ScriptedDrive() : config_(server::test_support::FakeDrive::Config("s1", "linudp")) {}

  void Edit(const std::function<void(DriveStatus&, LinkHealth&, std::string&)>& edit) {
    std::lock_guard lock(mu_);
    edit(status_, link_, endpoint_);
  }

  const DriveConfig& config() const override { return config_; }
  std::string endpoint() const override {
    std::lock_guard lock(mu_);
    return endpoint_;
  }
  absl::Status Activate() override { return absl::OkStatus(); }
  void Deactivate() override {}
  Lifecycle lifecycle() const override { return Lifecycle::kActive; }
  absl::StatusOr<CommandInfo> Enable() override { return absl::UnimplementedError("scripted"); }
  absl::StatusOr<CommandInfo> Disable() override { return absl::UnimplementedError("scripted"); }
  absl::StatusOr<CommandInfo> Home() override { return absl::UnimplementedError("scripted"); }
  absl::StatusOr<CommandInfo> Move(const MotionCommand&) override {
    return absl::UnimplementedError("scripted");
  }
  absl::StatusOr<CommandInfo> AcknowledgeFault() override {
    return absl::UnimplementedError("scripted");
  }
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef&) override {
    return absl::UnimplementedError("scripted");
  }
  absl::Status WriteParameter(const ParameterRef&, int64_t) override {
    return absl::UnimplementedError("scripted");
  }
  absl::StatusOr<NativeReply> SendNative(const NativeRequest&) override {
    return absl::UnimplementedError("scripted");
  }
  DriveStatus GetStatus() const override {
    std::lock_guard lock(mu_);
    return status_;
  }
  LinkHealth link_health() const override {
    std::lock_guard lock(mu_);
    return link_;
  }
  std::optional<CommandInfo> GetCommand(uint64_t) const override { return std::nullopt; }
  DriveStatus WaitForStatus(uint64_t, std::chrono::steady_clock::time_point) const override {
    return GetStatus();
  }

 private:
  const DriveConfig config_;
  mutable std::mutex mu_;
  DriveStatus status_;
  LinkHealth link_;
  std::string endpoint_ = "udp://127.0.0.1:49360";
};

// Every kind of field the printed Drive carries, changed one at a time with the status sequence
// left alone: the next direct GET (and list) prints it, equal to protobuf's own printing of a
// fresh GetDrive; an unchanged drive is answered from the cache.
TEST(DirectReadsCacheTest, EveryStatusFieldChange_VisibleInNextGet) {
  auto drive = std::make_shared<ScriptedDrive>();
  server::DriveServiceCore core({drive}, nullptr);
  ops::Registry registry;
  ops::RpcMetrics metrics(registry, {{"s1", "linudp"}});
  RouterOptions o;
  // Never called: every route this test asks is direct.
  o.channel = grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials());
  o.direct_unary = DriveServiceDirectReads(core, server::CallAuth::Open(), metrics);
  auto router = Router::Create(std::move(o));
  ASSERT_TRUE(router.ok()) << router.status();
  const JsonCache* get_cache = nullptr;
  for (const Route& r : (*router)->routes()) {
    if (r.grpc_path == "/drivegw.v1.DriveService/GetDrive") get_cache = r.json_cache.get();
  }
  ASSERT_NE(get_cache, nullptr);

  const auto expected = [&] {
    v1::GetDriveRequest req;
    req.set_name("drives/s1");
    auto d = core.GetDrive(req, {});
    EXPECT_TRUE(d.ok()) << d.status();
    google::protobuf::util::JsonPrintOptions po;
    po.always_print_primitive_fields = true;
    po.preserve_proto_field_names = true;
    std::string json;
    EXPECT_TRUE(google::protobuf::util::MessageToJsonString(*d, &json, po).ok());
    return json;
  };
  const auto get = [&](const std::string& target) {
    HttpRequest r;
    r.method = "GET";
    r.target = target;
    auto sink = std::make_shared<test_support::RecordingSink>();
    (*router)->Handle(r, sink);
    HttpResponse resp = sink->Response();
    EXPECT_EQ(resp.status, 200) << resp.body;
    return resp.body;
  };
  const auto t = [](int64_t s) { return WallTime(std::chrono::seconds(s)); };
  using Edit = std::function<void(DriveStatus&, LinkHealth&, std::string&)>;
  const std::vector<std::pair<std::string, Edit>> edits = {
      {"state", [](DriveStatus& s, LinkHealth&, std::string&) { s.state = DriveState::kReady; }},
      {"native main", [](DriveStatus& s, LinkHealth&, std::string&) { s.native.main_state = 8; }},
      {"native sub", [](DriveStatus& s, LinkHealth&, std::string&) { s.native.sub_state = 2; }},
      {"native text", [](DriveStatus& s, LinkHealth&, std::string&) { s.native.text = "Op"; }},
      {"status word", [](DriveStatus& s, LinkHealth&, std::string&) { s.native.status_word = 7; }},
      {"warn word", [](DriveStatus& s, LinkHealth&, std::string&) { s.native.warn_word = 1; }},
      {"position", [](DriveStatus& s, LinkHealth&, std::string&) { s.position_mm = 12.5; }},
      {"position 0", [](DriveStatus& s, LinkHealth&, std::string&) { s.position_mm = 0.0; }},
      {"position -0", [](DriveStatus& s, LinkHealth&, std::string&) { s.position_mm = -0.0; }},
      {"position ulp",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.position_mm = 0.1 + 0.2; }},
      {"velocity", [](DriveStatus& s, LinkHealth&, std::string&) { s.velocity_mm_s = -3; }},
      {"demand", [](DriveStatus& s, LinkHealth&, std::string&) { s.demand_position_mm = 4; }},
      {"homed", [](DriveStatus& s, LinkHealth&, std::string&) { s.homed = true; }},
      {"in target", [](DriveStatus& s, LinkHealth&, std::string&) { s.in_target = true; }},
      {"motion", [](DriveStatus& s, LinkHealth&, std::string&) { s.motion_active = true; }},
      {"warning added",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.warnings.push_back("hot"); }},
      {"warning text", [](DriveStatus& s, LinkHealth&, std::string&) { s.warnings[0] = "cold"; }},
      {"warning removed", [](DriveStatus& s, LinkHealth&, std::string&) { s.warnings.clear(); }},
      {"fault",
       [](DriveStatus& s, LinkHealth&, std::string&) {
         s.fault = {3, "E3", false};
       }},
      {"fault fatal", [](DriveStatus& s, LinkHealth&, std::string&) { s.fault.fatal = true; }},
      {"fault cleared", [](DriveStatus& s, LinkHealth&, std::string&) { s.fault = {}; }},
      {"last command",
       [&](DriveStatus& s, LinkHealth&, std::string&) {
         s.last_command = CommandInfo{4, "Home", CommandState::kActive, "", t(100), {}, {}};
       }},
      {"command progress",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.last_command->progress = 0.5; }},
      {"command ended",
       [&](DriveStatus& s, LinkHealth&, std::string&) {
         s.last_command->state = CommandState::kDone;
         s.last_command->ended = t(101);
       }},
      {"command message",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.last_command->message = "ok"; }},
      {"command gone", [](DriveStatus& s, LinkHealth&, std::string&) { s.last_command.reset(); }},
      {"time", [&](DriveStatus& s, LinkHealth&, std::string&) { s.time = t(200); }},
      {"time ns",
       [&](DriveStatus& s, LinkHealth&, std::string&) { s.time += std::chrono::nanoseconds(1); }},
      {"sequence", [](DriveStatus& s, LinkHealth&, std::string&) { s.sequence = 9; }},
      {"health",
       [&](DriveStatus& s, LinkHealth&, std::string&) {
         s.health = HealthInfo{HealthState::kUp, t(50), 0, ""};
       }},
      {"health state",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.health->state = HealthState::kDown; }},
      {"health failures",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.health->consecutive_failures = 3; }},
      {"health reason",
       [](DriveStatus& s, LinkHealth&, std::string&) { s.health->reason = "3 time-outs"; }},
      {"health gone", [](DriveStatus& s, LinkHealth&, std::string&) { s.health.reset(); }},
      {"link requests", [](DriveStatus&, LinkHealth& l, std::string&) { ++l.requests; }},
      {"link replies", [](DriveStatus&, LinkHealth& l, std::string&) { ++l.replies; }},
      {"link missed", [](DriveStatus&, LinkHealth& l, std::string&) { ++l.missed; }},
      {"link round trip",
       [](DriveStatus&, LinkHealth& l, std::string&) { l.last_round_trip_ms = 0.25; }},
      {"endpoint", [](DriveStatus&, LinkHealth&, std::string& e) { e = "udp://10.0.0.2:49360"; }},
  };
  std::string before = get("/v1/drives/s1");
  EXPECT_EQ(before, expected());
  std::string list_before = get("/v1/drives");
  for (const auto& [what, edit] : edits) {
    SCOPED_TRACE(what);
    drive->Edit(edit);
    const std::string now = get("/v1/drives/s1");
    EXPECT_NE(now, before);  // the edit is visible at once
    EXPECT_EQ(now, expected());
    const std::string list = get("/v1/drives");
    EXPECT_NE(list, list_before);
    EXPECT_NE(list.find(now), std::string::npos);  // the list holds the same drive JSON
    before = now;
    list_before = list;
    // Unchanged: the same bytes, from the cache.
    const uint64_t hits = get_cache->hits();
    EXPECT_EQ(get("/v1/drives/s1"), now);
    EXPECT_EQ(get_cache->hits(), hits + 1);
  }
}

// Decision 1363: the core writes GetDrive and ListDrives into a message the caller owns (the
// direct route's arena). On an arena they must equal the returned messages, each read must show
// a change made just before it (endpoint, counters and status are asked per read; only the
// resource name is kept), a refused read leaves the message empty, and timestamps written in
// place must equal TimeUtil's normalisation (seconds floored, nanos in [0, 1e9)).
TEST(DirectReadsArenaTest, InPlaceReadsOnArena_EqualReturnedOnes_AndShowEveryChange) {
  auto drive = std::make_shared<ScriptedDrive>();
  server::DriveServiceCore core({drive}, nullptr);
  v1::GetDriveRequest req;
  req.set_name("drives/s1");
  // EXPECTs only: a lambda returning a value cannot ASSERT.
  const auto check = [&](const std::string& what) -> v1::Drive {
    SCOPED_TRACE(what);
    google::protobuf::Arena arena;
    auto* in_place = google::protobuf::Arena::CreateMessage<v1::Drive>(&arena);
    EXPECT_TRUE(core.GetDrive(req, {}, in_place).ok());
    auto returned = core.GetDrive(req, {});
    EXPECT_TRUE(returned.ok()) << returned.status();
    if (!returned.ok()) return {};
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(*in_place, *returned))
        << in_place->DebugString() << " vs " << returned->DebugString();
    auto* list = google::protobuf::Arena::CreateMessage<v1::ListDrivesResponse>(&arena);
    EXPECT_TRUE(core.ListDrives({}, {}, list).ok());
    EXPECT_EQ(list->drives_size(), 1);
    if (list->drives_size() == 1) {
      EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(list->drives(0), *returned));
    }
    return *returned;
  };
  v1::Drive before = check("initial");
  EXPECT_EQ(before.name(), "drives/s1");
  EXPECT_EQ(before.status().name(), "drives/s1");

  drive->Edit([](DriveStatus&, LinkHealth&, std::string& e) { e = "udp://10.0.0.9:1"; });
  EXPECT_EQ(check("endpoint").endpoint(), "udp://10.0.0.9:1");
  drive->Edit([](DriveStatus&, LinkHealth& l, std::string&) { l.replies = 41; });
  EXPECT_EQ(check("link").status().link().replies(), 41u);
  drive->Edit([](DriveStatus& s, LinkHealth&, std::string&) { s.native.text = "Operation On"; });
  EXPECT_EQ(check("native text").status().native_state().text(), "Operation On");

  using std::chrono::nanoseconds;
  for (const int64_t ns : {int64_t{-1'500'000'000}, int64_t{-1}, int64_t{0}, int64_t{1'999'999'999},
                           int64_t{1'765'000'000'123'456'789}}) {
    SCOPED_TRACE(ns);
    const WallTime t{std::chrono::duration_cast<WallTime::duration>(nanoseconds(ns))};
    drive->Edit([&](DriveStatus& s, LinkHealth&, std::string&) {
      s.time = t;
      s.last_command = CommandInfo{2, "Home", CommandState::kDone, "", t, t, {}};
      s.health = HealthInfo{HealthState::kUp, t, 0, ""};
    });
    const v1::Drive d = check("time");
    const auto expected = google::protobuf::util::TimeUtil::NanosecondsToTimestamp(ns);
    for (const google::protobuf::Timestamp* ts :
         {&d.status().time(), &d.status().last_command().create_time(),
          &d.status().last_command().end_time(), &d.status().health().since()}) {
      EXPECT_EQ(ts->seconds(), expected.seconds());
      EXPECT_EQ(ts->nanos(), expected.nanos());
    }
  }

  google::protobuf::Arena arena;
  auto* refused = google::protobuf::Arena::CreateMessage<v1::Drive>(&arena);
  v1::GetDriveRequest unknown;
  unknown.set_name("drives/nope");
  const absl::Status status = core.GetDrive(unknown, {}, refused);
  EXPECT_EQ(status, core.GetDrive(unknown, {}).status());
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(refused->ByteSizeLong(), 0u);
}

}  // namespace
}  // namespace drivegw::rest
