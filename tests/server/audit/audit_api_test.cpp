// AuditService through both front ends on the real stack: REST (RestServer over TCP -> router ->
// in-process gRPC -> AuditServiceGrpc -> AuditServiceCore) with the export as NDJSON, and a gRPC
// client over TCP watching new entries (decision 017).
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <sstream>
#include <thread>

#include "drivegw/v1/audit.grpc.pb.h"
#include "nlohmann/json.hpp"
#include "server/grpc/audit_service_grpc.h"
#include "server/rest/server.h"
#include "tests/server/rest/http_client.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::server {
namespace {

using storage::testing::MakeEntry;
using ::testing::HasSubstr;

class AuditApiTest : public storage::testing::AuditDbTest {
 protected:
  void SetUp() override {
    AuditDbTest::SetUp();
    core_ = std::make_unique<AuditServiceCore>(*log_);
    service_ = std::make_unique<AuditServiceGrpc>(*core_, pool_, CallAuth::Open());
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    rest::RestOptions o;
    o.listen_address = "127.0.0.1";
    o.port = 0;
    o.channel = server_->InProcessChannel(grpc::ChannelArguments());
    o.openapi_json = "{}";
    o.more_services = {"drivegw.v1.AuditService"};
    auto rest = rest::RestServer::Start(std::move(o));
    ASSERT_TRUE(rest.ok()) << rest.status();
    rest_ = *std::move(rest);
  }
  void TearDown() override {
    core_->Shutdown();
    if (rest_) rest_->Stop();
    if (server_) {
      server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
      server_->Wait();
    }
    pool_.Shutdown();
  }

  rest::test_support::RawResponse Fetch(std::string_view method, std::string_view target,
                                        std::string_view body = {}) {
    rest::test_support::HttpClient c(rest_->port());
    EXPECT_TRUE(c.connected());
    EXPECT_TRUE(c.SendRequest(method, target, body));
    auto r = c.Read();
    EXPECT_TRUE(r.has_value()) << method << " " << target;
    return r.value_or(rest::test_support::RawResponse{});
  }

  WorkerPool pool_{2};
  std::unique_ptr<AuditServiceCore> core_;
  std::unique_ptr<AuditServiceGrpc> service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<rest::RestServer> rest_;
};

TEST_F(AuditApiTest, RestExport_NdjsonLinesOldestFirst) {
  for (int i = 0; i < 5; ++i) AppendOrDie(MakeEntry(i % 2 ? "x2" : "x1", "Enable"));
  const auto r = Fetch("GET", "/v1/auditEvents:export?drive=x1");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_THAT(r.header("content-type"), HasSubstr("application/x-ndjson"));
  std::istringstream in(r.body);
  std::string line;
  std::vector<nlohmann::json> lines;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    auto j = nlohmann::json::parse(line, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << line;
    lines.push_back(j);
  }
  ASSERT_EQ(lines.size(), 3u);
  for (size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i]["drive"], "x1");
    EXPECT_EQ(lines[i]["hash"].get<std::string>().size(), 64u);
    if (i > 0) {
      EXPECT_LT(std::stoll(lines[i - 1]["sequence"].get<std::string>()),
                std::stoll(lines[i]["sequence"].get<std::string>()));
    }
  }
}

// Gap 14 over REST: a bad time on export is a 400 naming the field, not a broken stream; watch
// has no time filters (it streams what is appended after it starts), so a time there is an
// unknown query parameter, named.
TEST_F(AuditApiTest, RestExportAndWatch_BadTimes_400NamingTheParameter) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  auto r = Fetch("GET", "/v1/auditEvents:export?start_time=2024-05-01");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_THAT(r.body, HasSubstr("start_time: timestamp: '2024-05-01' is not UTC ISO-8601"));
  r = Fetch("GET",
            "/v1/auditEvents:export?start_time=2024-05-02T00:00:00Z&end_time=2024-05-01T00:00:00Z");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_THAT(r.body, HasSubstr("is not after start_time"));
  r = Fetch("GET", "/v1/auditEvents:watch?start_time=2024-05-01T00:00:00Z");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_THAT(r.body, HasSubstr("start_time"));
  // Still serving.
  EXPECT_EQ(Fetch("GET", "/v1/auditEvents:export").status, 200);
}

TEST_F(AuditApiTest, RestListAndVerify) {
  for (int i = 0; i < 5; ++i) AppendOrDie(MakeEntry("x1", "Enable"));
  auto r = Fetch("GET", "/v1/auditEvents?action=Enable&page_size=2");
  ASSERT_EQ(r.status, 200) << r.body;
  auto j = nlohmann::json::parse(r.body);
  EXPECT_EQ(j["events"].size(), 2u);
  EXPECT_FALSE(j["next_page_token"].get<std::string>().empty());
  r = Fetch("GET", "/v1/auditEvents?start_time=soon");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(r.body, HasSubstr("start_time"));

  r = Fetch("POST", "/v1/auditLog:verify", "{}");
  ASSERT_EQ(r.status, 200) << r.body;
  j = nlohmann::json::parse(r.body);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["verified_entries"], "6");
  EXPECT_EQ(j["anchor"], "genesis");
}

TEST_F(AuditApiTest, GrpcWatch_ReceivesEntriesAppendedAfterTheStart) {
  auto stub = v1::AuditService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                                            grpc::InsecureChannelCredentials()));
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  v1::WatchAuditEventsRequest req;
  req.set_action("MoveAbsolute");
  auto reader = stub->WatchAuditEvents(&ctx, req);
  // The stream's start point is taken on the server when the call arrives; keep appending until
  // one arrives (each append is a new entry after any start point).
  std::atomic<bool> got{false};
  std::thread writer([&] {
    for (int i = 0; i < 600 && !got.load(); ++i) {
      AppendOrDie(MakeEntry("x1", "MoveAbsolute"));
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  v1::AuditEvent e;
  const bool read = reader->Read(&e);
  got.store(true);
  writer.join();
  ASSERT_TRUE(read);
  EXPECT_EQ(e.action(), "MoveAbsolute");
  EXPECT_EQ(e.principal(), "alice");
  ctx.TryCancel();
  reader->Finish().IgnoreError();
}

}  // namespace
}  // namespace drivegw::server
