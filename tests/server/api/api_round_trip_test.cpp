// The new Trinamic-era API through both front ends on the real stack: REST router -> in-process
// gRPC -> DriveServiceGrpc -> DriveServiceCore -> FakeDrive, and a gRPC client over TCP.
// Covers POST /v1/drives:moveCoordinated (handles in request order, field-named refusals,
// UNIMPLEMENTED for LinMot) and a trinamic native command with base64 `params`/`reply`.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <limits>
#include <nlohmann/json.hpp>
#include <variant>

#include "tests/server/api/api_fixture.h"

namespace drivegw::server {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using json = nlohmann::json;
using test_support::ApiRoundTripTest;

TEST_F(ApiRoundTripTest, RestMoveCoordinated_Ok_HandlesInRequestOrder) {
  const auto r = Post("/v1/drives:moveCoordinated", R"({
      "targets": [{"name": "drives/feeder-y", "position_mm": 20},
                  {"name": "drives/feeder-x", "position_mm": 12.5}],
      "velocity_mm_s": 50, "acceleration_mm_s2": 500})");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = Json(r);
  ASSERT_EQ(j["commands"].size(), 2u);
  EXPECT_EQ(j["commands"][0]["name"], "drives/feeder-y/commands/100");
  EXPECT_EQ(j["commands"][1]["name"], "drives/feeder-x/commands/101");
  EXPECT_EQ(j["commands"][0]["kind"], "MoveCoordinated");
  EXPECT_EQ(j["commands"][0]["state"], "ACTIVE");
  auto call = y_.coordinated();
  ASSERT_TRUE(call.has_value());
  EXPECT_THAT(call->group, ElementsAre("feeder-y", "feeder-x"));
  EXPECT_THAT(call->move.positions_mm, ElementsAre(20, 12.5));
  EXPECT_EQ(call->move.velocity_mm_s, 50);
}

TEST_F(ApiRoundTripTest, RestMoveCoordinated_PositionBeyondAxis_400WithFieldViolation) {
  const auto r = Post("/v1/drives:moveCoordinated", R"({
      "targets": [{"name": "drives/feeder-x", "position_mm": 10},
                  {"name": "drives/feeder-y", "position_mm": 150}],
      "velocity_mm_s": 50, "acceleration_mm_s2": 500})");
  EXPECT_EQ(r.status, 400) << r.body;  // OUT_OF_RANGE
  const auto j = Json(r);
  ASSERT_EQ(j["details"].size(), 1u);
  EXPECT_EQ(j["details"][0]["@type"], "type.googleapis.com/google.rpc.BadRequest");
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"],
            "move_coordinated.targets[1].position_mm");
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("exceeds axis max_mm 100"));
  EXPECT_FALSE(x_.coordinated().has_value());
}

TEST_F(ApiRoundTripTest, RestMoveCoordinated_Duplicate_400NamingTheIndex) {
  const auto r = Post("/v1/drives:moveCoordinated", R"({
      "targets": [{"name": "drives/feeder-x", "position_mm": 10},
                  {"name": "feeder-x", "position_mm": 20}],
      "velocity_mm_s": 50, "acceleration_mm_s2": 500})");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(Json(r)["details"][0]["field_violations"][0]["field"],
            "move_coordinated.targets[1].name");
}

TEST_F(ApiRoundTripTest, RestMoveCoordinated_LinMot_501Unimplemented) {
  const auto r = Post("/v1/drives:moveCoordinated", R"({
      "targets": [{"name": "drives/lin1", "position_mm": 10}, {"name": "drives/lin2", "position_mm": 20}],
      "velocity_mm_s": 50, "acceleration_mm_s2": 500})");
  EXPECT_EQ(r.status, 501) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["code"], 12);  // google.rpc.Code UNIMPLEMENTED
  EXPECT_THAT(j["message"].get<std::string>(),
              HasSubstr("no coordinated (interpolated) multi-axis move"));
}

TEST_F(ApiRoundTripTest, RestMoveCoordinated_UnknownJsonField_400) {
  // Field names follow MoveAbsoluteRequest (position_mm), not "position".
  const auto r = Post("/v1/drives:moveCoordinated", R"({
      "targets": [{"name": "drives/feeder-x", "position": 10}, {"name": "drives/feeder-y", "position": 20}],
      "velocity_mm_s": 50, "acceleration_mm_s2": 500})");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_FALSE(x_.coordinated().has_value());
}

TEST_F(ApiRoundTripTest, RestTrinamicNative_Base64ParamsIn_Base64ReplyOut) {
  NativeReply reply;
  reply.data = {0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00};  // §6.3: motor 2 at -1234
  x_.SetNativeReply(reply);
  // $20 query position: P0 = motor 2, P1 = RA F0 -> bytes 02 F0 00 00 00 00 00 = "AvAAAAAAAA==".
  const auto r = Post("/v1/drives/feeder-x:sendNativeCommand",
                      R"({"trinamic": {"opcode": 32, "params": "AvAAAAAAAA=="}})");
  ASSERT_EQ(r.status, 200) << r.body;
  auto sent = x_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* req = std::get_if<TrinamicRequest>(&*sent);
  ASSERT_NE(req, nullptr);
  EXPECT_EQ(req->opcode, 0x20);
  EXPECT_THAT(req->params, ElementsAre(0x02, 0xF0, 0, 0, 0, 0, 0));
  const auto j = Json(r);
  EXPECT_EQ(j["name"], "drives/feeder-x");
  EXPECT_EQ(j["reply"], "IAIu+///AAA=");  // base64 of 20 02 2E FB FF FF 00 00
}

TEST_F(ApiRoundTripTest, RestTrinamicNative_ShortParams_400NamingTrinamicParams) {
  const auto r = Post("/v1/drives/feeder-x:sendNativeCommand",
                      R"({"trinamic": {"opcode": 32, "params": "AvA="}})");
  EXPECT_EQ(r.status, 400) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "trinamic.params");
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("2 bytes; exactly 7 are required"));
  EXPECT_FALSE(x_.native().has_value());
}

TEST_F(ApiRoundTripTest, RestTrinamicTunnel_Base64Data) {
  const auto r =
      Post("/v1/drives/feeder-x:sendNativeCommand", R"({"trinamic_tunnel": {"data": "QVQN"}})");
  ASSERT_EQ(r.status, 200) << r.body;
  auto sent = x_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* t = std::get_if<TrinamicTunnelRequest>(&*sent);
  ASSERT_NE(t, nullptr);
  EXPECT_THAT(t->data, ElementsAre('A', 'T', '\r'));
  EXPECT_EQ(Json(r)["reply"], "");
}

TEST_F(ApiRoundTripTest, GrpcMoveCoordinated_OkAndUnimplemented) {
  auto stub = GrpcStub();
  v1::MoveCoordinatedRequest req;
  auto* a = req.add_targets();
  a->set_name("drives/feeder-x");
  a->set_position_mm(5);
  auto* b = req.add_targets();
  b->set_name("drives/feeder-y");
  b->set_position_mm(6);
  req.set_velocity_mm_s(10);
  req.set_acceleration_mm_s2(100);
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::MoveCoordinatedResponse resp;
    grpc::Status s = stub->MoveCoordinated(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(resp.commands_size(), 2);
    EXPECT_EQ(resp.commands(0).name(), "drives/feeder-x/commands/100");
    EXPECT_EQ(resp.commands(1).name(), "drives/feeder-y/commands/101");
  }
  a->set_name("drives/lin1");
  b->set_name("drives/lin2");
  {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::MoveCoordinatedResponse resp;
    grpc::Status s = stub->MoveCoordinated(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNIMPLEMENTED) << s.error_message();
  }
}

// Gap 6: NaN and infinities reach MoveAbsolute as JSON strings over REST ("NaN", "Infinity",
// proto3 JSON) and as doubles over gRPC; both are refused at the server layer naming the field,
// and the drive is never called.
TEST_F(ApiRoundTripTest, MoveAbsolute_NonFinite_RefusedOnBothFrontEndsNamingTheField) {
  struct Case {
    const char* body;
    const char* field;
    const char* text;
  };
  const Case cases[] = {
      {R"({"position_mm": "NaN", "velocity_mm_s": 10, "acceleration_mm_s2": 100})",
       "move_absolute.position_mm", "nan is not a finite number"},
      {R"({"position_mm": "-Infinity", "velocity_mm_s": 10, "acceleration_mm_s2": 100})",
       "move_absolute.position_mm", "-inf is not a finite number"},
      {R"({"position_mm": 10, "velocity_mm_s": "Infinity", "acceleration_mm_s2": 100})",
       "move_absolute.velocity_mm_s", "inf is not a finite number"},
      {R"({"position_mm": 10, "velocity_mm_s": 10, "acceleration_mm_s2": "NaN"})",
       "move_absolute.acceleration_mm_s2", "nan is not a finite number"},
      {R"({"position_mm": 10, "velocity_mm_s": 10, "acceleration_mm_s2": 100,
           "deceleration_mm_s2": -5})",
       "move_absolute.deceleration_mm_s2", "-5 must not be negative"},
  };
  for (const Case& c : cases) {
    const auto r = Post("/v1/drives/lin1:moveAbsolute", c.body);
    EXPECT_EQ(r.status, 400) << c.body << " -> " << r.body;
    const auto j = Json(r);
    EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], c.field) << r.body;
    EXPECT_THAT(j["message"].get<std::string>(), HasSubstr(c.text)) << r.body;
  }
  auto stub = GrpcStub();
  v1::MoveAbsoluteRequest req;
  req.set_name("drives/lin1");
  req.set_position_mm(std::numeric_limits<double>::quiet_NaN());
  req.set_velocity_mm_s(10);
  req.set_acceleration_mm_s2(100);
  grpc::ClientContext ctx;
  v1::CommandHandle h;
  grpc::Status s = stub->MoveAbsolute(&ctx, req, &h);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(), "move_absolute.position_mm: nan is not a finite number");
  EXPECT_EQ(lin1_.moves(), 0);
}

// Gap 5: a native command request without any command is a 400 / INVALID_ARGUMENT naming the
// oneof `command`; nothing reaches the drive.
TEST_F(ApiRoundTripTest, SendNativeCommand_EmptyOneof_RefusedNamingCommand) {
  const auto r = Post("/v1/drives/lin1:sendNativeCommand", "{}");
  EXPECT_EQ(r.status, 400) << r.body;
  const auto j = Json(r);
  EXPECT_EQ(j["details"][0]["field_violations"][0]["field"], "command") << r.body;
  EXPECT_THAT(j["message"].get<std::string>(), HasSubstr("command: one of linmot_motion,"));
  auto stub = GrpcStub();
  v1::SendNativeCommandRequest req;
  req.set_name("drives/st1");
  grpc::ClientContext ctx;
  v1::NativeCommandResponse resp;
  grpc::Status s = stub->SendNativeCommand(&ctx, req, &resp);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("is required"));
  EXPECT_FALSE(lin1_.native().has_value());
  EXPECT_FALSE(st1_.native().has_value());
}

}  // namespace
}  // namespace drivegw::server
