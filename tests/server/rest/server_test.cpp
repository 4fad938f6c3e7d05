// End-to-end REST tests over real TCP: RestServer in front of the fake DriveService, driven by
// a raw POSIX socket client (keep-alive, pipelining, chunked NDJSON, limits, timeouts, Stop).
#include "server/rest/server.h"

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "tests/server/rest/fake_drive_service.h"
#include "tests/server/rest/http_client.h"

namespace drivegw::rest {
namespace {

using ::testing::HasSubstr;
using json = nlohmann::json;
using test_support::HttpClient;
using namespace std::chrono_literals;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class RestServerTest : public ::testing::Test {
 protected:
  void SetUp() override { Start(); }

  void Start(size_t body_limit = 1 << 20, std::chrono::seconds read_timeout = 30s) {
    RestOptions o;
    o.listen_address = "127.0.0.1";
    o.port = 0;
    o.channel = grpc_.InProcessChannel();
    o.openapi_json = ReadFile(DGW_OPENAPI_JSON);
    o.body_limit = body_limit;
    o.read_timeout = read_timeout;
    server_.reset();
    auto s = RestServer::Start(std::move(o));
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
  }

  // One request on a fresh connection.
  test_support::RawResponse Fetch(std::string_view method, std::string_view target,
                                  std::string_view body = {}) {
    HttpClient c(server_->port());
    EXPECT_TRUE(c.connected());
    EXPECT_TRUE(c.SendRequest(method, target, body));
    auto r = c.Read();
    EXPECT_TRUE(r.has_value()) << method << " " << target;
    return r.value_or(test_support::RawResponse{});
  }

  test_support::FakeGrpcServer grpc_;
  std::unique_ptr<RestServer> server_;
};

TEST_F(RestServerTest, Start_PortZero_EphemeralPortReadBack) { EXPECT_NE(server_->port(), 0); }

TEST_F(RestServerTest, Start_BadAddressOrMissingChannel_InvalidArgument) {
  RestOptions o;
  o.listen_address = "not-an-ip";
  o.port = 0;
  o.channel = grpc_.InProcessChannel();
  EXPECT_EQ(RestServer::Start(o).status().code(), absl::StatusCode::kInvalidArgument);
  o.listen_address = "127.0.0.1";
  o.channel = nullptr;
  EXPECT_EQ(RestServer::Start(o).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(RestServerTest, Start_PortInUse_Unavailable) {
  RestOptions o;
  o.listen_address = "127.0.0.1";
  o.port = server_->port();
  o.channel = grpc_.InProcessChannel();
  const auto s = RestServer::Start(o);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr(std::to_string(server_->port())));
}

TEST_F(RestServerTest, Get_ListDrives_JsonOverKeepAlive) {
  HttpClient c(server_->port());
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(c.SendRequest("GET", "/v1/drives"));
    auto r = c.Read();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200);
    EXPECT_EQ(r->header("content-type"), "application/json");
    EXPECT_EQ(json::parse(r->body)["drives"].size(), 2u);
  }
}

TEST_F(RestServerTest, Pipelined_ThreeRequests_AnsweredInOrder) {
  HttpClient c(server_->port());
  ASSERT_TRUE(
      c.Send("GET /v1/drives/x1 HTTP/1.1\r\nHost: a\r\n\r\n"
             "GET /v1/nope HTTP/1.1\r\nHost: a\r\n\r\n"
             "POST /v1/drives/x2:moveAbsolute HTTP/1.1\r\nHost: a\r\nContent-Length: 19\r\n\r\n"
             "{\"position_mm\": 12}"));
  auto r1 = c.Read();
  auto r2 = c.Read();
  auto r3 = c.Read();
  ASSERT_TRUE(r1 && r2 && r3);
  EXPECT_EQ(r1->status, 200);
  EXPECT_EQ(json::parse(r1->body)["name"], "drives/x1");
  EXPECT_EQ(r2->status, 404);
  EXPECT_EQ(r3->status, 200);
  EXPECT_EQ(json::parse(r3->body)["name"], "drives/x2/commands/1");
}

// The session writes every whole response's head into one buffer it reuses (decision 1365): a
// longer head (405 with Allow) followed by shorter ones on the same connection, pipelined and
// one by one, must give each response its own head and body, nothing of the one before.
TEST_F(RestServerTest, KeepAlive_LongerHeadThenShorterOnes_NoBytesOfThePreviousResponse) {
  HttpClient c(server_->port());
  ASSERT_TRUE(
      c.Send(std::string("PUT /v1/drives HTTP/1.1\r\nHost: a\r\nContent-Length: 0\r\n\r\n") +
             "GET /v1/nope HTTP/1.1\r\nHost: a\r\n\r\n"));
  auto r1 = c.Read();
  auto r2 = c.Read();
  ASSERT_TRUE(r1 && r2);
  EXPECT_EQ(r1->status, 405);
  EXPECT_EQ(r1->header("allow"), "GET");
  EXPECT_EQ(r2->status, 404);
  EXPECT_EQ(r2->header("allow"), "");
  EXPECT_EQ(r2->headers.size(), 3u);  // server, content-type, content-length
  EXPECT_EQ(r2->header("server"), "drivegw");
  EXPECT_EQ(r2->header("content-type"), "application/json");
  EXPECT_EQ(json::parse(r2->body)["message"], "no route or file for GET /v1/nope");
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(c.SendRequest("GET", "/v1/drives/x1"));
    auto r = c.Read();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200);
    EXPECT_EQ(r->headers.size(), 3u);
    EXPECT_EQ(json::parse(r->body)["name"], "drives/x1");
  }
  ASSERT_TRUE(c.SendRequest("GET", "/v1/nope2"));
  auto r3 = c.Read();
  ASSERT_TRUE(r3);
  EXPECT_EQ(r3->status, 404);
  EXPECT_EQ(json::parse(r3->body)["message"], "no route or file for GET /v1/nope2");
}

TEST_F(RestServerTest, Post_MoveAbsolute_ClientAddressReachesService) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.SendRequest("POST", "/v1/drives/x1:moveAbsolute",
                            R"({"position_mm": 50, "velocity_mm_s": 500})"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  const auto seen = grpc_.service().seen();
  EXPECT_EQ(seen.source, "127.0.0.1:" + std::to_string(c.local_port()));
  EXPECT_EQ(seen.transport, "rest");
  EXPECT_EQ(seen.move.position_mm(), 50);
}

TEST_F(RestServerTest, Errors_StatusesAndBodiesOverTcp) {
  auto r = Fetch("GET", "/v1/missing");
  EXPECT_EQ(r.status, 404);
  EXPECT_THAT(json::parse(r.body)["message"].get<std::string>(), HasSubstr("/v1/missing"));

  r = Fetch("PUT", "/v1/drives");
  EXPECT_EQ(r.status, 405);
  EXPECT_EQ(r.header("allow"), "GET");

  r = Fetch("POST", "/v1/drives/x1:moveAbsolute", R"({"position_mm": true})");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["details"][0]["field_violations"][0]["field"], "position_mm");

  r = Fetch("POST", "/v1/drives/x1:moveAbsolute", R"({"velocity_mm_s": 2000})");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["details"][0]["@type"],
            "type.googleapis.com/google.rpc.BadRequest");
}

TEST_F(RestServerTest, Watch_FiniteStream_ChunkedNdjsonThenKeepAlive) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives:watch?names=x1&max_rate_hz=10"));
  auto head = c.ReadHead();
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 200);
  EXPECT_EQ(head->header("transfer-encoding"), "chunked");
  EXPECT_EQ(head->header("content-type"), "application/x-ndjson");
  std::string body;
  for (;;) {
    auto chunk = c.ReadChunk();
    ASSERT_TRUE(chunk);
    if (chunk->empty()) break;
    body += *chunk;
  }
  std::istringstream lines(body);
  std::string line;
  int n = 0;
  while (std::getline(lines, line)) {
    EXPECT_EQ(json::parse(line)["sequence"], std::to_string(n++));
  }
  EXPECT_EQ(n, 3);
  // The connection is still good for the next request.
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives/x1"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

TEST_F(RestServerTest, Watch_ClientCloses_GrpcCallCancelled) {
  {
    HttpClient c(server_->port());
    ASSERT_TRUE(c.SendRequest("GET", "/v1/drives:watch?names=forever"));
    auto head = c.ReadHead();
    ASSERT_TRUE(head);
    for (int i = 0; i < 5; ++i) {
      auto chunk = c.ReadChunk();
      ASSERT_TRUE(chunk && !chunk->empty());
      EXPECT_EQ(json::parse(*chunk)["sequence"], std::to_string(i));
    }
  }  // closes the socket
  EXPECT_TRUE(grpc_.service().WaitFor(
      [](const auto& s) { return s.watch_cancelled == 1 && s.watch_active == 0; }));
  EXPECT_EQ(Fetch("GET", "/v1/drives").status, 200);
}

TEST_F(RestServerTest, Watch_ErrorBeforeFirstMessage_PlainErrorResponse) {
  auto r = Fetch("GET", "/v1/drives:watch?names=missing");
  EXPECT_EQ(r.status, 404);
  EXPECT_EQ(r.header("content-type"), "application/json");
  EXPECT_EQ(json::parse(r.body)["message"], "drive 'missing' not found");
}

TEST_F(RestServerTest, Watch_ReaderStalls_WriteTimeoutCancelsAndOthersServed) {
  Start(1 << 20, 1s);
  HttpClient slow(server_->port(), /*rcvbuf=*/4096);
  ASSERT_TRUE(slow.SendRequest("GET", "/v1/drives:watch?names=forever"));
  // Never reads: socket buffers fill, the next write misses its deadline.
  EXPECT_EQ(Fetch("GET", "/v1/drives").status, 200);
  EXPECT_TRUE(grpc_.service().WaitFor(
      [](const auto& s) { return s.watch_cancelled == 1 && s.watch_active == 0; }, 20s));
  EXPECT_EQ(Fetch("GET", "/v1/drives").status, 200);
}

TEST_F(RestServerTest, OpenApi_GeneratedDocumentServed) {
  const std::string expected = ReadFile(DGW_OPENAPI_JSON);
  ASSERT_FALSE(expected.empty());
  auto r = Fetch("GET", "/openapi.json");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, expected);
  EXPECT_TRUE(json::parse(r.body)["paths"].contains("/v1/drives"));
}

TEST_F(RestServerTest, Healthz_Ok) {
  auto r = Fetch("GET", "/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "ok\n");
}

TEST_F(RestServerTest, MalformedRequests_400OrClosed_ServerStaysUp) {
  const char* bad[] = {
      "GARBAGE\r\n\r\n",
      "GET\r\n\r\n",
      "GET /v1/drives HTTP/7.1\r\n\r\n",
      "GET /v1/drives HTTP/1.1\r\nHost a\r\n\r\n",
      "GET /v1/drives HTTP/1.1\r\nContent-Length: zz\r\n\r\n",
      "GET /v1/drives HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\nxyz\r\n",
      "\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03 tls hello\r\n\r\n",
  };
  for (const char* req : bad) {
    HttpClient c(server_->port());
    ASSERT_TRUE(c.Send(req));
    auto r = c.Read(5s);
    if (r) {
      EXPECT_EQ(r->status, 400) << req;
    }
    EXPECT_TRUE(c.WaitClosed(5s)) << req;
  }
  EXPECT_EQ(Fetch("GET", "/v1/drives").status, 200);
}

TEST_F(RestServerTest, BadTarget_400KeepsConnection) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives/%zz"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives"));
  r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

TEST_F(RestServerTest, OversizedBody_413AndServerStaysUp) {
  Start(/*body_limit=*/1024);
  const std::string big = "{\"name\":\"" + std::string(4096, 'x') + "\"}";
  {
    HttpClient c(server_->port());
    ASSERT_TRUE(c.SendRequest("POST", "/v1/drives/x1:moveAbsolute", big));
    auto r = c.Read();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 413);
    EXPECT_EQ(json::parse(r->body)["code"], 8);
    EXPECT_TRUE(c.WaitClosed());
  }
  {
    HttpClient c(server_->port());  // chunked upload over the limit
    ASSERT_TRUE(
        c.Send("POST /v1/drives/x1:moveAbsolute HTTP/1.1\r\nHost: a\r\n"
               "Transfer-Encoding: chunked\r\n\r\n1000\r\n" +
               std::string(4096, ' ') + "\r\n0\r\n\r\n"));
    auto r = c.Read();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 413);
  }
  EXPECT_EQ(Fetch("POST", "/v1/drives/x1:moveAbsolute", R"({"position_mm": 1})").status, 200);
}

TEST_F(RestServerTest, OversizedHeader_431AndClosed) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives", {}, "X-Big: " + std::string(20000, 'a') + "\r\n"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 431);
  EXPECT_TRUE(c.WaitClosed());
  EXPECT_EQ(Fetch("GET", "/v1/drives").status, 200);
}

TEST_F(RestServerTest, Watch_Http10_LinesWithoutChunkingThenClose) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.Send("GET /v1/drives:watch?names=x2 HTTP/1.0\r\n\r\n"));
  auto r = c.Read();  // delimited by the close
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->header("transfer-encoding"), "");
  std::istringstream lines(r->body);
  std::string line;
  int n = 0;
  while (std::getline(lines, line)) {
    EXPECT_EQ(json::parse(line)["name"], "drives/x2") << line;
    ++n;
  }
  EXPECT_EQ(n, 3);
}

TEST_F(RestServerTest, IdleAndSlowClients_ClosedAfterReadTimeout) {
  Start(1 << 20, 1s);
  HttpClient idle(server_->port());
  HttpClient slow(server_->port());
  ASSERT_TRUE(slow.Send("GET /v1/drives HTTP/1.1\r\nHo"));  // never finished
  HttpClient kept(server_->port());
  ASSERT_TRUE(kept.SendRequest("GET", "/v1/drives"));
  ASSERT_TRUE(kept.Read());
  EXPECT_TRUE(idle.WaitClosed(5s));
  EXPECT_TRUE(slow.WaitClosed(5s));
  EXPECT_TRUE(kept.WaitClosed(5s));  // idle after its response
  EXPECT_EQ(Fetch("GET", "/healthz").status, 200);
}

TEST_F(RestServerTest, Http10_ResponseThenClose) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.Send("GET /v1/drives HTTP/1.0\r\n\r\n"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_TRUE(c.WaitClosed());
}

TEST_F(RestServerTest, ConnectionClose_ResponseThenClose) {
  HttpClient c(server_->port());
  ASSERT_TRUE(c.SendRequest("GET", "/v1/drives", {}, "Connection: close\r\n"));
  auto r = c.Read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->header("connection"), "close");
  EXPECT_TRUE(c.WaitClosed());
}

TEST_F(RestServerTest, ManyClients_Concurrent_AllServed) {
  std::atomic<int> ok{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 16; ++t) {
    threads.emplace_back([&] {
      HttpClient c(server_->port());
      for (int i = 0; i < 10; ++i) {
        if (!c.SendRequest("GET", i % 2 ? "/v1/drives" : "/v1/drives/x2")) return;
        auto r = c.Read();
        if (r && r->status == 200) ++ok;
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(ok.load(), 160);
}

TEST_F(RestServerTest, Stop_WithStreamIdleConnectionAndHangingCall_PromptAndClosesAll) {
  HttpClient watch(server_->port());
  ASSERT_TRUE(watch.SendRequest("GET", "/v1/drives:watch?names=forever"));
  ASSERT_TRUE(watch.ReadHead());
  ASSERT_TRUE(watch.ReadChunk());
  HttpClient idle(server_->port());
  HttpClient home(server_->port());
  ASSERT_TRUE(home.SendRequest("POST", "/v1/drives/x1:home", "{}"));
  ASSERT_TRUE(grpc_.service().WaitFor([](const auto& s) { return s.method == "Home"; }));

  const auto start = std::chrono::steady_clock::now();
  server_->Stop();
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_LT(took, 2s);
  EXPECT_TRUE(watch.WaitClosed(5s));
  EXPECT_TRUE(idle.WaitClosed(5s));
  EXPECT_TRUE(home.WaitClosed(5s));
  EXPECT_TRUE(grpc_.service().WaitFor([](const auto& s) {
    return s.watch_cancelled == 1 && s.watch_active == 0 && s.home_cancelled == 1;
  }));
  HttpClient after(server_->port());
  EXPECT_FALSE(after.connected());
  server_->Stop();  // idempotent
}

}  // namespace
}  // namespace drivegw::rest
