// Leases and streams over real gRPC (TCP) against the simulated STOBER axis on the user-space CAN
// bus: an anonymous holder is told apart by the x-drivegw-lease metadata it presents; a client
// that disconnects (cancels) its cyclic velocity stream brings the axis to a controlled stop
// (the stream's close, decision 008) instead of leaving it to extrapolate into event 78.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <thread>

#include "adapters/stober/drive.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "adapters/stober/param_id.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "drivegw/v1/leases.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/core/idempotency.h"
#include "server/core/lease_manager.h"
#include "server/core/lease_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/lease_service_grpc.h"
#include "server/grpc/worker_pool.h"
#include "server/rest/router.h"
#include "sim/stober/server.h"
#include "tests/server/rest/recording_sink.h"
#include "tests/support/wait_status.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
namespace ss = drivegw::sim::stober;

constexpr char kGroup[] = "239.74.163.98";
constexpr uint8_t kNode = 11;

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

class LeaseGrpcTest : public ::testing::Test {
 protected:
  void SetUp() override {
    CanBusConfig bus;
    bus.kind = CanBusConfig::Kind::kUdpMulticast;
    bus.group = kGroup;
    bus.port = RandomPort();
    ss::AxisServerOptions o;
    o.node_id = kNode;
    o.can = bus;
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    sim_ = std::move(*server);
    DriveConfig c;
    c.name = "s1";
    c.family = stober::kFamilyName;
    c.can = bus;
    c.node_id = kNode;
    c.axis.min_mm = -200;
    c.axis.max_mm = 200;
    c.axis.max_velocity_mm_s = 1000;
    c.axis.max_acceleration_mm_s2 = 10000;
    c.canopen.heartbeat = 50ms;
    c.canopen.heartbeat_timeout = 200ms;
    c.canopen.sdo_timeout = 300ms;
    auto drive = stober::CreateStoberDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::shared_ptr<Drive>(std::move(*drive));
    ASSERT_TRUE(drive_->Activate().ok());
    const DriveStatus up = test_support::WaitStatus(
        *drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, 10s);
    ASSERT_NE(up.state, DriveState::kOffline) << up.native.text;
    auto en = drive_->Enable();
    ASSERT_TRUE(en.ok()) << en.status();

    const std::vector<std::shared_ptr<Drive>> drives{drive_};
    core_ = std::make_unique<DriveServiceCore>(drives, nullptr, &leases_);
    lease_core_ = std::make_unique<LeaseServiceCore>(leases_, drives, nullptr);
    service_ = std::make_unique<DriveServiceGrpc>(*core_, pool_, CallAuth::Open(), &idempotency_);
    lease_service_ = std::make_unique<LeaseServiceGrpc>(*lease_core_, pool_, CallAuth::Open());
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    builder.RegisterService(lease_service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                       grpc::InsecureChannelCredentials());
    stub_ = v1::DriveService::NewStub(channel);
    lease_stub_ = v1::LeaseService::NewStub(channel);
  }
  void TearDown() override {
    if (server_) {
      server_->Shutdown(std::chrono::system_clock::now() + 5s);
      server_->Wait();
    }
    pool_.Shutdown();
    if (drive_) drive_->Deactivate();
    if (sim_) sim_->Stop();
  }

  static void Deadline(grpc::ClientContext& ctx) {
    ctx.set_deadline(std::chrono::system_clock::now() + 20s);
  }

  std::unique_ptr<ss::AxisServer> sim_;
  std::shared_ptr<Drive> drive_;
  LeaseManager leases_;
  IdempotencyCache idempotency_;
  WorkerPool pool_{4};
  std::unique_ptr<DriveServiceCore> core_;
  std::unique_ptr<LeaseServiceCore> lease_core_;
  std::unique_ptr<DriveServiceGrpc> service_;
  std::unique_ptr<LeaseServiceGrpc> lease_service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::DriveService::Stub> stub_;
  std::unique_ptr<v1::LeaseService::Stub> lease_stub_;
};

TEST_F(LeaseGrpcTest, AnonymousHolder_PresentsTheLeaseIdAsMetadata) {
  v1::Lease lease;
  {
    grpc::ClientContext ctx;
    Deadline(ctx);
    v1::AcquireLeaseRequest r;
    r.set_name("drives/s1");
    r.set_ttl_s(60);
    ASSERT_TRUE(lease_stub_->AcquireLease(&ctx, r, &lease).ok());
  }
  EXPECT_EQ(lease.holder(), "anonymous");
  v1::MoveRelativeRequest move;
  move.set_name("drives/s1");
  move.set_distance_mm(5);
  move.set_velocity_mm_s(100);
  move.set_acceleration_mm_s2(1000);
  v1::CommandHandle h;
  {
    grpc::ClientContext ctx;  // somebody else: no lease id
    Deadline(ctx);
    const grpc::Status s = stub_->MoveRelative(&ctx, move, &h);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(s.error_message(), HasSubstr("drive 's1' is leased by 'anonymous' until 20"));
  }
  {
    grpc::ClientContext ctx;
    Deadline(ctx);
    ctx.AddMetadata("x-drivegw-lease", lease.lease_id());
    const grpc::Status s = stub_->MoveRelative(&ctx, move, &h);
    EXPECT_TRUE(s.ok()) << s.error_message();
  }
  {
    grpc::ClientContext ctx;
    Deadline(ctx);
    v1::ListLeasesResponse list;
    ASSERT_TRUE(lease_stub_->ListLeases(&ctx, {}, &list).ok());
    ASSERT_EQ(list.leases_size(), 1);
    EXPECT_TRUE(list.leases(0).lease_id().empty());
  }
  {
    grpc::ClientContext ctx;
    Deadline(ctx);
    v1::ReleaseLeaseRequest r;
    r.set_lease_id(lease.lease_id());
    v1::ReleaseLeaseResponse resp;
    ASSERT_TRUE(lease_stub_->ReleaseLease(&ctx, r, &resp).ok());
  }
  EXPECT_TRUE(leases_.List().empty());
}

// REST: the lease comes back as JSON and the holder presents it as the X-Drivegw-Lease header,
// which the router forwards as x-drivegw-lease metadata; Idempotency-Key makes a retry harmless.
TEST_F(LeaseGrpcTest, Rest_LeaseHeaderForwarded) {
  rest::RouterOptions o;
  o.channel = server_->InProcessChannel(grpc::ChannelArguments());
  o.openapi_json = "{}";
  o.more_services = {"drivegw.v1.LeaseService"};
  auto router = rest::Router::Create(std::move(o));
  ASSERT_TRUE(router.ok()) << router.status();
  auto post = [&](std::string target, std::string body, std::string lease, std::string key = "") {
    auto sink = std::make_shared<rest::test_support::RecordingSink>();
    rest::HttpRequest req{"POST", std::move(target), std::move(body), "10.0.0.7:5555"};
    req.lease_id = std::move(lease);
    req.idempotency_key = std::move(key);
    (*router)->Handle(std::move(req), sink);
    return sink->Response();
  };
  const auto acquired = post("/v1/drives/s1:acquireLease", R"({"ttl_s": 60})", "");
  ASSERT_EQ(acquired.status, 200) << acquired.body;
  // The id is the 32 hex digits after the field name (proto or JSON spelling).
  std::string key = "\"lease_id\":\"";
  size_t at = acquired.body.find(key);
  if (at == std::string::npos) at = acquired.body.find(key = "\"leaseId\":\"");
  ASSERT_NE(at, std::string::npos) << acquired.body;
  const std::string id = acquired.body.substr(at + key.size(), 32);
  const std::string move =
      R"({"distance_mm": 2, "velocity_mm_s": 100, "acceleration_mm_s2": 1000})";
  const auto refused = post("/v1/drives/s1:moveRelative", move, "");
  EXPECT_EQ(refused.status, 400) << refused.body;  // FAILED_PRECONDITION
  EXPECT_THAT(refused.body, HasSubstr("leased by 'anonymous'"));
  const double start_mm = drive_->GetStatus().demand_position_mm;
  const auto allowed = post("/v1/drives/s1:moveRelative", move, id, "rest-move-1");
  EXPECT_EQ(allowed.status, 200) << allowed.body;
  // A retry with the same Idempotency-Key header answers the same command; the axis moves 2 mm
  // once, not twice.
  const auto retried = post("/v1/drives/s1:moveRelative", move, id, "rest-move-1");
  EXPECT_EQ(retried.status, 200) << retried.body;
  EXPECT_EQ(retried.body, allowed.body);
  const DriveStatus moved = test_support::WaitStatus(
      *drive_,
      [&](const DriveStatus& s) {
        // Both: near the end the actual position is within 1 µm one status before the last
        // demand step (1.999 mm) arrives (a CI run caught that snapshot).
        return s.state == DriveState::kEnabled && std::abs(s.position_mm - start_mm - 2) < 1e-3 &&
               std::abs(s.demand_position_mm - start_mm - 2) < 1e-6;
      },
      10s);
  EXPECT_NEAR(moved.position_mm, start_mm + 2, 1e-3);
  EXPECT_NEAR(moved.demand_position_mm, start_mm + 2, 1e-6);
  const auto released = post("/v1/leases/" + id + ":release", "{}", id);
  EXPECT_EQ(released.status, 200) << released.body;
  EXPECT_TRUE(leases_.List().empty());
}

TEST_F(LeaseGrpcTest, CancelledCyclicVelocityStream_AxisStopsUnderControl) {
  // Extrapolation time I423 = 100 ms: an axis nobody closes faults (event 78) soon after the
  // client is gone; a closed one stops with its limits and stays enabled.
  const auto i423 = *stober::ToCanOpen(stober::P("I423"));
  ASSERT_TRUE(
      drive_
          ->WriteParameter(
              ParameterRef{static_cast<uint32_t>(i423.index) << 8 | i423.sub_index, false}, 100)
          .ok());
  grpc::ClientContext ctx;
  Deadline(ctx);
  v1::CyclicStreamSummary summary;
  auto writer = stub_->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first;
  first.set_name("s1");
  first.set_mode(v1::CYCLIC_VELOCITY);
  first.mutable_setpoint()->set_value(50);
  ASSERT_TRUE(writer->Write(first));
  // Keep streaming 50 mm/s (about one set point per 2 ms SYNC) until the axis runs.
  std::atomic<bool> streaming{true};
  std::thread feeder([&] {
    v1::CyclicSetpointRequest m;
    m.mutable_setpoint()->set_value(50);
    while (streaming.load() && writer->Write(m)) std::this_thread::sleep_for(2ms);
  });
  const DriveStatus running = test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return s.velocity_mm_s > 20; }, 10s);
  EXPECT_GT(running.velocity_mm_s, 20);
  ctx.TryCancel();  // the client goes away mid-motion
  streaming = false;
  feeder.join();
  EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // The axis comes to rest enabled (not FAULT), with its cyclic command closed DONE.
  const DriveStatus rest = test_support::WaitStatus(
      *drive_,
      [](const DriveStatus& s) {
        return s.state == DriveState::kEnabled && std::abs(s.velocity_mm_s) < 1e-3;
      },
      10s);
  EXPECT_EQ(rest.state, DriveState::kEnabled) << rest.native.text;
  EXPECT_NEAR(rest.velocity_mm_s, 0, 1e-3);
  // Still at rest and enabled well past I423: nothing left running to extrapolate.
  const DriveStatus later = test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return s.state == DriveState::kFault; }, 500ms);
  EXPECT_EQ(later.state, DriveState::kEnabled) << later.native.text;
  EXPECT_NEAR(later.position_mm, rest.position_mm, 1e-3);
}

}  // namespace
}  // namespace drivegw::server
