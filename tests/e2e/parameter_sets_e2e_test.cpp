// End to end over real sockets (issue 6): the demo gateway's REST front end, parameter sets for the
// simulated Trinamic SIXpack axis feeder-x (pty): create -> apply (dry run, then real) -> poll the
// operation until done -> the drive holds the value; a stale etag is 412; the audit log has the
// create and both apply entries.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <random>
#include <regex>
#include <string>
#include <thread>

#include "drivegw/v1/parameter_sets.grpc.pb.h"
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

// The first `"key": "text"` (or number) of a JSON body; "" if absent.
std::string Field(const std::string& body, const std::string& key) {
  std::smatch m;
  const std::regex re("\"" + key + "\"\\s*:\\s*(\"([^\"]*)\"|(-?[0-9]+)|(true|false))");
  if (!std::regex_search(body, m, re)) return "";
  if (m[2].matched) return m[2];
  if (m[3].matched) return m[3];
  return m[4];
}

class ParameterSetsE2eTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-ps-e2e-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    GatewayOptions o = test_support::DemoGatewayOptions(data_dir_);
    auto gw = Gateway::Start(o);
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
  }
  void TearDown() override {
    gw_.reset();
    std::filesystem::remove_all(data_dir_);
  }
  int http() const { return gw_->http_port(); }

  // Polls GET /v1/operations/{id} until done (the apply runs in the background).
  std::string WaitDone(const std::string& name) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    std::string body;
    while (std::chrono::steady_clock::now() < deadline) {
      auto r = HttpRequest(http(), "GET", "/v1/" + name);
      EXPECT_EQ(r.status, 200) << r.body;
      body = r.body;
      if (Field(body, "done") == "true") return body;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // polling, not a timing assert
    }
    ADD_FAILURE() << name << " not done: " << body;
    return body;
  }

  std::string data_dir_;
  std::unique_ptr<Gateway> gw_;
};

TEST_F(ParameterSetsE2eTest, Rest_CreateApplyDryRunAndRealGetOperationAudited) {
  // One OpenAPI document for both services (merged at build time).
  auto openapi = HttpRequest(http(), "GET", "/openapi.json");
  ASSERT_EQ(openapi.status, 200);
  EXPECT_NE(openapi.body.find("/v1/parameterSets:import"), std::string::npos);
  EXPECT_NE(openapi.body.find("/v1/drives"), std::string::npos);

  // The catalogue is served per family.
  auto defs = HttpRequest(http(), "GET", "/v1/families/trinamic/parameterDefinitions?filter=vmax");
  ASSERT_EQ(defs.status, 200) << defs.body;
  EXPECT_NE(defs.body.find("\"$14.vmax\""), std::string::npos) << defs.body;

  auto created = HttpRequest(http(), "POST", "/v1/parameterSets",
                             R"({"name": "feeder-slow", "family": "trinamic",
                                 "parameters": [{"parameter": "$14.VMAX", "value": 300}]})");
  ASSERT_EQ(created.status, 200) << created.body;
  EXPECT_EQ(Field(created.body, "name"), "parameterSets/feeder-slow");
  EXPECT_EQ(Field(created.body, "parameter"), "$14.vmax");  // canonical name stored
  const std::string id = Field(created.body, "id");
  ASSERT_FALSE(id.empty()) << created.body;
  const std::string etag = Field(created.body, "etag");

  auto before = HttpRequest(http(), "GET", "/v1/drives/feeder-x/parameters/" + id);
  ASSERT_EQ(before.status, 200) << before.body;
  ASSERT_NE(Field(before.body, "value"), "300") << "the demo must start elsewhere: " << before.body;

  // Dry run: the operation comes back at once, ends SUCCEEDED, nothing written.
  auto dry = HttpRequest(http(), "POST", "/v1/parameterSets/feeder-slow:apply",
                         R"({"drives": ["drives/feeder-x"], "dry_run": true})");
  ASSERT_EQ(dry.status, 200) << dry.body;
  const std::string dry_name = Field(dry.body, "name");
  ASSERT_EQ(dry_name.rfind("operations/op-", 0), 0u) << dry.body;
  const std::string dry_done = WaitDone(dry_name);
  EXPECT_EQ(Field(dry_done, "state"), "SUCCEEDED") << dry_done;
  auto unchanged = HttpRequest(http(), "GET", "/v1/drives/feeder-x/parameters/" + id);
  EXPECT_EQ(Field(unchanged.body, "value"), Field(before.body, "value"));

  auto real = HttpRequest(http(), "POST", "/v1/parameterSets/feeder-slow:apply",
                          R"({"drives": ["feeder-x"]})");
  ASSERT_EQ(real.status, 200) << real.body;
  const std::string done = WaitDone(Field(real.body, "name"));
  EXPECT_EQ(Field(done, "state"), "SUCCEEDED") << done;
  EXPECT_NE(done.find("\"pre_image\""), std::string::npos) << done;
  auto after = HttpRequest(http(), "GET", "/v1/drives/feeder-x/parameters/" + id);
  ASSERT_EQ(after.status, 200) << after.body;
  EXPECT_EQ(Field(after.body, "value"), "300") << after.body;

  // Diff against the drive now: nothing differs.
  auto diff =
      HttpRequest(http(), "POST", "/v1/parameterSets/feeder-slow:diff", R"({"drive": "feeder-x"})");
  ASSERT_EQ(diff.status, 200) << diff.body;
  EXPECT_EQ(Field(diff.body, "differing"), "0") << diff.body;

  // Export as CSV.
  auto csv = HttpRequest(http(), "GET",
                         "/v1/parameterSets/feeder-slow:export?format=PARAMETER_SET_FORMAT_CSV");
  ASSERT_EQ(csv.status, 200) << csv.body;
  EXPECT_NE(csv.body.find("$14.vmax,300"), std::string::npos) << csv.body;

  // Update with the etag, then the same etag again is stale: 412 naming the version.
  const std::string update =
      R"({"name": "parameterSets/feeder-slow", "parameters": [{"parameter": "$14.vmax", "value": 250}]})";
  auto ok = HttpRequest(http(), "PATCH", "/v1/parameterSets/feeder-slow?etag=" + etag, update);
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(Field(ok.body, "version"), "2");
  auto stale = HttpRequest(http(), "PATCH", "/v1/parameterSets/feeder-slow?etag=" + etag, update);
  EXPECT_EQ(stale.status, 412) << stale.body;
  EXPECT_NE(stale.body.find("version 2"), std::string::npos) << stale.body;

  // If-Match carries the etag too: a stale one is 412, the current one deletes the set.
  auto del = [&](const std::string& tag) {
    rest::test_support::HttpClient client(static_cast<uint16_t>(http()));
    EXPECT_TRUE(client.SendRequest("DELETE", "/v1/parameterSets/feeder-slow", "",
                                   "If-Match: \"" + tag + "\"\r\n"));
    auto r = client.Read();
    return r ? r->status : 0;
  };
  EXPECT_EQ(del(etag), 412);
  // Malformed or empty tags never delete: an unbalanced quote or a list is an opaque tag that
  // matches nothing (412); an empty one is refused (400), it would read as "unconditional".
  auto del_raw = [&](const std::string& value) {
    rest::test_support::HttpClient client(static_cast<uint16_t>(http()));
    EXPECT_TRUE(client.SendRequest("DELETE", "/v1/parameterSets/feeder-slow", "",
                                   "If-Match: " + value + "\r\n"));
    auto r = client.Read();
    return r ? r->status : 0;
  };
  EXPECT_EQ(del_raw("\"abc"), 412);
  EXPECT_EQ(del_raw("\"a\", \"b\""), 412);
  EXPECT_EQ(del_raw("\"\""), 400);
  EXPECT_EQ(del_raw("W/\"\""), 400);
  EXPECT_EQ(HttpRequest(http(), "GET", "/v1/parameterSets/feeder-slow").status, 200);
  EXPECT_EQ(del(Field(ok.body, "etag")), 200);
  EXPECT_EQ(HttpRequest(http(), "GET", "/v1/parameterSets/feeder-slow").status, 404);

  // A malformed import names line and field.
  auto bad =
      HttpRequest(http(), "POST", "/v1/parameterSets:import",
                  R"({"format": "PARAMETER_SET_FORMAT_CSV", "name": "x", "family": "trinamic",
                             "content": "parameter,value\n$14.vmax,abc\n"})");
  EXPECT_EQ(bad.status, 400) << bad.body;
  EXPECT_NE(bad.body.find("line 2, field value: 'abc' is not an integer"), std::string::npos)
      << bad.body;

  // Audit: create, update, both applies started and finished.
  auto db = storage::Db::Open((std::filesystem::path(data_dir_) / "drivegw.db").string());
  ASSERT_TRUE(db.ok()) << db.status();
  storage::AuditLog audit(*db);
  auto count = [&](const std::string& action) {
    storage::AuditQuery q;
    q.action = action;
    auto r = audit.Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? r->size() : 0u;
  };
  // The finished-apply entry is written just after the operation turns done: poll for it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (count("ApplyParameterSet.done") < 2u && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(count("CreateParameterSet"), 1u);
  EXPECT_EQ(count("UpdateParameterSet"), 2u);
  EXPECT_EQ(count("ApplyParameterSet"), 2u);
  EXPECT_EQ(count("ApplyParameterSet.done"), 2u);
  EXPECT_EQ(count("ImportParameterSet"), 1u);
  // Three refused with 412 (one stale, two malformed tags) and the one that deleted; the two
  // empty tags were refused by the REST front end before any call, so they are not audited.
  EXPECT_EQ(count("DeleteParameterSet"), 4u);
}

TEST_F(ParameterSetsE2eTest, Grpc_CaptureFromDriveThenStaleEtagIsFailedPreconditionWithEtagDetail) {
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = v1::ParameterSetService::NewStub(channel);

  v1::CaptureParameterSetRequest capture;
  capture.set_name("parameterSets/feeder-now");
  capture.set_drive("drives/feeder-x");
  capture.add_parameters("$14.vmax");
  v1::ParameterSet set;
  {
    grpc::ClientContext ctx;
    const grpc::Status s = stub->CaptureParameterSet(&ctx, capture, &set);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  EXPECT_EQ(set.family(), "trinamic");
  ASSERT_EQ(set.parameters_size(), 1);
  EXPECT_EQ(set.parameters(0).parameter(), "$14.vmax");

  v1::UpdateParameterSetRequest update;
  *update.mutable_parameter_set() = set;
  update.mutable_parameter_set()->mutable_parameters(0)->set_value(100);
  update.set_etag(set.etag());
  v1::ParameterSet v2;
  {
    grpc::ClientContext ctx;
    ASSERT_TRUE(stub->UpdateParameterSet(&ctx, update, &v2).ok());
  }
  grpc::ClientContext ctx;
  const grpc::Status stale = stub->UpdateParameterSet(&ctx, update, &v2);
  ASSERT_EQ(stale.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(stale.error_message().find("version 2"), std::string::npos) << stale.error_message();
  google::rpc::Status rich;
  ASSERT_TRUE(rich.ParseFromString(stale.error_details()));
  ASSERT_EQ(rich.details_size(), 1);
  google::rpc::PreconditionFailure pf;
  ASSERT_TRUE(rich.details(0).UnpackTo(&pf));
  EXPECT_EQ(pf.violations(0).type(), "ETAG");
  EXPECT_EQ(pf.violations(0).subject(), "parameterSets/feeder-now");
}

}  // namespace
}  // namespace drivegw::server
