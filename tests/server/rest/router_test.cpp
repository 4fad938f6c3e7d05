// Router unit tests: HttpRule routes, request building, status mapping, streaming, fixed routes
// and static files, against the fake DriveService over the gRPC server's in-process channel.
#include "server/rest/router.h"

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>

#include "tests/server/rest/fake_drive_service.h"
#include "tests/server/rest/recording_sink.h"

namespace drivegw::rest {
namespace {

using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Pair;
using json = nlohmann::json;
using namespace std::chrono_literals;

using test_support::RecordingSink;

class RouterTest : public ::testing::Test {
 protected:
  void SetUp() override { router_ = MakeRouter(); }

  std::unique_ptr<Router> MakeRouter(std::string static_dir = {}) {
    RouterOptions o;
    o.channel = grpc_.InProcessChannel();
    o.openapi_json = R"({"swagger":"2.0"})";
    o.static_dir = std::move(static_dir);
    auto r = Router::Create(std::move(o));
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *std::move(r) : nullptr;
  }

  HttpResponse Call(std::string method, std::string target, std::string body = {},
                    Router* router = nullptr) {
    auto sink = std::make_shared<RecordingSink>();
    (router ? router : router_.get())
        ->Handle({std::move(method), std::move(target), std::move(body), "10.0.0.7:5555"}, sink);
    return sink->Response();
  }

  static json Json(const HttpResponse& r) {
    auto j = json::parse(r.body, nullptr, /*allow_exceptions=*/false);
    EXPECT_FALSE(j.is_discarded()) << r.body;
    return j;
  }

  test_support::FakeGrpcServer grpc_;
  std::unique_ptr<Router> router_;
};

TEST_F(RouterTest, Create_EveryAnnotatedMethod_OneRoute) {
  std::vector<std::string> routes;
  for (const auto& r : router_->routes()) routes.push_back(r.http_method + " " + r.path.text());
  EXPECT_EQ(routes.size(), 16u);
  EXPECT_THAT(routes, Contains("POST /v1/drives:moveCoordinated"));
  EXPECT_THAT(routes, Contains("GET /v1/drives"));
  EXPECT_THAT(routes, Contains("GET /v1/drives:watch"));
  EXPECT_THAT(routes, Contains("POST /v1/{name=drives/*}:moveAbsolute"));
  EXPECT_THAT(routes, Contains("GET /v1/{name=drives/*/commands/*}"));
  EXPECT_THAT(routes, Contains("POST /v1/{name=drives/*}/parameters/{parameter_id}:write"));
  for (const auto& r : router_->routes()) {
    EXPECT_EQ(r.server_streaming, r.grpc_path == "/drivegw.v1.DriveService/WatchDrives");
  }
}

TEST_F(RouterTest, Create_NoChannel_InvalidArgument) {
  auto r = Router::Create(RouterOptions{});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(RouterTest, Create_UnknownService_InvalidArgument) {
  RouterOptions o;
  o.channel = grpc_.InProcessChannel();
  o.service = "drivegw.v1.NoSuchService";
  auto r = Router::Create(std::move(o));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("drivegw.v1.NoSuchService"));
}

TEST_F(RouterTest, ListDrives_Ok_JsonWithSnakeCaseAndDefaults) {
  const auto r = Call("GET", "/v1/drives");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "application/json");
  const auto j = Json(r);
  ASSERT_EQ(j["drives"].size(), 2u);
  EXPECT_EQ(j["drives"][0]["name"], "drives/x1");
  EXPECT_EQ(j["drives"][0]["axis"]["max_mm"], 100);  // preserve_proto_field_names
  EXPECT_EQ(j["drives"][0]["axis"]["min_mm"], 0);    // always_print_primitive_fields
  EXPECT_EQ(j["drives"][0]["endpoint"], "");
}

TEST_F(RouterTest, AnyCall_ForwardsPeerAndTransportAsMetadata) {
  ASSERT_EQ(Call("GET", "/v1/drives").status, 200);
  const auto seen = grpc_.service().seen();
  EXPECT_EQ(seen.source, "10.0.0.7:5555");
  EXPECT_EQ(seen.transport, "rest");
}

TEST_F(RouterTest, GetDrive_PathBinding_SetsName) {
  const auto r = Call("GET", "/v1/drives/x1");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["name"], "drives/x1");
  EXPECT_EQ(j["status"]["sequence"], "7");  // uint64 is a JSON string
  EXPECT_EQ(j["status"]["state"], "ENABLED");
}

TEST_F(RouterTest, GetDrive_PercentEncodedPath_Decoded) {
  const auto r = Call("GET", "/v1/drives/x%32");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(Json(r)["name"], "drives/x2");
}

TEST_F(RouterTest, GetDrive_Unknown_404WithGrpcStatusBody) {
  const auto r = Call("GET", "/v1/drives/zz");
  EXPECT_EQ(r.status, 404);
  const auto j = Json(r);
  EXPECT_EQ(j["code"], 5);
  EXPECT_EQ(j["message"], "drive 'drives/zz' not found");
}

TEST_F(RouterTest, MoveAbsolute_BodyAndPath_Merged) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute",
                      R"({"position_mm": 50, "velocityMmS": 500, "name": "drives/ignored"})");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["name"], "drives/x1/commands/1");
  EXPECT_EQ(j["state"], "BUSY");
  const auto seen = grpc_.service().seen();
  EXPECT_EQ(seen.move.name(), "drives/x1");  // the path wins over the body
  EXPECT_EQ(seen.move.position_mm(), 50);
  EXPECT_EQ(seen.move.velocity_mm_s(), 500);
}

TEST_F(RouterTest, MoveAbsolute_ServerBadRequest_400WithDetails) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute", R"({"velocity_mm_s": 5000})");
  EXPECT_EQ(r.status, 400);
  const auto j = Json(r);
  EXPECT_EQ(j["code"], 3);
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("exceeds axis limit 1000"));
  ASSERT_EQ(j["details"].size(), 1u);
  EXPECT_EQ(j["details"][0]["@type"], "type.googleapis.com/google.rpc.BadRequest");
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "move_absolute.velocity_mm_s");
}

TEST_F(RouterTest, MoveAbsolute_WrongJsonType_400NamesField) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute", R"({"position_mm": "far"})");
  EXPECT_EQ(r.status, 400);
  const auto j = Json(r);
  EXPECT_EQ(j["code"], 3);
  EXPECT_EQ(j["message"], "body field position_mm: invalid value \"far\" for type TYPE_DOUBLE");
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "position_mm");
}

TEST_F(RouterTest, MoveAbsolute_UnknownJsonField_400NamesField) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute", R"({"speed": 1})");
  EXPECT_EQ(r.status, 400);
  const auto j = Json(r);
  EXPECT_EQ(j["message"], "body field speed: no such field");
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "speed");
}

TEST_F(RouterTest, MoveAbsolute_MalformedJson_400) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute", R"({"position_mm": )");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("body"));
}

TEST_F(RouterTest, PostWithEmptyBody_TreatedAsEmptyMessage) {
  // Disable is not implemented by the fake: the call gets through and maps to 501.
  const auto r = Call("POST", "/v1/drives/x1:disable", "");
  EXPECT_EQ(r.status, 501);
  EXPECT_EQ(Json(r)["code"], 12);
}

TEST_F(RouterTest, UnknownPath_404NamesPath) {
  const auto r = Call("GET", "/v1/nope?x=1");
  EXPECT_EQ(r.status, 404);
  const auto j = Json(r);
  EXPECT_EQ(j["code"], 5);
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("GET /v1/nope"));
}

TEST_F(RouterTest, KnownPathOtherMethod_405WithAllow) {
  auto r = Call("DELETE", "/v1/drives");
  EXPECT_EQ(r.status, 405);
  EXPECT_THAT(r.headers, Contains(Pair("Allow", "GET")));
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("/v1/drives"));
  // A verb route outranks the bare resource template.
  r = Call("GET", "/v1/drives/x1:moveAbsolute");
  EXPECT_EQ(r.status, 405);
  EXPECT_THAT(r.headers, Contains(Pair("Allow", "POST")));
}

TEST_F(RouterTest, ReadParameter_PathUint32AndQueryBool_Parsed) {
  const auto r = Call("GET", "/v1/drives/x1/parameters/4660?rom=true");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["name"], "drives/x1");
  EXPECT_EQ(j["parameter_id"], 4660);
  EXPECT_EQ(j["rom"], true);
  EXPECT_EQ(j["value"], "-42");  // int64 is a JSON string
}

TEST_F(RouterTest, ReadParameter_BadPathNumber_400NamesField) {
  for (const char* id : {"abc", "-1", "4294967296"}) {
    const auto r = Call("GET", std::string("/v1/drives/x1/parameters/") + id);
    EXPECT_EQ(r.status, 400) << id;
    const auto j = Json(r);
    EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("parameter_id")) << id;
    EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("uint32")) << id;
    EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "parameter_id");
  }
}

TEST_F(RouterTest, Query_BadBool_400NamesField) {
  const auto r = Call("GET", "/v1/drives/x1/parameters/1?rom=maybe");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("rom"));
}

TEST_F(RouterTest, Query_UnknownParameter_400NamesIt) {
  const auto r = Call("GET", "/v1/drives?bogus=1");
  EXPECT_EQ(r.status, 400);
  const auto j = Json(r);
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("bogus"));
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "bogus");
}

// Found by rest_body_fuzz (decision 1403): a parameter name that is not UTF-8 made the error
// body invalid JSON (MessageToJsonString refused it, the fallback wrote C escapes). The bytes
// are now quoted as \xNN and the answer stays a parseable google.rpc.Status.
TEST_F(RouterTest, Query_NonUtf8ParameterName_400ValidJsonNamingTheBytes) {
  const auto r = Call("GET", "/v1/drives?b%FFgus%C0%AF=1");
  EXPECT_EQ(r.status, 400);
  ASSERT_TRUE(json::accept(r.body)) << r.body;
  const auto j = Json(r);
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("b\\xffgus\\xc0\\xaf"));
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "b\\xffgus\\xc0\\xaf");
}

TEST(ValidUtf8, KeepsUtf8QuotesEveryOtherByte) {
  EXPECT_EQ(ValidUtf8("drive \xE2\x82\xAC x1"), "drive \xE2\x82\xAC x1");  // U+20AC kept
  EXPECT_EQ(ValidUtf8("\xF0\x9F\x98\x80"), "\xF0\x9F\x98\x80");            // U+1F600 kept
  EXPECT_EQ(ValidUtf8("a\xFF"
                      "b"),
            "a\\xffb");
  EXPECT_EQ(ValidUtf8("\xC0\xAF"), "\\xc0\\xaf");                    // overlong '/'
  EXPECT_EQ(ValidUtf8("\xED\xA0\x80"), "\\xed\\xa0\\x80");           // surrogate D800
  EXPECT_EQ(ValidUtf8("\xE2\x82"), "\\xe2\\x82");                    // truncated sequence
  EXPECT_EQ(ValidUtf8("\xF4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // above U+10FFFF
}

TEST_F(RouterTest, Query_FieldBoundByPath_400) {
  const auto r = Call("GET", "/v1/drives/x1?name=drives/x2");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("bound by the path"));
}

TEST_F(RouterTest, Query_OnBodyStarRoute_400) {
  const auto r = Call("POST", "/v1/drives/x1:moveAbsolute?position_mm=3", "{}");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("position_mm"));
}

TEST_F(RouterTest, WriteParameter_PathAndBody_Int64FromJsonString) {
  const auto r = Call("POST", "/v1/drives/x1/parameters/17:write", R"({"value": "-9000000000"})");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto seen = grpc_.service().seen();
  EXPECT_EQ(seen.write.name(), "drives/x1");
  EXPECT_EQ(seen.write.parameter_id(), 17u);
  EXPECT_EQ(seen.write.value(), -9000000000LL);
}

TEST_F(RouterTest, Watch_RepeatedQueryAndDouble_StreamsNdjsonThenEnds) {
  auto sink = std::make_shared<RecordingSink>();
  router_->Handle({"GET", "/v1/drives:watch?names=x1&names=x%32&max_rate_hz=10.5", "", "p"}, sink);
  const auto end = sink->End();
  EXPECT_EQ(end.status, 200);
  EXPECT_FALSE(sink->has_response());
  const auto lines = sink->lines();
  ASSERT_EQ(lines.size(), 6u);
  for (size_t i = 0; i < lines.size(); ++i) {
    ASSERT_EQ(lines[i].back(), '\n');
    EXPECT_EQ(lines[i].find('\n'), lines[i].size() - 1);  // one line per message
    const auto j = json::parse(lines[i]);
    EXPECT_EQ(j["sequence"], std::to_string(i));
    EXPECT_EQ(j["name"], i % 2 == 0 ? "drives/x1" : "drives/x2");
  }
  const auto seen = grpc_.service().seen();
  EXPECT_THAT(seen.watch.names(), ElementsAre("x1", "x2"));
  EXPECT_EQ(seen.watch.max_rate_hz(), 10.5);
}

TEST_F(RouterTest, Watch_FlowControl_NothingReadWithoutRequestNext) {
  auto sink = std::make_shared<RecordingSink>(/*auto_next=*/false);
  router_->Handle({"GET", "/v1/drives:watch?names=forever", "", "p"}, sink);
  auto stream = sink->stream();
  ASSERT_NE(stream, nullptr);
  stream->RequestNext();
  ASSERT_TRUE(sink->WaitLines(1));
  stream->RequestNext();
  ASSERT_TRUE(sink->WaitLines(2));
  EXPECT_EQ(sink->lines().size(), 2u);
  stream->Cancel();
  EXPECT_NE(sink->End().status, 200);
  EXPECT_EQ(sink->lines().size(), 2u);
  EXPECT_TRUE(grpc_.service().WaitFor([](const auto& s) { return s.watch_cancelled == 1; }));
}

TEST_F(RouterTest, Watch_ErrorBeforeFirstMessage_EndCarriesStatus) {
  auto sink = std::make_shared<RecordingSink>();
  router_->Handle({"GET", "/v1/drives:watch?names=missing", "", "p"}, sink);
  const auto end = sink->End();
  EXPECT_EQ(end.status, 404);
  EXPECT_EQ(Json(end)["message"], "drive 'missing' not found");
  EXPECT_TRUE(sink->lines().empty());
}

TEST_F(RouterTest, Watch_BadQuery_WholeErrorResponse) {
  const auto r = Call("GET", "/v1/drives:watch?max_rate_hz=fast");
  EXPECT_EQ(r.status, 400);
  EXPECT_THAT(Json(r)["message"].get<std::string>(), HasSubstr("max_rate_hz"));
}

TEST_F(RouterTest, CancelAll_EndsStreamsAndHangingCalls_ThenRefuses) {
  auto watch = std::make_shared<RecordingSink>();
  router_->Handle({"GET", "/v1/drives:watch?names=forever", "", "p"}, watch);
  ASSERT_TRUE(watch->WaitLines(3));
  auto home = std::make_shared<RecordingSink>();
  router_->Handle({"POST", "/v1/drives/x1:home", "", "p"}, home);
  ASSERT_TRUE(grpc_.service().WaitFor([](const auto& s) { return s.method == "Home"; }));
  router_->CancelAll();
  EXPECT_TRUE(router_->WaitIdle(5s));
  EXPECT_NE(watch->End().status, 200);
  EXPECT_EQ(home->Response().status, 500);  // CANCELLED
  EXPECT_EQ(Call("GET", "/v1/drives").status, 503);
}

TEST_F(RouterTest, OpenApi_ServedAsGiven) {
  auto r = Call("GET", "/openapi.json");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, R"({"swagger":"2.0"})");
  r = Call("POST", "/openapi.json");
  EXPECT_EQ(r.status, 405);
}

TEST_F(RouterTest, Healthz_ServingServer_Ok) {
  const auto r = Call("GET", "/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "ok\n");
}

TEST_F(RouterTest, Healthz_ChannelToNoServer_503) {
  // Not the in-process channel of a shut-down server: gRPC 1.51 crashes creating a call on
  // one (docs/decisions/501-rest-transcoding.md), so RestServer stops before the gRPC server.
  RouterOptions o;
  o.channel = grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials());
  o.health_timeout = 500ms;
  auto router = Router::Create(std::move(o));
  ASSERT_TRUE(router.ok());
  const auto r = Call("GET", "/healthz", "", router->get());
  EXPECT_EQ(r.status, 503);
  EXPECT_THAT(r.body, HasSubstr("not connected"));
}

TEST_F(RouterTest, Static_NoDirectory_404) {
  EXPECT_EQ(Call("GET", "/").status, 404);
  EXPECT_EQ(Call("GET", "/index.html").status, 404);
}

class RouterStaticTest : public RouterTest {
 protected:
  void SetUp() override {
    dir_ =
        std::filesystem::temp_directory_path() / ("dgw_rest_static_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_ / "js");
    std::ofstream(dir_ / "index.html") << "<h1>drivegw</h1>";
    std::ofstream(dir_ / "js" / "app.js") << "let x = 1;";
    std::ofstream(dir_.parent_path() / "dgw_secret.txt") << "secret";
    router_ = MakeRouter(dir_.string());
  }
  void TearDown() override {
    std::filesystem::remove_all(dir_);
    std::filesystem::remove(dir_.parent_path() / "dgw_secret.txt");
  }
  std::filesystem::path dir_;
};

TEST_F(RouterStaticTest, Files_ServedWithContentType) {
  auto r = Call("GET", "/");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "<h1>drivegw</h1>");
  EXPECT_EQ(r.content_type, "text/html; charset=utf-8");
  r = Call("GET", "/js/app.js");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "let x = 1;");
  EXPECT_EQ(r.content_type, "text/javascript; charset=utf-8");
  EXPECT_EQ(Call("GET", "/js/").status, 404);  // no index.html there
  EXPECT_EQ(Call("GET", "/missing.css").status, 404);
  EXPECT_EQ(Call("POST", "/index.html").status, 404);
}

TEST_F(RouterStaticTest, Traversal_Rejected) {
  for (const char* target :
       {"/../dgw_secret.txt", "/js/../../dgw_secret.txt", "/%2e%2e/dgw_secret.txt",
        "/js%2f..%2f..%2fdgw_secret.txt", "//etc/passwd", "/%2Fetc/passwd"}) {
    const auto r = Call("GET", target);
    EXPECT_EQ(r.status, 400) << target;
    EXPECT_EQ(r.body.find("secret\""), std::string::npos);
  }
}

TEST_F(RouterStaticTest, ApiRoutes_StillWin) { EXPECT_EQ(Call("GET", "/v1/drives").status, 200); }

TEST(ErrorResponse, FieldGiven_BadRequestDetail) {
  const auto r = ErrorResponse(400, 3, "x: bad", "x", "bad");
  EXPECT_EQ(r.status, 400);
  const auto j = json::parse(r.body);
  EXPECT_EQ(j["code"], 3);
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "x");
  EXPECT_EQ(j["details"][0]["field_violations"][0]["description"], "bad");
}

TEST(HttpStatusForGrpcCode, Table) {
  const std::pair<grpc::StatusCode, int> table[] = {
      {grpc::StatusCode::OK, 200},
      {grpc::StatusCode::CANCELLED, 500},
      {grpc::StatusCode::UNKNOWN, 500},
      {grpc::StatusCode::INVALID_ARGUMENT, 400},
      {grpc::StatusCode::DEADLINE_EXCEEDED, 504},
      {grpc::StatusCode::NOT_FOUND, 404},
      {grpc::StatusCode::ALREADY_EXISTS, 409},
      {grpc::StatusCode::PERMISSION_DENIED, 403},
      {grpc::StatusCode::RESOURCE_EXHAUSTED, 429},
      {grpc::StatusCode::FAILED_PRECONDITION, 400},
      {grpc::StatusCode::ABORTED, 409},
      {grpc::StatusCode::OUT_OF_RANGE, 400},
      {grpc::StatusCode::UNIMPLEMENTED, 501},
      {grpc::StatusCode::INTERNAL, 500},
      {grpc::StatusCode::UNAVAILABLE, 503},
      {grpc::StatusCode::DATA_LOSS, 500},
      {grpc::StatusCode::UNAUTHENTICATED, 401},
  };
  for (const auto& [code, http] : table) {
    EXPECT_EQ(HttpStatusForGrpcCode(static_cast<int>(code)), http) << code;
  }
}

}  // namespace
}  // namespace drivegw::rest
