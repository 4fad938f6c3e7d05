// Operations on the real demo gateway (issue 7; decisions 021, 022): /metrics scraped and parsed
// after a move over REST, /readyz and per-service gRPC health, the per-drive wire trace switched
// on and off at run time for every family (LinUDP, DeviceNet, Trinamic, CANopen).
#include <fcntl.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/gateway.h"
#include "tests/e2e/http_client.h"
#include "tests/server/ops/exposition_parser.h"
#include "tests/support/demo_gateway.h"

namespace drivegw::server {
namespace {

using drivegw::testing::HttpRequest;
using ops::test_support::CheckHistograms;
using ops::test_support::ParseExposition;

// stderr (the log) goes to a file for the test's life, so wire trace lines can be read back.
class StderrCapture {
 public:
  explicit StderrCapture(const std::string& path) : path_(path) {
    saved_ = ::dup(STDERR_FILENO);
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_APPEND, 0644);
    ::dup2(fd, STDERR_FILENO);
    ::close(fd);
  }
  ~StderrCapture() {
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
  }
  std::string Read(size_t from = 0) const {
    std::ifstream in(path_);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string all = ss.str();
    return from >= all.size() ? "" : all.substr(from);
  }
  size_t Size() const { return Read().size(); }

 private:
  std::string path_;
  int saved_ = -1;
};

size_t Count(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1)) {
    ++n;
  }
  return n;
}

// `"key": true` anywhere in a JSON body (whatever the spacing).
bool JsonTrue(const std::string& body, const std::string& key) {
  return std::regex_search(body, std::regex("\"" + key + "\"\\s*:\\s*true"));
}

class OpsGatewayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-ops-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    capture_ = std::make_unique<StderrCapture>(data_dir_ + "/stderr.log");
    GatewayOptions o = test_support::DemoGatewayOptions(data_dir_);
    auto gw = Gateway::Start(o);
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
  }
  void TearDown() override {
    gw_.reset();
    capture_.reset();
    std::filesystem::remove_all(data_dir_);
  }
  int http() const { return gw_->http_port(); }

  ops::test_support::ParsedExposition Scrape() {
    auto r = HttpRequest(http(), "GET", "/metrics");
    EXPECT_EQ(r.status, 200);
    return ParseExposition(r.body);
  }

  // Waits (polling the captured log, not a timing assert) until `needle` appears after `from`.
  bool WaitLog(const std::string& needle, size_t from = 0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      if (capture_->Read(from).find(needle) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  // Waits until the drive's wire request counter grew by `n` (the exchange went on).
  void WaitWireRequests(const std::string& drive, double n) {
    const double start = Scrape().Sum("drivegw_drive_wire_requests_total", {{"drive", drive}});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      if (Scrape().Sum("drivegw_drive_wire_requests_total", {{"drive", drive}}) >= start + n)
        return;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << drive << ": wire requests did not grow by " << n;
  }

  std::string data_dir_;
  std::unique_ptr<StderrCapture> capture_;
  std::unique_ptr<Gateway> gw_;
};

TEST_F(OpsGatewayTest, Metrics_AfterMoveOverRest_DriveAndRpcCountsParsed) {
  ASSERT_EQ(HttpRequest(http(), "POST", "/v1/drives/x1:enable", "{}").status, 200);
  auto mv = HttpRequest(http(), "POST", "/v1/drives/x1:moveAbsolute",
                        R"({"position_mm": 20, "velocity_mm_s": 500, "acceleration_mm_s2": 5000})");
  ASSERT_EQ(mv.status, 200) << mv.body;
  // One SDO upload of the STOBER axis's status word (6041h) through the native pass-through.
  auto sdo = HttpRequest(http(), "POST", "/v1/drives/s1:sendNativeCommand",
                         R"({"canopen_sdo": {"index": 24641, "sub_index": 0}})");
  ASSERT_EQ(sdo.status, 200) << sdo.body;

  auto metrics = HttpRequest(http(), "GET", "/metrics");
  ASSERT_EQ(metrics.status, 200);
  const auto e = ParseExposition(metrics.body);
  ASSERT_TRUE(e.errors.empty()) << e.errors.front();
  EXPECT_EQ(CheckHistograms(e), "");
  // Per drive and family: the API calls on x1 and its session's telegrams.
  EXPECT_GE(e.Sum("drivegw_drive_requests_total",
                  {{"drive", "x1"}, {"family", "linmot"}, {"method", "MoveAbsolute"}}),
            1);
  EXPECT_GT(e.Sum("drivegw_drive_wire_requests_total", {{"drive", "x1"}, {"family", "linmot"}}), 0);
  EXPECT_GT(e.Sum("drivegw_drive_wire_replies_total", {{"drive", "x1"}}), 0);
  EXPECT_EQ(e.Sum("drivegw_drive_online", {{"drive", "x1"}}), 1);
  EXPECT_EQ(e.type.at("drivegw_drive_wire_errors_total"), "counter");
  // Every configured drive reports its link state.
  for (const char* d : {"x1", "x2", "d1", "feeder-x", "feeder-y", "s1"}) {
    EXPECT_EQ(e.Find("drivegw_drive_online", {{"drive", d}}).size(), 1u) << d;
  }
  // Per RPC, REST calls labelled as such; latency histogram present.
  EXPECT_GE(e.Sum("drivegw_rpc_requests_total", {{"service", "drivegw.v1.DriveService"},
                                                 {"method", "MoveAbsolute"},
                                                 {"transport", "rest"},
                                                 {"code", "OK"}}),
            1);
  EXPECT_GE(e.Sum("drivegw_rpc_duration_seconds_count",
                  {{"method", "MoveAbsolute"}, {"transport", "rest"}}),
            1);
  // Round trips of the LinUDP telegrams, the Trinamic line and the STOBER axis's SDO transfers.
  EXPECT_GT(e.Sum("drivegw_wire_round_trip_seconds_count", {{"family", "linmot"}, {"drive", "x1"}}),
            0);
  EXPECT_GT(e.Sum("drivegw_wire_round_trip_seconds_count", {{"family", "trinamic"}}), 0);
  EXPECT_GT(e.Sum("drivegw_wire_round_trip_seconds_count", {{"family", "stober"}, {"drive", "s1"}}),
            0);
  // The move was audited: the audit write latency histogram has observations.
  EXPECT_GE(e.Sum("drivegw_audit_write_seconds_count"), 1);
}

// WatchDrives is a raw (ByteBuffer) method (decision 1341): the metrics interceptor learns that
// from the service and counts the stream without reading its messages as protobuf Messages.
TEST_F(OpsGatewayTest, Metrics_WatchDrivesRawStream_CountedWithItsStatus) {
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = v1::DriveService::NewStub(channel);
  {
    grpc::ClientContext ctx;
    v1::WatchDrivesRequest req;
    req.add_names("drives/x1");
    req.set_max_rate_hz(50);
    auto reader = stub->WatchDrives(&ctx, req);
    v1::DriveStatus st;
    ASSERT_TRUE(reader->Read(&st));
    EXPECT_EQ(st.name(), "drives/x1");
    ctx.TryCancel();
    while (reader->Read(&st)) {
    }
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }
  {
    // An unknown drive ends the stream with NOT_FOUND, counted under that code.
    grpc::ClientContext ctx;
    v1::WatchDrivesRequest req;
    req.add_names("drives/nope");
    auto reader = stub->WatchDrives(&ctx, req);
    v1::DriveStatus st;
    EXPECT_FALSE(reader->Read(&st));
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::NOT_FOUND);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  ops::test_support::ParsedExposition e;
  for (;;) {
    e = Scrape();
    const std::map<std::string, std::string> watch = {
        {"service", "drivegw.v1.DriveService"}, {"method", "WatchDrives"}, {"transport", "grpc"}};
    std::map<std::string, std::string> cancelled = watch, not_found = watch;
    cancelled["code"] = "CANCELLED";
    not_found["code"] = "NOT_FOUND";
    if ((e.Sum("drivegw_rpc_requests_total", cancelled) >= 1 &&
         e.Sum("drivegw_rpc_requests_total", not_found) >= 1) ||
        std::chrono::steady_clock::now() > deadline) {
      EXPECT_GE(e.Sum("drivegw_rpc_requests_total", cancelled), 1)
          << "WatchDrives calls of any code: " << e.Sum("drivegw_rpc_requests_total", watch);
      EXPECT_EQ(e.Sum("drivegw_rpc_requests_total", not_found), 1);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // No per-drive series from a raw stream (its request names drives only in `names`).
  EXPECT_EQ(e.Sum("drivegw_drive_requests_total", {{"method", "WatchDrives"}}), 0);
}

TEST_F(OpsGatewayTest, Readyz_AfterStart_200_AndHealthPerService) {
  auto r = HttpRequest(http(), "GET", "/readyz");
  EXPECT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(HttpRequest(http(), "GET", "/healthz").status, 200);
  auto rd = HttpRequest(http(), "GET", "/v1/readiness");
  EXPECT_EQ(rd.status, 200);
  EXPECT_TRUE(JsonTrue(rd.body, "ready")) << rd.body;

  // grpc.health.v1.Health/Check per service: HealthCheckRequest{service = 1} -> status 1 SERVING.
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                     grpc::InsecureChannelCredentials());
  grpc::GenericStub stub(channel);
  for (const std::string service :
       {"drivegw.v1.DriveService", "drivegw.v1.OpsService", "drivegw.v1.CurveSetService"}) {
    std::string req = "\x0a";
    req += static_cast<char>(service.size());
    req += service;
    grpc::Slice slice(req);
    grpc::ByteBuffer request(&slice, 1);
    grpc::ByteBuffer response;
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    std::promise<grpc::Status> done;
    stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                   [&](grpc::Status s) { done.set_value(s); });
    const grpc::Status s = done.get_future().get();
    ASSERT_TRUE(s.ok()) << service << ": " << s.error_message();
    std::vector<grpc::Slice> slices;
    ASSERT_TRUE(response.Dump(&slices).ok());
    std::string bytes;
    for (auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
    EXPECT_EQ(bytes, std::string("\x08\x01")) << service;
  }
}

TEST_F(OpsGatewayTest, WireTrace_LinUdp_OnLogsTelegramsOffStops) {
  auto on = HttpRequest(http(), "POST", "/v1/drives/x1:setWireTrace", R"({"enabled": true})");
  ASSERT_EQ(on.status, 200) << on.body;
  EXPECT_TRUE(JsonTrue(on.body, "enabled")) << on.body;
  EXPECT_TRUE(WaitLog("event=wire drive=x1 family=linmot dir=tx bytes="));
  EXPECT_TRUE(WaitLog("event=wire drive=x1 family=linmot dir=rx bytes="));

  ASSERT_EQ(
      HttpRequest(http(), "POST", "/v1/drives/x1:setWireTrace", R"({"enabled": false})").status,
      200);
  const size_t off = capture_->Size();
  WaitWireRequests("x1", 40);
  // At most the exchange in flight when the switch flipped.
  EXPECT_LE(Count(capture_->Read(off), "event=wire drive=x1 "), 2u);
  // The other demo LinMot drive was never traced.
  EXPECT_EQ(Count(capture_->Read(), "event=wire drive=x2 "), 0u);
}

TEST_F(OpsGatewayTest, WireTrace_TrinamicDeviceNetCanOpen_OnLogsOffStops) {
  struct Case {
    const char* drive;
    const char* line;
  };
  for (const Case& c : {Case{"feeder-x", "event=wire drive=feeder-x family=trinamic dir=tx bytes="},
                        Case{"d1", "event=wire drive=d1 family=linmot-devicenet dir=tx frame="},
                        Case{"s1", "event=wire drive=s1 family=canopen dir=rx frame="}}) {
    SCOPED_TRACE(c.drive);
    const std::string path = std::string("/v1/drives/") + c.drive + ":setWireTrace";
    const size_t before = capture_->Size();
    auto on = HttpRequest(http(), "POST", path, R"({"enabled": true})");
    ASSERT_EQ(on.status, 200) << on.body;
    EXPECT_TRUE(WaitLog(c.line, before));
    ASSERT_EQ(HttpRequest(http(), "POST", path, R"({"enabled": false})").status, 200);
    const size_t off = capture_->Size();
    // x1's cyclic exchange (5 ms) as the clock: 200 telegrams outlast several of the drive's
    // polls, heartbeats (100 ms) and status frames.
    WaitWireRequests("x1", 200);
    EXPECT_LE(Count(capture_->Read(off), std::string("event=wire drive=") + c.drive + " "), 2u);
  }
}

TEST_F(OpsGatewayTest, WireTrace_UnknownDrive_404_Audited) {
  auto r = HttpRequest(http(), "POST", "/v1/drives/nope:setWireTrace", R"({"enabled": true})");
  EXPECT_EQ(r.status, 404) << r.body;
}

}  // namespace
}  // namespace drivegw::server
