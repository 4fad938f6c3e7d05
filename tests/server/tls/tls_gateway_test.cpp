// A real gateway (no drives, SQLite in a temp dir) with the tls: section on both ports, checked
// with curl and the gRPC C++ client against certificates made by openssl at test time: HTTPS
// and gRPC over TLS with a trusted and an untrusted CA, mTLS required and optional, and the
// client certificate's CN mapped to the principal that the audit log records.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/config/config.h"
#include "server/gateway.h"
#include "storage/db.h"
#include "tests/server/rest/http_client.h"
#include "tests/server/tls/test_pki.h"

namespace drivegw::server {
namespace {

using testing::Curl;
using testing::Quote;
using testing::ReadFile;
using testing::TestPki;

constexpr auto kCallTimeout = std::chrono::seconds(20);

class TlsGatewayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    pki_ = new TestPki();
    ASSERT_TRUE(pki_->MakeCa("ca", "drivegw test CA"));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "server", "localhost", /*server=*/true));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "line3", "line-3", /*server=*/false));
    // A CA nobody trusts, with a client certificate of the same CN.
    ASSERT_TRUE(pki_->MakeCa("rogue-ca", "rogue CA"));
    ASSERT_TRUE(pki_->MakeLeaf("rogue-ca", "rogue", "line-3", /*server=*/false));
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }
  static std::string P(const std::string& file) { return pki_->Path(file); }

  void TearDown() override {
    gw_.reset();
    if (!data_dir_.empty()) std::filesystem::remove_all(data_dir_);
  }

  // Starts a gateway without drives whose tls: section is cert + key + `extra`; with `auth`,
  // calls need a bearer token or a mapped client certificate (decision 015).
  void Start(const std::string& extra, bool auth = false) {
    char tmpl[] = "/tmp/drivegw-tls-gw-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    std::string yaml = "listen: {grpc: \"127.0.0.1:0\", http: \"127.0.0.1:0\"}\n";
    yaml += "data_dir: \"" + data_dir_ + "\"\n";
    if (auth) yaml += "auth: {enabled: true}\n";
    yaml += "tls:\n  cert: \"" + P("server.pem") + "\"\n  key: \"" + P("server.key") + "\"\n";
    yaml += extra;
    auto cfg = config::ParseConfig(yaml);
    ASSERT_TRUE(cfg.ok()) << cfg.status();
    GatewayOptions options;
    options.config = *std::move(cfg);
    options.config.demo = false;  // no drives, no simulators: only the two ports matter here
    auto gw = Gateway::Start(std::move(options));
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
  }

  // mTLS: the client CA, and `line-3` mapped to principal mes-line-3 with role operator.
  static std::string ClientCa(bool required) {
    return "  client_ca: \"" + P("ca.pem") +
           "\"\n  require_client_cert: " + (required ? "true" : "false") +
           "\n  client_principals:\n"
           "    - {common_name: line-3, principal: mes-line-3, role: operator}\n";
  }

  // curl options: trust our CA, and present client certificate `client` ("" for none).
  static std::string Trust(const std::string& client = "") {
    std::string o = "--cacert " + Quote(P("ca.pem"));
    if (!client.empty())
      o += " --cert " + Quote(P(client + ".pem")) + " --key " + Quote(P(client + ".key"));
    return o;
  }

  // A DriveService stub over TLS that trusts `root_ca` and presents `client` ("" for none).
  std::unique_ptr<v1::DriveService::Stub> TlsStub(const std::string& root_ca,
                                                  const std::string& client = "") const {
    grpc::SslCredentialsOptions o;
    o.pem_root_certs = ReadFile(P(root_ca + ".pem"));
    if (!client.empty()) {
      o.pem_cert_chain = ReadFile(P(client + ".pem"));
      o.pem_private_key = ReadFile(P(client + ".key"));
    }
    return v1::DriveService::NewStub(grpc::CreateChannel(Target(), grpc::SslCredentials(o)));
  }
  std::string Target() const { return "127.0.0.1:" + std::to_string(gw_->grpc_port()); }

  static grpc::Status ListDrives(v1::DriveService::Stub& stub) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + kCallTimeout);
    v1::ListDrivesRequest req;
    v1::ListDrivesResponse resp;
    return stub.ListDrives(&ctx, req, &resp);
  }

  // The principal of the newest audit entry of `action` on `drive` ("" if none); an unknown
  // drive is audited by the name as sent, which over REST is the resource name "drives/<name>".
  std::string AuditPrincipal(const std::string& action, const std::string& drive) const {
    auto db = storage::Db::Open((std::filesystem::path(data_dir_) / "drivegw.db").string());
    EXPECT_TRUE(db.ok()) << db.status();
    if (!db.ok()) return "";
    auto stmt = db->Prepare(
        "SELECT principal FROM audit_log WHERE action = ?1 AND (drive = ?2 OR drive = 'drives/' "
        "|| ?2) ORDER BY id DESC LIMIT 1");
    EXPECT_TRUE(stmt.ok()) << stmt.status();
    if (!stmt.ok() || !stmt->Bind(1, action).ok() || !stmt->Bind(2, drive).ok()) return "";
    auto row = stmt->Step();
    return row.ok() && *row ? stmt->ColumnText(0) : "";
  }

  static TestPki* pki_;
  std::string data_dir_;
  std::unique_ptr<Gateway> gw_;
};
TestPki* TlsGatewayTest::pki_ = nullptr;

TEST_F(TlsGatewayTest, Https_TrustedCa_ServesAndUntrustedFails) {
  ASSERT_NO_FATAL_FAILURE(Start(""));
  const int port = gw_->http_port();
  auto ok = Curl(port, "/v1/drives", Trust());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("HTTP 200"), std::string::npos) << ok.output;

  // Without trusting the CA the client refuses the server: curl exit 60 (peer certificate).
  auto untrusted = Curl(port, "/v1/drives", "");
  EXPECT_EQ(untrusted.exit_code, 60) << untrusted.output;
  auto rogue = Curl(port, "/v1/drives", "--cacert " + Quote(P("rogue-ca.pem")));
  EXPECT_EQ(rogue.exit_code, 60) << rogue.output;

  // HTTP/1.0: the response ends with "Connection: close" (the TLS close path of the session).
  auto http10 = Curl(port, "/v1/drives", Trust() + " --http1.0");
  EXPECT_EQ(http10.exit_code, 0) << http10.output;
  EXPECT_NE(http10.output.find("HTTP 200"), std::string::npos) << http10.output;

  // Plain HTTP on the TLS port gets no HTTP answer.
  rest::test_support::HttpClient plain(static_cast<uint16_t>(port));
  ASSERT_TRUE(plain.connected());
  ASSERT_TRUE(plain.SendRequest("GET", "/v1/drives", ""));
  auto r = plain.Read();
  EXPECT_FALSE(r.has_value() && r->status == 200);

  // Still serving after all of that.
  auto again = Curl(port, "/v1/drives", Trust());
  EXPECT_NE(again.output.find("HTTP 200"), std::string::npos) << again.output;
}

TEST_F(TlsGatewayTest, Grpc_Tls_TrustedCaWorksOthersFail) {
  ASSERT_NO_FATAL_FAILURE(Start(""));
  auto stub = TlsStub("ca");
  grpc::Status s = ListDrives(*stub);
  EXPECT_TRUE(s.ok()) << s.error_code() << " " << s.error_message();

  auto insecure =
      v1::DriveService::NewStub(grpc::CreateChannel(Target(), grpc::InsecureChannelCredentials()));
  EXPECT_EQ(ListDrives(*insecure).error_code(), grpc::StatusCode::UNAVAILABLE);
  auto rogue = TlsStub("rogue-ca");
  EXPECT_EQ(ListDrives(*rogue).error_code(), grpc::StatusCode::UNAVAILABLE);
}

TEST_F(TlsGatewayTest, Mtls_Required_HandshakeNeedsTrustedClientCert) {
  ASSERT_NO_FATAL_FAILURE(Start(ClientCa(/*required=*/true)));
  const int port = gw_->http_port();
  // No client certificate: the handshake (or, in TLS 1.3, the first read) fails.
  auto none = Curl(port, "/v1/drives", Trust());
  EXPECT_NE(none.exit_code, 0) << none.output;
  EXPECT_EQ(none.output.find("HTTP 200"), std::string::npos) << none.output;
  // A certificate of the same CN from an untrusted CA fails the same way.
  auto rogue = Curl(port, "/v1/drives", Trust("rogue"));
  EXPECT_NE(rogue.exit_code, 0) << rogue.output;
  EXPECT_EQ(rogue.output.find("HTTP 200"), std::string::npos) << rogue.output;
  auto ok = Curl(port, "/v1/drives", Trust("line3"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("HTTP 200"), std::string::npos) << ok.output;

  EXPECT_EQ(ListDrives(*TlsStub("ca")).error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(ListDrives(*TlsStub("ca", "rogue")).error_code(), grpc::StatusCode::UNAVAILABLE);
  grpc::Status s = ListDrives(*TlsStub("ca", "line3"));
  EXPECT_TRUE(s.ok()) << s.error_code() << " " << s.error_message();
}

TEST_F(TlsGatewayTest, Mtls_Optional_AnonymousAllowedUntrustedRefused) {
  ASSERT_NO_FATAL_FAILURE(Start(ClientCa(/*required=*/false)));
  const int port = gw_->http_port();
  auto none = Curl(port, "/v1/drives", Trust());
  EXPECT_NE(none.output.find("HTTP 200"), std::string::npos) << none.output;
  auto rogue = Curl(port, "/v1/drives", Trust("rogue"));
  EXPECT_EQ(rogue.output.find("HTTP 200"), std::string::npos) << rogue.output;

  grpc::Status s = ListDrives(*TlsStub("ca"));
  EXPECT_TRUE(s.ok()) << s.error_code() << " " << s.error_message();
  EXPECT_EQ(ListDrives(*TlsStub("ca", "rogue")).error_code(), grpc::StatusCode::UNAVAILABLE);
}

// With auth on, the client certificate's mapped principal (role operator) is the caller, over
// HTTPS (CN passed in process by the REST server) and over gRPC (CN from the TLS auth context):
// Enable passes authorisation and the audit log records the principal.
TEST_F(TlsGatewayTest, Mtls_ClientCert_MappedPrincipalAudited) {
  ASSERT_NO_FATAL_FAILURE(Start(ClientCa(/*required=*/true), /*auth=*/true));
  // A drive that does not exist: the command is refused (NOT_FOUND) but audited.
  auto https =
      Curl(gw_->http_port(), "/v1/drives/via-https:enable", Trust("line3") + " -X POST -d '{}'");
  EXPECT_NE(https.output.find("HTTP 404"), std::string::npos) << https.output;
  EXPECT_EQ(AuditPrincipal("Enable", "via-https"), "mes-line-3");

  auto stub = TlsStub("ca", "line3");
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + kCallTimeout);
  v1::EnableRequest req;
  req.set_name("via-grpc");
  v1::CommandHandle resp;
  EXPECT_EQ(stub->Enable(&ctx, req, &resp).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(AuditPrincipal("Enable", "via-grpc"), "mes-line-3");
}

// A client without a certificate cannot claim a CN through the metadata the REST server uses
// in process: over gRPC it is ignored from a network peer, over HTTP it is never forwarded.
TEST_F(TlsGatewayTest, ClientCnMetadataFromClients_Ignored) {
  ASSERT_NO_FATAL_FAILURE(Start(ClientCa(/*required=*/false), /*auth=*/true));
  auto stub = TlsStub("ca");
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + kCallTimeout);
  ctx.AddMetadata("x-drivegw-client-cn-bin", "line-3");
  v1::EnableRequest req;
  req.set_name("spoofed");
  v1::CommandHandle resp;
  EXPECT_EQ(stub->Enable(&ctx, req, &resp).error_code(), grpc::StatusCode::UNAUTHENTICATED);

  // base64("line-3"), as gRPC would carry a -bin value.
  auto https = Curl(gw_->http_port(), "/v1/drives/spoofed:enable",
                    Trust() + " -X POST -d '{}' -H 'x-drivegw-client-cn-bin: bGluZS0z'");
  EXPECT_NE(https.output.find("HTTP 401"), std::string::npos) << https.output;

  // The same client with its certificate is the mapped operator.
  auto mapped =
      Curl(gw_->http_port(), "/v1/drives/spoofed:enable", Trust("line3") + " -X POST -d '{}'");
  EXPECT_NE(mapped.output.find("HTTP 404"), std::string::npos) << mapped.output;
}

}  // namespace
}  // namespace drivegw::server
