// End to end over real sockets: the demo gateway (embedded simulated LinMot drives on loopback
// UDP, a DeviceNet drive on the user-space CAN bus, a Trinamic SIXpack on a pty, a STOBER axis
// on a CANopen bus of its own, SQLite file) driven through gRPC and through REST.
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <thread>

#include "drivegw/v1/drive.grpc.pb.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "adapters/stober/param_id.h"
#include "server/gateway.h"
#include "sim/stober/motion_core.h"
#include "sim/stober/server.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "tests/e2e/http_client.h"

namespace drivegw::server {
namespace {

using testing::HttpRequest;

class GatewayE2eTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-e2e-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    std::random_device rd;
    can_port_ = static_cast<uint16_t>(20000 + rd() % 20000);
    auto gw = Gateway::Start(Options());
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw_->grpc_port()),
                                   grpc::InsecureChannelCredentials());
    stub_ = v1::DriveService::NewStub(channel_);
  }
  GatewayOptions Options() const {
    GatewayOptions o;
    o.config.listen.grpc = "127.0.0.1:0";
    o.config.listen.http = "127.0.0.1:0";
    o.config.data_dir = data_dir_;
    o.config.demo = true;
    o.demo_first_port = 0;   // ephemeral simulator ports: ctest runs in parallel
    o.demo_master_port = 0;  // ephemeral master port; the simulators answer any source port
    // A CAN bus of this test's own: parallel ctest runs must not share one.
    o.demo_can_port = can_port_;
    o.demo_canopen_port = static_cast<uint16_t>(can_port_ + 1);  // the STOBER axis's own bus
    return o;
  }
  void TearDown() override {
    gw_.reset();
    std::filesystem::remove_all(data_dir_);
  }

  // Waits until GetDrive reports `pred` or the deadline passes.
  template <typename Pred>
  v1::Drive WaitFor(const std::string& name, Pred pred, std::chrono::seconds timeout = std::chrono::seconds(10)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    v1::Drive d;
    while (std::chrono::steady_clock::now() < deadline) {
      grpc::ClientContext ctx;
      v1::GetDriveRequest req;
      req.set_name(name);
      if (stub_->GetDrive(&ctx, req, &d).ok() && pred(d)) return d;
      // Status arrives every LinUDP cycle (5 ms); a short poll keeps the test quick.
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return d;
  }

  int http() const { return gw_->http_port(); }

  std::string data_dir_;
  uint16_t can_port_ = 0;
  std::unique_ptr<Gateway> gw_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::DriveService::Stub> stub_;
};

TEST_F(GatewayE2eTest, ListDrives_Demo_ListsEveryFamilyOnline) {
  WaitFor("drives/x1", [](const v1::Drive& d) { return d.status().state() != v1::OFFLINE; });
  grpc::ClientContext ctx;
  v1::ListDrivesResponse resp;
  ASSERT_TRUE(stub_->ListDrives(&ctx, v1::ListDrivesRequest(), &resp).ok());
  ASSERT_EQ(resp.drives_size(), 6);
  EXPECT_EQ(resp.drives(0).name(), "drives/x1");
  EXPECT_EQ(resp.drives(1).name(), "drives/x2");
  EXPECT_EQ(resp.drives(2).name(), "drives/d1");
  EXPECT_EQ(resp.drives(3).name(), "drives/feeder-x");
  EXPECT_EQ(resp.drives(4).name(), "drives/feeder-y");
  EXPECT_EQ(resp.drives(5).name(), "drives/s1");
  EXPECT_EQ(resp.drives(0).family(), "linmot");
  EXPECT_EQ(resp.drives(2).family(), "linmot-devicenet");
  EXPECT_EQ(resp.drives(3).family(), "trinamic");
  EXPECT_EQ(resp.drives(4).family(), "trinamic");
  EXPECT_EQ(resp.drives(5).family(), "stober");
  EXPECT_NE(resp.drives(0).status().state(), v1::OFFLINE);
}

TEST_F(GatewayE2eTest, MoveAbsolute_Grpc_WatchSeesRampToTargetAndDone) {
  {
    grpc::ClientContext ctx;
    v1::EnableRequest req;
    req.set_name("drives/x1");
    v1::CommandHandle h;
    grpc::Status s = stub_->Enable(&ctx, req, &h);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(h.state(), v1::DONE);
  }
  // Watch in the background and record every position and the final command state.
  grpc::ClientContext watch_ctx;
  v1::WatchDrivesRequest wreq;
  wreq.add_names("drives/x1");
  wreq.set_max_rate_hz(200);
  auto reader = stub_->WatchDrives(&watch_ctx, wreq);
  std::vector<double> positions;
  std::atomic<bool> done_seen{false};
  std::string moved_command;
  std::thread watcher([&] {
    v1::DriveStatus st;
    while (reader->Read(&st)) {
      positions.push_back(st.position_mm());
      if (!moved_command.empty() && st.last_command().name() == moved_command &&
          st.last_command().state() == v1::DONE) {
        done_seen = true;
        break;
      }
    }
  });
  v1::CommandHandle move;
  {
    grpc::ClientContext ctx;
    v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(50);
    req.set_velocity_mm_s(500);
    req.set_acceleration_mm_s2(5000);
    grpc::Status s = stub_->MoveAbsolute(&ctx, req, &move);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_TRUE(move.state() == v1::ACTIVE || move.state() == v1::DONE) << move.ShortDebugString();
    EXPECT_EQ(move.kind(), "MoveAbsolute");
  }
  moved_command = move.name();
  const v1::Drive d = WaitFor("drives/x1", [&](const v1::Drive& d) {
    return d.status().last_command().name() == move.name() && d.status().last_command().state() == v1::DONE;
  });
  EXPECT_EQ(d.status().last_command().state(), v1::DONE);
  EXPECT_NEAR(d.status().position_mm(), 50, 0.01);
  EXPECT_TRUE(d.status().in_target());
  // The stream must have carried intermediate positions of the ramp and then DONE.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!done_seen && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  watch_ctx.TryCancel();
  watcher.join();
  EXPECT_TRUE(done_seen);
  int intermediate = 0;
  for (double p : positions) {
    if (p > 11 && p < 49) ++intermediate;
  }
  EXPECT_GE(intermediate, 3) << "watch stream did not show the ramp";
}

TEST_F(GatewayE2eTest, MoveAbsolute_VelocityAboveAxis_BadRequestNamesField) {
  grpc::ClientContext ctx;
  v1::MoveAbsoluteRequest req;
  req.set_name("drives/x1");
  req.set_position_mm(50);
  req.set_velocity_mm_s(1e9);
  req.set_acceleration_mm_s2(5000);
  v1::CommandHandle h;
  grpc::Status s = stub_->MoveAbsolute(&ctx, req, &h);
  ASSERT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_NE(s.error_message().find("move_absolute.velocity_mm_s"), std::string::npos) << s.error_message();
  google::rpc::Status details;
  ASSERT_TRUE(details.ParseFromString(s.error_details()));
  ASSERT_EQ(details.details_size(), 1);
  google::rpc::BadRequest br;
  ASSERT_TRUE(details.details(0).UnpackTo(&br));
  ASSERT_EQ(br.field_violations_size(), 1);
  EXPECT_EQ(br.field_violations(0).field(), "move_absolute.velocity_mm_s");
}

TEST_F(GatewayE2eTest, HealthCheck_Serving) {
  // grpc.health.v1.Health/Check with an empty HealthCheckRequest (service "" = the server).
  grpc::GenericStub stub(channel_);
  grpc::Slice empty("");
  grpc::ByteBuffer in(&empty, 1), out;
  grpc::ClientContext ctx;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &in, &out,
                 [&](grpc::Status s) { done.set_value(s); });
  grpc::Status s = done.get_future().get();
  ASSERT_TRUE(s.ok()) << s.error_message();
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(out.Dump(&slices).ok());
  std::string bytes;
  for (const auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
  // HealthCheckResponse{status: SERVING(1)} = field 1, varint 1.
  EXPECT_EQ(bytes, std::string("\x08\x01", 2));
}

TEST_F(GatewayE2eTest, GetDrive_Unknown_NotFound) {
  grpc::ClientContext ctx;
  v1::GetDriveRequest req;
  req.set_name("drives/nope");
  v1::Drive d;
  EXPECT_EQ(stub_->GetDrive(&ctx, req, &d).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(GatewayE2eTest, Rest_EnableAndMove_ReachesTargetAndIsAudited) {
  WaitFor("drives/x2", [](const v1::Drive& d) { return d.status().state() != v1::OFFLINE; });
  auto list = HttpRequest(http(), "GET", "/v1/drives");
  ASSERT_EQ(list.status, 200) << list.body;
  EXPECT_NE(list.body.find("\"drives/x2\""), std::string::npos) << list.body;

  auto en = HttpRequest(http(), "POST", "/v1/drives/x2:enable", "");
  ASSERT_EQ(en.status, 200) << en.body;
  EXPECT_NE(en.body.find("\"DONE\""), std::string::npos) << en.body;

  auto mv = HttpRequest(http(), "POST", "/v1/drives/x2:moveAbsolute",
                        R"({"position_mm": 50, "velocity_mm_s": 500, "acceleration_mm_s2": 5000})");
  ASSERT_EQ(mv.status, 200) << mv.body;
  EXPECT_NE(mv.body.find("MoveAbsolute"), std::string::npos) << mv.body;

  const v1::Drive d = WaitFor("drives/x2", [](const v1::Drive& d) {
    return d.status().last_command().kind() == "MoveAbsolute" && d.status().last_command().state() == v1::DONE;
  });
  EXPECT_NEAR(d.status().position_mm(), 50, 0.01);

  auto got = HttpRequest(http(), "GET", "/v1/drives/x2");
  ASSERT_EQ(got.status, 200);
  EXPECT_NE(got.body.find("\"position_mm\""), std::string::npos) << got.body;
  // Issue 8: the status carries the drive's link health (the move put requests on the wire).
  EXPECT_NE(got.body.find("\"link\":{\"requests\":\""), std::string::npos) << got.body;

  // Every mutating call is in the audit log with the REST client's address.
  auto db = storage::Db::Open((std::filesystem::path(data_dir_) / "drivegw.db").string());
  ASSERT_TRUE(db.ok()) << db.status();
  storage::AuditLog audit(*db);
  storage::AuditQuery q;
  q.drive = "x2";
  auto records = audit.Query(q);
  ASSERT_TRUE(records.ok()) << records.status();
  ASSERT_GE(records->size(), 2u);
  EXPECT_EQ((*records)[0].action, "MoveAbsolute");
  EXPECT_EQ((*records)[0].principal, "anonymous");
  EXPECT_EQ((*records)[0].result_code, 0);
  EXPECT_NE((*records)[0].source_address.find("127.0.0.1"), std::string::npos) << (*records)[0].source_address;
  EXPECT_NE((*records)[0].request_json.find("position_mm"), std::string::npos);
}

TEST_F(GatewayE2eTest, Rest_DeviceNetDemoDrive_EnablesAndMoves) {
  // The DeviceNet drive on the user-space CAN bus behind the same API (issue 3).
  const v1::Drive online = WaitFor("drives/d1", [](const v1::Drive& d) {
    return d.status().state() != v1::OFFLINE && d.status().state() != v1::DRIVE_STATE_UNSPECIFIED;
  }, std::chrono::seconds(15));
  ASSERT_NE(online.status().state(), v1::OFFLINE) << online.ShortDebugString();
  auto en = HttpRequest(http(), "POST", "/v1/drives/d1:enable", "");
  ASSERT_EQ(en.status, 200) << en.body;
  EXPECT_NE(en.body.find("\"DONE\""), std::string::npos) << en.body;
  auto home = HttpRequest(http(), "POST", "/v1/drives/d1:home", "");
  ASSERT_EQ(home.status, 200) << home.body;
  WaitFor("drives/d1", [](const v1::Drive& d) { return d.status().homed(); }, std::chrono::seconds(15));
  auto mv = HttpRequest(http(), "POST", "/v1/drives/d1:moveAbsolute",
                        R"({"position_mm": 40, "velocity_mm_s": 500, "acceleration_mm_s2": 5000})");
  ASSERT_EQ(mv.status, 200) << mv.body;
  const v1::Drive d = WaitFor("drives/d1", [](const v1::Drive& d) {
    return d.status().last_command().kind() == "MoveAbsolute" && d.status().last_command().state() == v1::DONE;
  }, std::chrono::seconds(15));
  EXPECT_EQ(d.status().last_command().state(), v1::DONE) << d.ShortDebugString();
  EXPECT_NEAR(d.status().position_mm(), 40, 0.05);
}

TEST_F(GatewayE2eTest, Rest_TrinamicDemoAxis_EnablesAndMovesTo10Mm) {
  // Motor 0 of the simulated SIXpack behind the pty link in the data dir (issue 4).
  ASSERT_NE(gw_->demo_trinamic_simulator(), nullptr);
  EXPECT_TRUE(std::filesystem::is_symlink(std::filesystem::path(data_dir_) / "trinamic-demo.pty"));
  const v1::Drive online = WaitFor("drives/feeder-x", [](const v1::Drive& d) {
    return d.status().state() != v1::OFFLINE && d.status().state() != v1::DRIVE_STATE_UNSPECIFIED;
  }, std::chrono::seconds(15));
  ASSERT_NE(online.status().state(), v1::OFFLINE) << online.ShortDebugString();
  auto en = HttpRequest(http(), "POST", "/v1/drives/feeder-x:enable", "");
  ASSERT_EQ(en.status, 200) << en.body;
  EXPECT_NE(en.body.find("\"DONE\""), std::string::npos) << en.body;
  // 20 mm/s and 100 mm/s² are within the axis limits (40 mm/s, 190 mm/s²): about 0.7 s.
  auto mv = HttpRequest(http(), "POST", "/v1/drives/feeder-x:moveAbsolute",
                        R"({"position_mm": 10, "velocity_mm_s": 20, "acceleration_mm_s2": 100})");
  ASSERT_EQ(mv.status, 200) << mv.body;
  EXPECT_NE(mv.body.find("MoveAbsolute"), std::string::npos) << mv.body;
  const v1::Drive d = WaitFor("drives/feeder-x", [](const v1::Drive& d) {
    return d.status().last_command().kind() == "MoveAbsolute" && d.status().last_command().state() == v1::DONE;
  }, std::chrono::seconds(15));
  EXPECT_EQ(d.status().last_command().state(), v1::DONE) << d.ShortDebugString();
  // 640 microsteps/mm: one microstep is 1/640 mm.
  EXPECT_NEAR(d.status().position_mm(), 10.0, 1.0 / 640) << d.ShortDebugString();
  // The other axis of the same controller did not move.
  const v1::Drive y = WaitFor("drives/feeder-y", [](const v1::Drive& d) {
    return d.status().state() != v1::OFFLINE && d.status().state() != v1::DRIVE_STATE_UNSPECIFIED;
  });
  EXPECT_NEAR(y.status().position_mm(), 0.0, 1.0 / 640) << y.ShortDebugString();
}

TEST_F(GatewayE2eTest, Demo_TrinamicPtyLink_StaleReplacedOtherFileRefused) {
  const std::filesystem::path link = std::filesystem::path(data_dir_) / "trinamic-demo.pty";
  const std::filesystem::path pts = std::filesystem::read_symlink(link);
  gw_.reset();  // the link goes with the simulator's pty
  EXPECT_FALSE(std::filesystem::is_symlink(link));
  // A link left behind by a killed gateway points at a pty that no longer exists.
  std::filesystem::create_symlink("/dev/pts/drivegw-e2e-gone", link);
  auto again = Gateway::Start(Options());
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_NE(std::filesystem::read_symlink(link), "/dev/pts/drivegw-e2e-gone");
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::read_symlink(link))) << pts;
  again->reset();
  // Anything else at that path is not the gateway's to delete.
  std::ofstream(link) << "not a pty";
  auto refused = Gateway::Start(Options());
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("feeder-x"), std::string::npos) << refused.status();
  EXPECT_NE(refused.status().message().find(link.string()), std::string::npos) << refused.status();
}

// Gap 14 (decision 1495): a database file whose header is valid but whose pages are damaged stops
// the start with DATA_LOSS naming data_dir, the file and SQLite's finding, instead of starting
// and failing the first audited command: damage in the schema's pages (Open fails) and in the
// last page only (Open succeeds, PRAGMA quick_check finds it). The undamaged file starts again.
TEST_F(GatewayE2eTest, Start_DatabaseDamagedBehindAValidHeader_DataLossNamingTheFile) {
  gw_.reset();  // closes the database (its WAL is checkpointed into the file)
  const std::filesystem::path db = std::filesystem::path(data_dir_) / "drivegw.db";
  const auto size = std::filesystem::file_size(db);
  std::vector<char> original(size);
  std::ifstream(db, std::ios::binary).read(original.data(), static_cast<std::streamsize>(size));
  // The file's page size (header bytes 16-17, big-endian; decision 1486 makes it 2048 for a new
  // database): the damage starts behind the first page (the schema) or covers the last one.
  ASSERT_GT(size, 18u);
  const std::uintmax_t page = (static_cast<unsigned char>(original[16]) << 8) |
                              static_cast<unsigned char>(original[17]);
  ASSERT_GE(page, 512u);
  ASSERT_GT(size, 4 * page) << "too small to damage behind the header";
  // Overwrites [from, size) with seeded noise, as a torn write or a bad sector would leave it.
  auto damage = [&](std::uintmax_t from) {
    std::ofstream(db, std::ios::binary | std::ios::trunc)
        .write(original.data(), static_cast<std::streamsize>(size));
    std::mt19937 noise(1495);
    std::fstream f(db, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(static_cast<std::streamoff>(from));
    for (auto i = from; i < size; ++i) f.put(static_cast<char>(noise()));
  };
  const std::string prefix = "data_dir: database '" + db.string() + "' ";
  for (const std::uintmax_t from : {page, size - page}) {
    SCOPED_TRACE(from);
    damage(from);
    char header[16] = {};
    std::ifstream(db, std::ios::binary).read(header, sizeof header);
    ASSERT_EQ(std::string(header, 15), "SQLite format 3");
    auto refused = Gateway::Start(Options());
    ASSERT_FALSE(refused.ok()) << "started on a damaged database";
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kDataLoss) << refused.status();
    const std::string message(refused.status().message());
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
    EXPECT_NE(message.find("restore it from a backup"), std::string::npos) << message;
    if (from != page) {  // Open succeeds on this one: the check itself found it
      EXPECT_NE(message.find("fails PRAGMA quick_check: "), std::string::npos) << message;
    }
  }
  std::ofstream(db, std::ios::binary | std::ios::trunc)
      .write(original.data(), static_cast<std::streamsize>(size));
  auto again = Gateway::Start(Options());
  EXPECT_TRUE(again.ok()) << again.status();
}

// Gap 14: a data_dir that is a file is named as such (not "cannot create: File exists").
TEST_F(GatewayE2eTest, Start_DataDirIsAFile_FailedPreconditionNamingIt) {
  gw_.reset();
  const std::string file = data_dir_ + "/not-a-dir";
  std::ofstream(file) << "x";
  GatewayOptions o = Options();
  o.config.data_dir = file;
  auto refused = Gateway::Start(o);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(refused.status().message(),
            "data_dir: '" + file + "' exists and is not a directory");
}

TEST_F(GatewayE2eTest, Rest_StoberDemoAxis_EnablesAndMovesTo25Mm) {
  // CANopen node 3 on the demo's CANopen bus (issue 5; decision 409): 1 u = 1 mm.
  ASSERT_NE(gw_->demo_stober_simulator(), nullptr);
  EXPECT_EQ(gw_->demo_stober_simulator()->node_id(), 3);
  EXPECT_EQ(gw_->demo_stober_simulator()->bus_name(),
            "udp:239.74.163.2:" + std::to_string(can_port_ + 1));
  const v1::Drive online = WaitFor("drives/s1", [](const v1::Drive& d) {
    return d.status().state() != v1::OFFLINE && d.status().state() != v1::DRIVE_STATE_UNSPECIFIED;
  }, std::chrono::seconds(15));
  ASSERT_NE(online.status().state(), v1::OFFLINE) << online.ShortDebugString();
  auto en = HttpRequest(http(), "POST", "/v1/drives/s1:enable", "");
  ASSERT_EQ(en.status, 200) << en.body;
  EXPECT_NE(en.body.find("\"DONE\""), std::string::npos) << en.body;
  // 100 mm/s and 1000 mm/s² (limits 1000 mm/s, 10000 mm/s²): about 0.35 s.
  auto mv = HttpRequest(http(), "POST", "/v1/drives/s1:moveAbsolute",
                        R"({"position_mm": 25, "velocity_mm_s": 100, "acceleration_mm_s2": 1000})");
  ASSERT_EQ(mv.status, 200) << mv.body;
  EXPECT_NE(mv.body.find("MoveAbsolute"), std::string::npos) << mv.body;
  const v1::Drive d = WaitFor("drives/s1", [](const v1::Drive& d) {
    return d.status().last_command().kind() == "MoveAbsolute" && d.status().last_command().state() == v1::DONE;
  }, std::chrono::seconds(15));
  EXPECT_EQ(d.status().last_command().state(), v1::DONE) << d.ShortDebugString();
  // Positions travel in 0.001 u (decision 1172).
  EXPECT_NEAR(d.status().position_mm(), 25.0, 0.001) << d.ShortDebugString();
  // The simulated axis stands at 25 u, the target the drive sent.
  double actual = 0;
  gw_->demo_stober_simulator()->WithAxis([&](sim::stober::MotionCore& core) {
    auto position = core.Read(drivegw::stober::P("I80"));
    ASSERT_TRUE(position.ok()) << position.status();
    actual = *position;
  });
  EXPECT_NEAR(actual, 25.0, 0.001);
}

TEST_F(GatewayE2eTest, Demo_CanOpenBusEqualToDeviceNetBus_Refused) {
  gw_.reset();
  GatewayOptions o = Options();
  o.demo_canopen_port = o.demo_can_port;
  auto refused = Gateway::Start(o);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("demo_canopen_port"), std::string::npos) << refused.status();
  EXPECT_NE(refused.status().message().find("decision 407"), std::string::npos) << refused.status();
}

TEST_F(GatewayE2eTest, Rest_BadInput_ClearErrorsAndGatewayStaysUp) {
  auto bad_json = HttpRequest(http(), "POST", "/v1/drives/x1:moveAbsolute", "{\"position_mm\": \"far\"}");
  EXPECT_EQ(bad_json.status, 400) << bad_json.body;
  EXPECT_NE(bad_json.body.find("position_mm"), std::string::npos) << bad_json.body;

  auto out_of_stroke = HttpRequest(http(), "POST", "/v1/drives/x1:moveAbsolute",
                                   R"({"position_mm": 5000, "velocity_mm_s": 100, "acceleration_mm_s2": 1000})");
  EXPECT_EQ(out_of_stroke.status, 400) << out_of_stroke.body;
  EXPECT_NE(out_of_stroke.body.find("move_absolute.position_mm"), std::string::npos) << out_of_stroke.body;
  EXPECT_NE(out_of_stroke.body.find("max_mm"), std::string::npos) << out_of_stroke.body;

  auto unknown = HttpRequest(http(), "POST", "/v1/drives/zz:enable", "");
  EXPECT_EQ(unknown.status, 404) << unknown.body;

  auto not_enabled = HttpRequest(http(), "POST", "/v1/drives/x1:moveAbsolute",
                                 R"({"position_mm": 20, "velocity_mm_s": 100, "acceleration_mm_s2": 1000})");
  EXPECT_EQ(not_enabled.status, 400) << not_enabled.body;  // FAILED_PRECONDITION: drive not enabled

  // A native command of another family is refused by name, and the gateway stays up.
  auto wrong_family = HttpRequest(http(), "POST", "/v1/drives/x1:sendNativeCommand",
                                  R"({"linmot_devicenet": {"command": 17, "value": 5}})");
  EXPECT_EQ(wrong_family.status, 400) << wrong_family.body;
  EXPECT_NE(wrong_family.body.find("linmot_devicenet"), std::string::npos) << wrong_family.body;

  auto openapi = HttpRequest(http(), "GET", "/openapi.json");
  EXPECT_EQ(openapi.status, 200);
  EXPECT_NE(openapi.body.find("/v1/drives"), std::string::npos);

  auto still_up = HttpRequest(http(), "GET", "/v1/drives");
  EXPECT_EQ(still_up.status, 200);
}

}  // namespace
}  // namespace drivegw::server
