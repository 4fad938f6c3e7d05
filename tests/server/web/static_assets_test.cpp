// The embedded dashboard files (decision 505): a fixture dist (tests/server/web/fixture_dist)
// embedded by the same cmake/embed_web_assets.cmake as web/dist, served through the real
// RestServer over TCP: Content-Type, cache headers, 404 for anything else, 503 when not built.
#include "server/rest/static_assets.h"

#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "server/rest/server.h"
#include "tests/server/rest/http_client.h"

namespace drivegw::rest {

const WebAssetSet& FixtureWebAssets();  // generated from tests/server/web/fixture_dist

namespace {

using test_support::HttpClient;
using test_support::RawResponse;

TEST(StaticAssets, FixtureEmbedded_EveryFileWithItsBytes) {
  const WebAssetSet& set = FixtureWebAssets();
  ASSERT_EQ(set.count, 4u);
  const WebAsset* js = set.Find("assets/index-AbCd1234.js");
  ASSERT_NE(js, nullptr);
  EXPECT_EQ(js->data, "document.getElementById(\"app\").textContent = \"fixture\";\n");
  EXPECT_EQ(set.Find("index.html") != nullptr, true);
  EXPECT_EQ(set.Find("missing.js"), nullptr);
}

TEST(StaticAssets, HashedName_OnlyViteStyleContentHashes) {
  EXPECT_TRUE(IsHashedName("assets/index-AbCd1234.js"));
  EXPECT_TRUE(IsHashedName("assets/index-Zz9_xY-8.css"));
  EXPECT_FALSE(IsHashedName("assets/logo.svg"));
  EXPECT_FALSE(IsHashedName("assets/index-abc.js"));
  EXPECT_FALSE(IsHashedName("assets/indexAbCd1234.js"));
  EXPECT_FALSE(IsHashedName("index.html"));
}

TEST(StaticAssets, EmptySet_Index503NotBuilt) {
  const WebAssetSet empty{nullptr, 0};
  const HttpResponse r = ServeWebAsset(empty, "/");
  EXPECT_EQ(r.status, 503);
  EXPECT_NE(r.body.find("dashboard not built"), std::string::npos) << r.body;
  EXPECT_EQ(ServeWebAsset(empty, "/assets/index-AbCd1234.js").status, 404);
}

class StaticAssetsServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // A gRPC server with no services: the dashboard routes never reach it.
    grpc::ServerBuilder builder;
    builder.RegisterCallbackGenericService(&generic_);  // answers UNIMPLEMENTED
    grpc_ = builder.BuildAndStart();
    ASSERT_NE(grpc_, nullptr);
    RestOptions o;
    o.listen_address = "127.0.0.1";
    o.port = 0;
    o.channel = grpc_->InProcessChannel(grpc::ChannelArguments());
    o.web_assets = &FixtureWebAssets();
    auto server = RestServer::Start(std::move(o));
    ASSERT_TRUE(server.ok()) << server.status();
    rest_ = std::move(*server);
  }
  void TearDown() override {
    rest_.reset();
    grpc_->Shutdown();
  }
  RawResponse Get(const std::string& target) {
    HttpClient client(rest_->port());
    EXPECT_TRUE(client.connected());
    EXPECT_TRUE(client.SendRequest("GET", target));
    auto r = client.Read();
    EXPECT_TRUE(r.has_value()) << target;
    return r.value_or(RawResponse{});
  }
  grpc::CallbackGenericService generic_;
  std::unique_ptr<grpc::Server> grpc_;
  std::unique_ptr<RestServer> rest_;
};

TEST_F(StaticAssetsServerTest, Root_IndexHtmlNoCache) {
  const RawResponse r = Get("/");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(r.header("cache-control"), "no-cache");
  EXPECT_NE(r.body.find("fixture dashboard"), std::string::npos) << r.body;
  EXPECT_EQ(Get("/index.html").body, r.body);
}

TEST_F(StaticAssetsServerTest, HashedAssets_ContentTypeAndImmutable) {
  const RawResponse js = Get("/assets/index-AbCd1234.js");
  EXPECT_EQ(js.status, 200);
  EXPECT_EQ(js.header("content-type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(js.header("cache-control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(js.header("x-content-type-options"), "nosniff");
  const RawResponse css = Get("/assets/index-Zz9_xY-8.css");
  EXPECT_EQ(css.status, 200);
  EXPECT_EQ(css.header("content-type"), "text/css; charset=utf-8");
  EXPECT_EQ(css.body, "body { font-family: sans-serif; }\n");
  const RawResponse svg = Get("/assets/logo.svg");
  EXPECT_EQ(svg.status, 200);
  EXPECT_EQ(svg.header("content-type"), "image/svg+xml");
  EXPECT_EQ(svg.header("cache-control"), "no-cache");  // not hashed: may change in place
}

TEST_F(StaticAssetsServerTest, Unknown_404) {
  EXPECT_EQ(Get("/assets/missing-12345678.js").status, 404);
  EXPECT_EQ(Get("/fleet").status, 404);
  EXPECT_EQ(Get("/assets/").status, 404);
  EXPECT_EQ(Get("/nested/assets/index-AbCd1234.js").status, 404);
  EXPECT_EQ(Get("/v1/nothing").status, 404);
  EXPECT_EQ(Get("/%2e%2e/etc/passwd").status, 404);
}

}  // namespace
}  // namespace drivegw::rest
