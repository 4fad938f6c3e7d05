// WatchDrives over gRPC on the shared ticker (issue 10, P5; decision 1341): the raw method still
// speaks DriveStatus on the wire, sends the first snapshot at once and then changes only, refuses
// a bad request with the core's status, and ends with the deadline, a cancel and server shutdown.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "tests/server/api/api_fixture.h"

namespace drivegw::server::test_support {
namespace {

using namespace std::chrono_literals;

class WatchApiTest : public ApiRoundTripTest {
 protected:
  static void Deadline(grpc::ClientContext& ctx, std::chrono::milliseconds in) {
    ctx.set_deadline(std::chrono::system_clock::now() + in);
  }
  static v1::WatchDrivesRequest Request(const std::string& name, double rate_hz) {
    v1::WatchDrivesRequest r;
    r.add_names(name);
    r.set_max_rate_hz(rate_hz);
    return r;
  }
};

TEST_F(WatchApiTest, WatchDrives_StateChanges_FirstSnapshotThenEachChange) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  Deadline(ctx, 20s);
  auto reader = stub->WatchDrives(&ctx, Request("drives/lin1", 100));
  v1::DriveStatus s;
  ASSERT_TRUE(reader->Read(&s));
  EXPECT_EQ(s.name(), "drives/lin1");
  EXPECT_EQ(s.state(), v1::OFFLINE);
  lin1_.SetState(DriveState::kEnabled);
  ASSERT_TRUE(reader->Read(&s));
  EXPECT_EQ(s.state(), v1::ENABLED);
  lin1_.SetState(DriveState::kMoving);
  ASSERT_TRUE(reader->Read(&s));
  EXPECT_EQ(s.state(), v1::MOVING);
  ctx.TryCancel();
  while (reader->Read(&s)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
}

TEST_F(WatchApiTest, WatchDrives_BadRequest_RefusedWithTheCoreStatus) {
  auto stub = GrpcStub();
  {
    grpc::ClientContext ctx;
    Deadline(ctx, 20s);
    auto reader = stub->WatchDrives(&ctx, Request("drives/lin1", -1));
    v1::DriveStatus s;
    EXPECT_FALSE(reader->Read(&s));
    grpc::Status st = reader->Finish();
    EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(st.error_message().find("max_rate_hz"), std::string::npos) << st.error_message();
  }
  {
    grpc::ClientContext ctx;
    Deadline(ctx, 20s);
    auto reader = stub->WatchDrives(&ctx, Request("drives/nope", 10));
    v1::DriveStatus s;
    EXPECT_FALSE(reader->Read(&s));
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::NOT_FOUND);
  }
}

TEST_F(WatchApiTest, WatchDrives_Deadline_EndsTheStream) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  Deadline(ctx, 300ms);
  auto reader = stub->WatchDrives(&ctx, Request("drives/lin2", 50));
  v1::DriveStatus s;
  int n = 0;
  while (reader->Read(&s)) ++n;
  EXPECT_EQ(n, 1) << "nothing changed after the first snapshot";
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

TEST_F(WatchApiTest, WatchDrives_CoreShutdown_EndsEveryStreamOk) {
  auto stub = GrpcStub();
  constexpr int kStreams = 20;
  std::vector<std::unique_ptr<grpc::ClientContext>> ctxs;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::DriveStatus>>> readers;
  for (int i = 0; i < kStreams; ++i) {
    ctxs.push_back(std::make_unique<grpc::ClientContext>());
    Deadline(*ctxs.back(), 20s);
    readers.push_back(stub->WatchDrives(ctxs.back().get(), Request("drives/lin1", 100)));
    v1::DriveStatus s;
    ASSERT_TRUE(readers.back()->Read(&s));
  }
  core_.Shutdown();  // server/ops shutdown: streams end before the gRPC server goes
  for (auto& r : readers) {
    v1::DriveStatus s;
    while (r->Read(&s)) {
    }
    grpc::Status st = r->Finish();
    EXPECT_TRUE(st.ok()) << st.error_message();
  }
  // A stream opened after shutdown is refused.
  grpc::ClientContext ctx;
  Deadline(ctx, 20s);
  auto late = stub->WatchDrives(&ctx, Request("drives/lin1", 100));
  v1::DriveStatus s;
  EXPECT_FALSE(late->Read(&s));
  EXPECT_EQ(late->Finish().error_code(), grpc::StatusCode::UNAVAILABLE);
}

}  // namespace
}  // namespace drivegw::server::test_support
