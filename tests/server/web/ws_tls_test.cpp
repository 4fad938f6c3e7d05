// The status WebSocket over TLS (decision 504 item 1, decision 023): a RestServer with rest.tls
// in front of the demo gateway's gRPC port, certificates made by openssl at test time; wss://
// gets status frames, a plain ws:// client on the TLS port gets no handshake.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/gateway.h"
#include "server/rest/server.h"
#include "tests/server/tls/test_pki.h"
#include "tests/server/web/ws_client.h"
#include "tests/support/demo_gateway.h"

namespace drivegw::server {
namespace {

using rest::test_support::WsClient;
using rest::test_support::WssClient;

TEST(WebTls, StatusStreamOverWss) {
  drivegw::testing::TestPki pki;
  ASSERT_TRUE(pki.MakeCa("ca", "drivegw test CA"));
  ASSERT_TRUE(pki.MakeLeaf("ca", "server", "localhost", /*server=*/true));

  char tmpl[] = "/tmp/drivegw-web-tls-XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  const std::string data_dir = tmpl;
  GatewayOptions o = test_support::DemoGatewayOptions(data_dir);
  auto gw = Gateway::Start(o);
  ASSERT_TRUE(gw.ok()) << gw.status();

  rest::RestOptions ro;
  ro.listen_address = "127.0.0.1";
  ro.port = 0;
  ro.channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*gw)->grpc_port()),
                                   grpc::InsecureChannelCredentials());
  ro.tls = rest::RestTls{drivegw::testing::ReadFile(pki.Path("server.pem")),
                         drivegw::testing::ReadFile(pki.Path("server.key")), "", false};
  auto rest = rest::RestServer::Start(std::move(ro));
  ASSERT_TRUE(rest.ok()) << rest.status();

  {
    boost::asio::ssl::context tls(boost::asio::ssl::context::tls_client);
    tls.load_verify_file(pki.Path("ca.pem"));
    tls.set_verify_mode(boost::asio::ssl::verify_peer);
    WssClient wss(tls);
    ASSERT_TRUE(wss.Connect((*rest)->port(), "/v1/drives:ws?names=x1"));
    auto frame = wss.Read();
    ASSERT_TRUE(frame.has_value());
    const auto j = nlohmann::json::parse(*frame);
    EXPECT_EQ(j.at("type"), "status") << *frame;
    EXPECT_EQ(j.at("status").at("name"), "drives/x1");
    wss.Close();
  }
  {
    WsClient plain;  // speaks HTTP into a TLS port: no upgrade
    EXPECT_FALSE(plain.Connect((*rest)->port(), "/v1/drives:ws?names=x1"));
  }
  rest->reset();
  gw->reset();
  std::filesystem::remove_all(data_dir);
}

}  // namespace
}  // namespace drivegw::server
