// The STOBER-era API on the real stack: a gRPC client streams cyclic set points
// (StreamCyclicSetpoints, client streaming, gRPC only) to a FakeDrive's cyclic channel, and the
// STOBER native command and raw CANopen SDO go through REST with base64 bytes
// (docs/decisions/008-cyclic-setpoint-stream.md).
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <thread>
#include <variant>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "tests/server/api/api_fixture.h"

namespace drivegw::server {
namespace {

using test_support::ApiRoundTripTest;
using test_support::FakeCyclicStream;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

v1::CyclicSetpointRequest Point(double value) {
  v1::CyclicSetpointRequest r;
  r.mutable_setpoint()->set_value(value);
  return r;
}

// google.rpc.Status from the error details: the BadRequest field and the summary, if present.
struct ErrorDetails {
  std::string field;
  std::optional<v1::CyclicStreamSummary> summary;
};
ErrorDetails DetailsOf(const grpc::Status& s) {
  ErrorDetails out;
  google::rpc::Status st;
  if (!st.ParseFromString(s.error_details())) return out;
  for (const auto& any : st.details()) {
    google::rpc::BadRequest br;
    v1::CyclicStreamSummary summary;
    if (any.UnpackTo(&br) && br.field_violations_size() > 0) {
      out.field = br.field_violations(0).field();
    } else if (any.UnpackTo(&summary)) {
      out.summary = summary;
    }
  }
  return out;
}

class StoberApiTest : public ApiRoundTripTest {
 protected:
  void SetUp() override {
    ApiRoundTripTest::SetUp();
    st1_.SetCyclic(true, FakeCyclicStream::Options{.late = 3, .missing = 5});
    st1_.SetState(DriveState::kEnabled);
  }
};

TEST_F(StoberApiTest, GrpcCyclicStream_100SetPoints_SummaryMatches) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first = Point(0);
  first.set_name("drives/st1");
  first.set_mode(v1::CYCLIC_POSITION);
  ASSERT_TRUE(writer->Write(first));
  for (int i = 1; i < 100; ++i) ASSERT_TRUE(writer->Write(Point(i * 0.5))) << i;
  ASSERT_TRUE(writer->WritesDone());
  grpc::Status s = writer->Finish();
  ASSERT_TRUE(s.ok()) << s.error_message();

  EXPECT_EQ(summary.name(), "drives/st1");
  EXPECT_EQ(summary.command().name(), "drives/st1/commands/7");
  EXPECT_EQ(summary.command().kind(), "CyclicPosition");
  EXPECT_EQ(summary.command().state(), v1::DONE);
  EXPECT_EQ(summary.stats().received(), 100u);
  EXPECT_EQ(summary.stats().sent(), 97u);
  EXPECT_EQ(summary.stats().late(), 3u);
  EXPECT_EQ(summary.stats().missing(), 5u);
  EXPECT_EQ(summary.stats().cycle_us(), 2000u);
  EXPECT_EQ(summary.state(), v1::ENABLED);

  auto rec = st1_.cyclic();
  ASSERT_TRUE(rec.has_value());
  ASSERT_EQ(rec->setpoints.size(), 100u);
  for (size_t i = 0; i < rec->setpoints.size(); ++i) {
    ASSERT_EQ(rec->setpoints[i].value, static_cast<double>(i) * 0.5) << i;
  }
  EXPECT_EQ(rec->closes, 1);
}

TEST_F(StoberApiTest, GrpcCyclicStream_VelocityMode_FirstMessageWithoutSetPoint) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first;
  first.set_name("st1");
  first.set_mode(v1::CYCLIC_VELOCITY);
  ASSERT_TRUE(writer->Write(first));
  ASSERT_TRUE(writer->Write(Point(-120)));
  ASSERT_TRUE(writer->Write(Point(40)));
  ASSERT_TRUE(writer->WritesDone());
  grpc::Status s = writer->Finish();
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(summary.command().kind(), "CyclicSpeed");
  EXPECT_EQ(summary.stats().received(), 2u);
  auto rec = st1_.cyclic();
  ASSERT_TRUE(rec.has_value());
  EXPECT_EQ(rec->mode, CyclicMode::kVelocity);
  ASSERT_EQ(rec->setpoints.size(), 2u);
  EXPECT_EQ(rec->setpoints[0].value, -120);
}

TEST_F(StoberApiTest, GrpcCyclicStream_OutOfRangeSetPoint_InvalidArgumentAfterClose) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first = Point(1);
  first.set_name("drives/st1");
  first.set_mode(v1::CYCLIC_POSITION);
  ASSERT_TRUE(writer->Write(first));
  for (int i = 1; i < 10; ++i) ASSERT_TRUE(writer->Write(Point(1 + i)));
  writer->Write(Point(150));  // beyond max_mm 100
  // Later writes may already fail: the server ends the call after the bad set point.
  for (int i = 0; i < 5 && writer->Write(Point(5)); ++i) {
  }
  writer->WritesDone();
  grpc::Status s = writer->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("setpoints[10].value: 150 exceeds axis max_mm 100"));
  ErrorDetails details = DetailsOf(s);
  EXPECT_EQ(details.field, "setpoints[10].value");
  ASSERT_TRUE(details.summary.has_value());
  EXPECT_EQ(details.summary->stats().received(), 10u);
  EXPECT_EQ(details.summary->command().state(), v1::DONE);
  auto rec = st1_.cyclic();
  ASSERT_TRUE(rec.has_value());
  EXPECT_EQ(rec->setpoints.size(), 10u);  // nothing after the bad one reached the drive
  EXPECT_EQ(rec->closes, 1);
}

TEST_F(StoberApiTest, GrpcCyclicStream_FamilyWithoutCyclicChannel_Unimplemented) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first = Point(1);
  first.set_name("drives/lin1");
  first.set_mode(v1::CYCLIC_POSITION);
  writer->Write(first);
  writer->WritesDone();
  grpc::Status s = writer->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNIMPLEMENTED) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("family 'linmot' has no cyclic set-point channel"));
}

TEST_F(StoberApiTest, GrpcCyclicStream_NoMessageAtAll_InvalidArgument) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  writer->WritesDone();
  grpc::Status s = writer->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_EQ(DetailsOf(s).field, "name");
  EXPECT_FALSE(st1_.cyclic().has_value());
}

TEST_F(StoberApiTest, GrpcCyclicStream_ClientCancels_CommandClosed) {
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::CyclicStreamSummary summary;
  auto writer = stub->StreamCyclicSetpoints(&ctx, &summary);
  v1::CyclicSetpointRequest first = Point(1);
  first.set_name("st1");
  first.set_mode(v1::CYCLIC_POSITION);
  ASSERT_TRUE(writer->Write(first));
  ASSERT_TRUE(writer->Write(Point(2)));
  // Both set points have reached the drive before the cancel (a poll with a deadline).
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((!st1_.cyclic() || st1_.cyclic()->setpoints.size() < 2) &&
         std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ctx.TryCancel();
  EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // Server::Shutdown waits for the reactor, whose End closed the command on the pool.
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(5));
  server_->Wait();
  server_.reset();
  auto rec = st1_.cyclic();
  ASSERT_TRUE(rec.has_value());
  EXPECT_EQ(rec->setpoints.size(), 2u);
  EXPECT_EQ(rec->closes, 1);
  EXPECT_FALSE(rec->destroyed_open);
}

TEST_F(StoberApiTest, RestStoberCommand_EnumByName_ReachesDrive) {
  const auto r = Post("/v1/drives/st1:sendNativeCommand", R"({"stober": {
      "command": "MC_MOVE_ABSOLUTE", "position_mm": 42.5, "velocity_mm_s": 100,
      "acceleration_mm_s2": 1000, "deceleration_mm_s2": 1000, "jerk_mm_s3": 20000,
      "direction": 1, "motion_id": 9}})");
  ASSERT_EQ(r.status, 200) << r.body;
  auto sent = st1_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* mc = std::get_if<StoberMcRequest>(&*sent);
  ASSERT_NE(mc, nullptr);
  EXPECT_EQ(mc->command, 1);
  EXPECT_EQ(mc->position_mm, 42.5);
  EXPECT_EQ(mc->jerk_mm_s3, 20000);
  EXPECT_EQ(mc->direction, 1);
  EXPECT_EQ(mc->motion_id, 9u);
  EXPECT_EQ(Json(r)["name"], "drives/st1");
}

TEST_F(StoberApiTest, RestStoberCommand_DirectionOutOfRange_400NamingTheField) {
  const auto r = Post("/v1/drives/st1:sendNativeCommand",
                      R"({"stober": {"command": "MC_MOVE_ABSOLUTE", "direction": 7}})");
  EXPECT_EQ(r.status, 400) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "stober.direction");
  EXPECT_FALSE(st1_.native().has_value());
}

TEST_F(StoberApiTest, RestCanOpenSdo_UploadReplyAndDownloadData_Base64) {
  NativeReply reply;
  reply.data = {0x01, 0x00, 0x00, 0x00};
  st1_.SetNativeReply(reply);
  // Upload I92 (305Ch/0): no data; the object's bytes come back base64 in `reply`.
  const auto up = Post("/v1/drives/st1:sendNativeCommand",
                       R"({"canopen_sdo": {"index": 12380, "sub_index": 0}})");
  ASSERT_EQ(up.status, 200) << up.body;
  EXPECT_EQ(Json(up)["reply"], "AQAAAA==");
  {
    const auto sent = st1_.native();
    ASSERT_TRUE(sent.has_value());
    const auto sdo = std::get<CanOpenSdoRequest>(*sent);
    EXPECT_EQ(sdo.index, 0x305C);
    EXPECT_FALSE(sdo.write);
  }
  // Download 6060h/0 = 8 (CSP): "CA==" is the byte 08.
  st1_.SetNativeReply({});
  const auto down = Post("/v1/drives/st1:sendNativeCommand",
                         R"({"canopen_sdo": {"index": 24672, "write": true, "data": "CA=="}})");
  ASSERT_EQ(down.status, 200) << down.body;
  const auto sent = st1_.native();
  ASSERT_TRUE(sent.has_value());
  const auto sdo = std::get<CanOpenSdoRequest>(*sent);
  EXPECT_EQ(sdo.index, 0x6060);
  EXPECT_TRUE(sdo.write);
  EXPECT_THAT(sdo.data, ElementsAre(0x08));
  EXPECT_EQ(Json(down)["reply"], "");
}

TEST_F(StoberApiTest, RestCanOpenSdo_WriteWithoutData_400) {
  const auto r = Post("/v1/drives/st1:sendNativeCommand",
                      R"({"canopen_sdo": {"index": 24672, "write": true}})");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(Json(r)["details"][0]["field_violations"][0]["field"], "canopen_sdo.data");
}

TEST_F(StoberApiTest, Rest_CyclicStreamHasNoRoute) {
  // Client streaming has no google.api.http transcoding, so no POST binding exists: the path only
  // matches GetDrive's GET /v1/{name=drives/*} template.
  const auto r = Post("/v1/drives/st1:streamCyclicSetpoints", R"({"mode": "CYCLIC_POSITION"})");
  EXPECT_EQ(r.status, 405) << r.body;
  EXPECT_THAT(Json(r)["message"].get<std::string>(),
              HasSubstr("method not allowed (allowed: GET)"));
  EXPECT_FALSE(st1_.cyclic().has_value());
}

}  // namespace
}  // namespace drivegw::server
