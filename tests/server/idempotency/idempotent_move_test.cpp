// An idempotent MoveRelative over real gRPC (TCP) against the simulated LinMot drive on loopback
// UDP: a retry with the same key returns the first command and the simulator executes one motion
// command (its own counter), concurrent retries too; a different body with the key is refused.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "adapters/linmot/linudp/factory.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/core/idempotency.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/worker_pool.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

class IdempotentMoveTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sim::linmot::SimOptions o = test_support::LinUdpSimOptions();
    auto server = sim::linmot::LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    sim_ = std::move(*server);
    DriveConfig c = test_support::LinUdpDriveConfig(sim_->port());
    auto drive = linmot::linudp::CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::shared_ptr<Drive>(std::move(*drive));
    ASSERT_TRUE(drive_->Activate().ok());
    auto en = drive_->Enable();
    ASSERT_TRUE(en.ok()) << en.status();
    ASSERT_EQ(en->state, CommandState::kDone);
    start_mm_ = drive_->GetStatus().demand_position_mm;

    core_ =
        std::make_unique<DriveServiceCore>(std::vector<std::shared_ptr<Drive>>{drive_}, nullptr);
    service_ = std::make_unique<DriveServiceGrpc>(*core_, pool_, CallAuth::Open(), &cache_);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = v1::DriveService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                                          grpc::InsecureChannelCredentials()));
  }
  void TearDown() override {
    if (server_) {
      server_->Shutdown(std::chrono::system_clock::now() + 2s);
      server_->Wait();
    }
    pool_.Shutdown();
    if (drive_) drive_->Deactivate();
  }

  grpc::Status MoveBy(double mm, const std::string& key, v1::CommandHandle* out) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 20s);
    if (!key.empty()) ctx.AddMetadata("idempotency-key", key);
    v1::MoveRelativeRequest r;
    r.set_name("drives/x1");
    r.set_distance_mm(mm);
    r.set_velocity_mm_s(200);
    r.set_acceleration_mm_s2(2000);
    return stub_->MoveRelative(&ctx, r, out);
  }
  uint64_t Executed() { return sim_->Snapshot().device.mc_commands_executed; }
  // Waits for the command the handle names to end; returns the drive's demand position then.
  double FinalPosition(const v1::CommandHandle& h) {
    uint64_t id = 0;
    EXPECT_TRUE(absl::SimpleAtoi(h.name().substr(h.name().rfind('/') + 1), &id)) << h.name();
    const CommandInfo done = test_support::WaitCommandFinal(*drive_, id, 10s);
    EXPECT_EQ(done.state, CommandState::kDone) << done.message;
    return drive_->GetStatus().demand_position_mm;
  }

  std::unique_ptr<sim::linmot::LinMotServer> sim_;
  std::shared_ptr<Drive> drive_;
  double start_mm_ = 0;
  IdempotencyCache cache_;
  WorkerPool pool_{4};
  std::unique_ptr<DriveServiceCore> core_;
  std::unique_ptr<DriveServiceGrpc> service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::DriveService::Stub> stub_;
};

TEST_F(IdempotentMoveTest, Retry_SameCommand_DriveMovesOnce) {
  const uint64_t before = Executed();
  v1::CommandHandle first, retry;
  ASSERT_TRUE(MoveBy(10, "move-1", &first).ok());
  const double after_first = FinalPosition(first);
  EXPECT_NEAR(after_first, start_mm_ + 10, 1e-6);
  ASSERT_TRUE(MoveBy(10, "move-1", &retry).ok());
  EXPECT_EQ(retry.name(), first.name());
  EXPECT_NEAR(FinalPosition(retry), start_mm_ + 10, 1e-6);  // not 20: no second move
  EXPECT_EQ(Executed() - before, 1u);
  // Without a key the same request is a new move.
  v1::CommandHandle fresh;
  ASSERT_TRUE(MoveBy(10, "", &fresh).ok());
  EXPECT_NE(fresh.name(), first.name());
  EXPECT_NEAR(FinalPosition(fresh), start_mm_ + 20, 1e-6);
  EXPECT_EQ(Executed() - before, 2u);
}

TEST_F(IdempotentMoveTest, DifferentBody_InvalidArgumentNamingTheKey_NoMotion) {
  v1::CommandHandle first, other;
  ASSERT_TRUE(MoveBy(10, "move-2", &first).ok());
  FinalPosition(first);
  const uint64_t before = Executed();
  const grpc::Status s = MoveBy(5, "move-2", &other);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("idempotency key 'move-2'"));
  EXPECT_EQ(Executed(), before);
}

TEST_F(IdempotentMoveTest, ConcurrentRetries_OneMotionCommand) {
  const uint64_t before = Executed();
  constexpr int kClients = 4;
  std::vector<v1::CommandHandle> handles(kClients);
  std::vector<grpc::Status> statuses(kClients);
  std::vector<std::thread> clients;
  for (int i = 0; i < kClients; ++i) {
    clients.emplace_back([&, i] { statuses[i] = MoveBy(10, "move-3", &handles[i]); });
  }
  for (auto& t : clients) t.join();
  for (int i = 0; i < kClients; ++i) {
    ASSERT_TRUE(statuses[i].ok()) << statuses[i].error_message();
    EXPECT_EQ(handles[i].name(), handles[0].name());
  }
  EXPECT_NEAR(FinalPosition(handles[0]), start_mm_ + 10, 1e-6);
  EXPECT_EQ(Executed() - before, 1u);
}

}  // namespace
}  // namespace drivegw::server
