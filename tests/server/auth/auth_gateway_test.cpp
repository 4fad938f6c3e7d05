// The one enforcement point on the real demo gateway with auth enabled (issue 7, decision 015):
// every method of every service in proto/drivegw/v1/*.proto is called over gRPC without a token,
// with a wrong token and with a token of each role, and must be refused exactly when the role
// table says so; a method without a role entry, a service not registered or a handler that skips
// CallAuth fails here. REST: 401 with WWW-Authenticate / 403 through the real HTTP front end,
// TokenService over REST, revocation effective on the next call (API and a second connection),
// refusals audited as auth.denied.
#include <gmock/gmock.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "google/protobuf/descriptor.h"
#include "server/auth/method_roles.h"
#include "server/auth/role.h"
#include "server/gateway.h"
#include "storage/db.h"
#include "storage/token_repo.h"
#include "tests/server/rest/http_client.h"
#include "tests/support/demo_gateway.h"

namespace drivegw::server {
namespace {

using auth::Role;
using ::testing::HasSubstr;

// The first `"key": "text"` of a JSON body; "" if absent.
std::string Field(const std::string& body, const std::string& key) {
  std::smatch m;
  const std::regex re("\"" + key + "\"\\s*:\\s*\"([^\"]*)\"");
  return std::regex_search(body, m, re) ? m[1].str() : "";
}

struct Credential {
  std::string label;
  std::string token;         // "" = no authorization metadata
  std::optional<Role> role;  // nullopt = not a valid token
};

class AuthGatewayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-auth-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    GatewayOptions o = test_support::DemoGatewayOptions(data_dir_);
    o.config.auth.enabled = true;
    auto gw = Gateway::Start(o);
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
    // A second connection to the gateway's database, as the CLI in another process has.
    auto db = storage::Db::Open((std::filesystem::path(data_dir_) / "drivegw.db").string());
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    tokens_ = std::make_unique<storage::TokenRepo>(*db_);
    for (Role r : auth::kAllRoles) {
      auto t = tokens_->Create(absl::StrCat("test-", std::string(auth::RoleName(r))),
                               std::string(auth::RoleName(r)));
      ASSERT_TRUE(t.ok()) << t.status();
      token_[r] = t->token;
    }
    channel_ = grpc::CreateChannel(absl::StrCat("127.0.0.1:", gw_->grpc_port()),
                                   grpc::InsecureChannelCredentials());
  }
  void TearDown() override {
    gw_.reset();
    tokens_.reset();
    db_.reset();
    std::filesystem::remove_all(data_dir_);
  }

  // One call of `method` with an empty request message, over the generic (byte) API so every
  // kind of method is called alike: unary, client-, server-streaming. A call that was admitted
  // and keeps streaming is cancelled after its first message or `open_wait`.
  grpc::Status Call(const std::string& method, const std::string& token,
                    std::chrono::milliseconds open_wait, bool server_streaming = false) {
    grpc::GenericStub stub(channel_);
    grpc::ClientContext ctx;
    if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
    ctx.set_deadline(std::chrono::system_clock::now() + open_wait);
    grpc::CompletionQueue cq;
    auto call = stub.PrepareCall(&ctx, method, &cq);
    auto step = [&](int tag) {
      void* got = nullptr;
      bool ok = false;
      EXPECT_TRUE(cq.Next(&got, &ok));
      EXPECT_EQ(got, reinterpret_cast<void*>(static_cast<intptr_t>(tag)));
      return ok;
    };
    auto tag = [](int t) { return reinterpret_cast<void*>(static_cast<intptr_t>(t)); };
    call->StartCall(tag(1));
    step(1);
    grpc::Slice empty("");
    grpc::ByteBuffer request(&empty, 1);
    call->Write(request, tag(2));
    step(2);
    call->WritesDone(tag(3));
    step(3);
    grpc::ByteBuffer response;
    call->Read(&response, tag(4));
    // A message came: admitted; do not wait for a stream's end.
    if (step(4) && server_streaming) ctx.TryCancel();
    grpc::Status status;
    call->Finish(&status, tag(5));
    step(5);
    cq.Shutdown();
    void* got = nullptr;
    bool ok = false;
    while (cq.Next(&got, &ok)) {
    }
    return status;
  }

  int http() const { return gw_->http_port(); }
  rest::test_support::RawResponse Http(const std::string& method, const std::string& target,
                                       const std::string& token, const std::string& body = "") {
    rest::test_support::HttpClient client(static_cast<uint16_t>(http()));
    EXPECT_TRUE(client.connected());
    const std::string headers = token.empty() ? "" : "Authorization: Bearer " + token + "\r\n";
    EXPECT_TRUE(client.SendRequest(method, target, body, headers));
    auto r = client.Read();
    EXPECT_TRUE(r.has_value());
    return r.value_or(rest::test_support::RawResponse{});
  }

  // auth.denied audit rows: (result_code, request_json, principal).
  std::vector<std::tuple<int, std::string, std::string>> Denials() {
    std::vector<std::tuple<int, std::string, std::string>> out;
    auto stmt = db_->Prepare(
        "SELECT result_code, request_json, principal FROM audit_log WHERE action = 'auth.denied' "
        "ORDER BY id");
    EXPECT_TRUE(stmt.ok()) << stmt.status();
    while (stmt.ok() && stmt->Step().value_or(false)) {
      out.emplace_back(stmt->ColumnInt(0), stmt->ColumnText(1), stmt->ColumnText(2));
    }
    return out;
  }

  std::string data_dir_;
  std::unique_ptr<Gateway> gw_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::TokenRepo> tokens_;
  std::map<Role, std::string> token_;
  std::shared_ptr<grpc::Channel> channel_;
};

// Every proto file of the API, found in the source tree so a new file cannot be forgotten.
std::vector<const google::protobuf::FileDescriptor*> ApiFiles() {
  std::vector<const google::protobuf::FileDescriptor*> files;
  for (const auto& entry : std::filesystem::directory_iterator(DGW_PROTO_DIR)) {
    if (entry.path().extension() != ".proto") continue;
    const std::string name = "drivegw/v1/" + entry.path().filename().string();
    const auto* file = google::protobuf::DescriptorPool::generated_pool()->FindFileByName(name);
    EXPECT_NE(file, nullptr) << name << " is not linked into the gateway (proto/CMakeLists.txt)";
    if (file != nullptr) files.push_back(file);
  }
  return files;
}

TEST_F(AuthGatewayTest, EveryRoleEveryRpc_RefusedExactlyBelowItsRole) {
  const auto files = ApiFiles();
  ASSERT_GE(files.size(), 4u);
  int methods = 0;
  for (const auto* file : files) {
    for (int s = 0; s < file->service_count(); ++s) {
      const auto* service = file->service(s);
      for (int m = 0; m < service->method_count(); ++m) {
        const auto* method = service->method(m);
        const std::string full = absl::StrCat("/", service->full_name(), "/", method->name());
        SCOPED_TRACE(full);
        ++methods;
        const std::optional<Role> need = auth::RequiredRole(full);
        ASSERT_TRUE(need) << full << " has no entry in server/auth/method_roles.cpp";
        // Streams that are admitted may stay open: they are cut after 3 s (a refusal is
        // immediate). Unary calls get the generous deadline ctest -j3 on 2 cores needs.
        const bool streams = method->server_streaming();
        const auto admitted_wait =
            streams ? std::chrono::milliseconds(3000) : std::chrono::milliseconds(30000);
        const auto refused_wait = std::chrono::milliseconds(30000);

        std::vector<Credential> credentials = {
            {"no token", "", std::nullopt},
            {"wrong token", "dgw_0123456789abcdef_AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA",
             std::nullopt}};
        for (Role r : auth::kAllRoles) {
          credentials.push_back({std::string(auth::RoleName(r)), token_[r], r});
        }
        for (const Credential& c : credentials) {
          const bool admitted = c.role && auth::Satisfies(*c.role, *need);
          const grpc::Status st =
              Call(full, c.token, admitted ? admitted_wait : refused_wait, streams);
          if (!c.role) {
            EXPECT_EQ(st.error_code(), grpc::StatusCode::UNAUTHENTICATED)
                << c.label << ": " << st.error_message();
          } else if (!admitted) {
            EXPECT_EQ(st.error_code(), grpc::StatusCode::PERMISSION_DENIED)
                << c.label << ": " << st.error_message();
            EXPECT_THAT(st.error_message(),
                        HasSubstr(absl::StrCat("needs role ", std::string(auth::RoleName(*need)))));
            EXPECT_THAT(st.error_message(),
                        HasSubstr(absl::StrCat("has role ", std::string(auth::RoleName(*c.role)))));
          } else {
            // Admitted: whatever the empty request earns (INVALID_ARGUMENT, NOT_FOUND, OK, a
            // stream cut short), never a refusal and never an unregistered service.
            EXPECT_NE(st.error_code(), grpc::StatusCode::UNAUTHENTICATED)
                << c.label << ": " << st.error_message();
            EXPECT_NE(st.error_code(), grpc::StatusCode::PERMISSION_DENIED)
                << c.label << ": " << st.error_message();
            EXPECT_NE(st.error_code(), grpc::StatusCode::UNIMPLEMENTED)
                << c.label << ": " << st.error_message();
          }
        }
      }
    }
  }
  // Every table entry belongs to a method of the API (no stale rows).
  EXPECT_EQ(static_cast<size_t>(methods), auth::MethodRoles().size());
}

TEST_F(AuthGatewayTest, Rest_NoToken401WithChallenge_LowRole403_RightRoleServed) {
  auto none = Http("GET", "/v1/drives", "");
  EXPECT_EQ(none.status, 401) << none.body;
  EXPECT_EQ(none.header("www-authenticate"), "Bearer realm=\"drivegw\"");
  EXPECT_THAT(none.body, HasSubstr("\"code\":16"));

  auto wrong = Http("GET", "/v1/drives", "dgw_nonsense");
  EXPECT_EQ(wrong.status, 401) << wrong.body;

  auto listed = Http("GET", "/v1/drives", token_[Role::kViewer]);
  EXPECT_EQ(listed.status, 200) << listed.body;
  EXPECT_THAT(listed.body, HasSubstr("drives/x1"));

  auto enable = Http("POST", "/v1/drives/x1:enable", token_[Role::kViewer], "{}");
  EXPECT_EQ(enable.status, 403) << enable.body;
  EXPECT_THAT(enable.body, HasSubstr("/drivegw.v1.DriveService/Enable needs role operator; "
                                     "principal 'test-viewer' has role viewer"));
  EXPECT_TRUE(enable.header("www-authenticate").empty());

  auto by_operator = Http("POST", "/v1/drives/x1:enable", token_[Role::kOperator], "{}");
  EXPECT_NE(by_operator.status, 401) << by_operator.body;
  EXPECT_NE(by_operator.status, 403) << by_operator.body;
}

TEST_F(AuthGatewayTest, TokenServiceOverRest_AdminOnly_NewTokenWorks_RevocationImmediate) {
  auto refused = Http("POST", "/v1/tokens", token_[Role::kEngineer],
                      R"({"name": "mes-line-3", "role": "operator"})");
  EXPECT_EQ(refused.status, 403) << refused.body;

  auto created = Http("POST", "/v1/tokens", token_[Role::kAdmin],
                      R"({"name": "mes-line-3", "role": "operator"})");
  ASSERT_EQ(created.status, 200) << created.body;
  const std::string secret = Field(created.body, "secret");
  ASSERT_THAT(secret, ::testing::StartsWith("dgw_"));

  EXPECT_EQ(Http("GET", "/v1/drives", secret).status, 200);
  auto list = Http("GET", "/v1/tokens", token_[Role::kAdmin]);
  ASSERT_EQ(list.status, 200) << list.body;
  EXPECT_THAT(list.body, HasSubstr("tokens/mes-line-3"));
  EXPECT_THAT(list.body, ::testing::Not(HasSubstr(secret.substr(21)))) << "no secrets listed";

  auto revoked = Http("POST", "/v1/tokens/mes-line-3:revoke", token_[Role::kAdmin], "{}");
  ASSERT_EQ(revoked.status, 200) << revoked.body;
  auto after = Http("GET", "/v1/drives", secret);
  EXPECT_EQ(after.status, 401) << after.body;
  EXPECT_THAT(after.body, HasSubstr("revoked"));
}

TEST_F(AuthGatewayTest, RevokedByAnotherConnection_RefusedOnTheNextCall) {
  EXPECT_EQ(Http("GET", "/v1/drives", token_[Role::kOperator]).status, 200);
  ASSERT_TRUE(tokens_->Revoke("test-operator").ok());  // the CLI's way: straight into SQLite
  EXPECT_EQ(Http("GET", "/v1/drives", token_[Role::kOperator]).status, 401);
  const grpc::Status st = Call("/drivegw.v1.DriveService/ListDrives", token_[Role::kOperator],
                               std::chrono::milliseconds(30000));
  EXPECT_EQ(st.error_code(), grpc::StatusCode::UNAUTHENTICATED) << st.error_message();
}

TEST_F(AuthGatewayTest, Refusals_AuditedAsAuthDeniedWithMethodAndPrincipal) {
  EXPECT_EQ(Http("GET", "/v1/drives", "").status, 401);
  EXPECT_EQ(
      Http("POST", "/v1/drives/x1:moveAbsolute", token_[Role::kViewer], R"({"position_mm": 10})")
          .status,
      403);
  const auto denials = Denials();
  ASSERT_EQ(denials.size(), 2u);
  const auto& [code401, request401, principal401] = denials[0];
  EXPECT_EQ(code401, static_cast<int>(absl::StatusCode::kUnauthenticated));
  EXPECT_THAT(request401, HasSubstr("/drivegw.v1.DriveService/ListDrives"));
  EXPECT_EQ(principal401, "(unauthenticated)");
  const auto& [code403, request403, principal403] = denials[1];
  EXPECT_EQ(code403, static_cast<int>(absl::StatusCode::kPermissionDenied));
  EXPECT_THAT(request403, HasSubstr("/drivegw.v1.DriveService/MoveAbsolute"));
  EXPECT_EQ(principal403, "test-viewer");
}

}  // namespace
}  // namespace drivegw::server
