// Router tests for the HttpRule forms drive.proto does not use (additional_bindings, custom
// verbs, a body field, response_body, "**", nested/enum/repeated/bytes query fields), against a
// generic echo server: each answer is the request the router built.
#include <gmock/gmock.h>
#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "rest_test.pb.h"  // generated into this test's build directory
#include "server/rest/router.h"
#include "tests/server/rest/recording_sink.h"

namespace drivegw::rest {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Pair;
using json = nlohmann::json;
using test_support::RecordingSink;

// Answers every method with its request bytes (and records the method name).
class EchoService final : public grpc::CallbackGenericService {
 public:
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext* ctx) override {
    {
      std::lock_guard lock(mu_);
      last_method_ = ctx->method();
    }
    class Reactor final : public grpc::ServerGenericBidiReactor {
     public:
      Reactor() { StartRead(&buffer_); }
      void OnReadDone(bool ok) override {
        if (ok) {
          StartWriteAndFinish(&buffer_, grpc::WriteOptions(), grpc::Status::OK);
        } else {
          Finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "no request"));
        }
      }
      void OnDone() override { delete this; }

     private:
      grpc::ByteBuffer buffer_;
    };
    return new Reactor;
  }
  std::string last_method() {
    std::lock_guard lock(mu_);
    return last_method_;
  }

 private:
  std::mutex mu_;
  std::string last_method_;
};

class RouterBindingsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    builder.RegisterCallbackGenericService(&echo_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    (void)drivegw::resttest::Echo::descriptor();  // links and registers rest_test.proto
    RouterOptions o;
    o.channel = server_->InProcessChannel(grpc::ChannelArguments());
    o.service = "drivegw.resttest.TestService";
    auto r = Router::Create(std::move(o));
    ASSERT_TRUE(r.ok()) << r.status();
    router_ = *std::move(r);
  }
  void TearDown() override {
    router_.reset();  // before the server: see docs/decisions/501-rest-transcoding.md item 9
    server_->Shutdown();
  }

  HttpResponse Call(std::string method, std::string target, std::string body = {}) {
    auto sink = std::make_shared<RecordingSink>();
    router_->Handle({std::move(method), std::move(target), std::move(body), "peer"}, sink);
    return sink->Response();
  }
  json Echoed(std::string method, std::string target, std::string body = {}) {
    const auto r = Call(std::move(method), std::move(target), std::move(body));
    EXPECT_EQ(r.status, 200) << r.body;
    auto j = json::parse(r.body, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << r.body;
    return j;
  }

  EchoService echo_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<Router> router_;
};

TEST_F(RouterBindingsTest, Create_AdditionalBindingsAndCustom_AllRouted) {
  std::vector<std::string> routes;
  for (const auto& r : router_->routes()) routes.push_back(r.http_method + " " + r.path.text());
  EXPECT_THAT(routes, Contains("GET /t/{name=things/*}"));
  EXPECT_THAT(routes, Contains("GET /t/by-label/{inner.label}"));
  EXPECT_THAT(routes, Contains("PURGE /t/{name=things/*}"));
  EXPECT_EQ(routes.size(), 7u);
}

TEST_F(RouterBindingsTest, AdditionalBinding_NestedPathField) {
  const auto j = Echoed("GET", "/t/by-label/blue%20one");
  EXPECT_EQ(j["inner"]["label"], "blue one");
  EXPECT_EQ(echo_.last_method(), "/drivegw.resttest.TestService/Get");
}

TEST_F(RouterBindingsTest, Query_NestedEnumRepeatedBytesFloat) {
  const auto j =
      Echoed("GET",
             "/t/things/a?inner.count=-7&color=GREEN&ids=1&ids=-2"
             "&ids=9000000000&flag=1&ratio=2.5e-3&blob=aGk%3D&gain=1.5&big=18446744073709551615");
  EXPECT_EQ(j["name"], "things/a");
  EXPECT_EQ(j["inner"]["count"], -7);
  EXPECT_EQ(j["color"], "GREEN");
  EXPECT_EQ(j["ids"], json::array({"1", "-2", "9000000000"}));
  EXPECT_EQ(j["flag"], true);
  EXPECT_DOUBLE_EQ(j["ratio"].get<double>(), 2.5e-3);
  EXPECT_EQ(j["blob"], "aGk=");  // bytes: base64 in, base64 out
  EXPECT_EQ(j["gain"], 1.5);
  EXPECT_EQ(j["big"], "18446744073709551615");
}

TEST_F(RouterBindingsTest, Query_JsonNameOfTopLevelField_Accepted) {
  // "innerLabel" above is no field (JSON names are per message); this one is.
  const auto r = Call("GET", "/t/things/a?innerLabel=x");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(r.body, HasSubstr("innerLabel"));
  const auto j = Echoed("GET", "/t/things/a?inner.label=x&color=1");
  EXPECT_EQ(j["inner"]["label"], "x");
  EXPECT_EQ(j["color"], "RED");  // enum by number
}

TEST_F(RouterBindingsTest, Query_BadEnumAndBytesAndOverflow_400) {
  EXPECT_EQ(Call("GET", "/t/things/a?color=BLUE").status, 400);
  EXPECT_EQ(Call("GET", "/t/things/a?color=7").status, 400);
  EXPECT_EQ(Call("GET", "/t/things/a?blob=%%%").status, 400);
  EXPECT_EQ(Call("GET", "/t/things/a?blob=!!").status, 400);
  EXPECT_EQ(Call("GET", "/t/things/a?ids=99999999999999999999").status, 400);
  EXPECT_EQ(Call("GET", "/t/things/a?inner=x").status, 400);  // a message, not a scalar
  EXPECT_EQ(Call("GET", "/t/things/a?flag=1&flag=0").status, 400);
}

TEST_F(RouterBindingsTest, BodyField_ParsedIntoThatField) {
  const auto j = Echoed("PUT", "/t/things/b/inner", R"({"label": "x", "count": 3})");
  EXPECT_EQ(j["name"], "things/b");
  EXPECT_EQ(j["inner"]["label"], "x");
  EXPECT_EQ(j["inner"]["count"], 3);
}

TEST_F(RouterBindingsTest, BodyField_BadValue_400NamesNestedField) {
  const auto r = Call("PUT", "/t/things/b/inner", R"({"count": "many"})");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(r.body, HasSubstr("inner.count"));
}

TEST_F(RouterBindingsTest, BodyField_QueryForOtherFieldsAllowed_ButNotInsideBody) {
  auto j = Echoed("PUT", "/t/things/b/inner?color=RED", R"({"label": "x"})");
  EXPECT_EQ(j["color"], "RED");
  const auto r = Call("PUT", "/t/things/b/inner?inner.count=2", R"({"label": "x"})");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(r.body, HasSubstr("JSON body"));
}

TEST_F(RouterBindingsTest, ResponseBody_OnlyThatFieldReturned) {
  const auto j = Echoed("GET", "/t/things/c/inner?inner.label=only");
  EXPECT_EQ(j, json({{"label", "only"}, {"count", 0}}));
}

TEST_F(RouterBindingsTest, CustomVerbAndDelete_Routed) {
  EXPECT_EQ(Echoed("PURGE", "/t/things/d")["name"], "things/d");
  EXPECT_EQ(echo_.last_method(), "/drivegw.resttest.TestService/Purge");
  EXPECT_EQ(Echoed("DELETE", "/t/things/d")["name"], "things/d");
  EXPECT_EQ(echo_.last_method(), "/drivegw.resttest.TestService/Delete");
  const auto r = Call("POST", "/t/things/d");
  EXPECT_EQ(r.status, 405);
  EXPECT_THAT(r.headers, Contains(Pair("Allow", "DELETE, GET, PURGE")));
}

TEST_F(RouterBindingsTest, DoubleWildcard_KeepsEncodedSlash) {
  EXPECT_EQ(Echoed("GET", "/t/files/a/b%2Fc/d.txt")["path"], "a/b%2Fc/d.txt");
  EXPECT_EQ(Echoed("GET", "/t/files")["path"], "");
}

}  // namespace
}  // namespace drivegw::rest
