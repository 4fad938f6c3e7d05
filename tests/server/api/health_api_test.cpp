// Decision 1431 through both front ends: a DOWN drive is refused UNAVAILABLE (REST 503) with the
// message naming the drive, since when and why; the drive's health is in GetDrive's status
// (gRPC message and REST JSON).
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/server/api/api_fixture.h"

namespace drivegw::server {
namespace {

using test_support::ApiRoundTripTest;
using ::testing::HasSubstr;

constexpr char kDownMessage[] =
    "drive 'lin1' is DOWN since 2026-12-07T05:12:03Z (5 consecutive time-outs): move_absolute "
    "refused";

HealthInfo Down() {
  HealthInfo h;
  h.state = HealthState::kDown;
  h.since = std::chrono::sys_days{std::chrono::year{2026} / 12 / 7} + std::chrono::hours(5) +
            std::chrono::minutes(12) + std::chrono::seconds(3);
  h.consecutive_failures = 5;
  h.reason = "5 consecutive time-outs";
  return h;
}

class HealthApiTest : public ApiRoundTripTest {
 protected:
  rest::HttpResponse Get(std::string target) {
    auto sink = std::make_shared<rest::test_support::RecordingSink>();
    router_->Handle({"GET", std::move(target), "", "10.0.0.7:5555"}, sink);
    return sink->Response();
  }
};

TEST_F(HealthApiTest, Grpc_DownDrive_UnavailableNamingDriveAndSince) {
  lin1_.SetHealthInfo(Down());
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  v1::MoveAbsoluteRequest r;
  r.set_name("drives/lin1");
  r.set_position_mm(10);
  r.set_velocity_mm_s(10);
  r.set_acceleration_mm_s2(100);
  v1::CommandHandle h;
  grpc::Status s = stub->MoveAbsolute(&ctx, r, &h);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(s.error_message(), kDownMessage);
  EXPECT_EQ(lin1_.moves(), 0);
}

TEST_F(HealthApiTest, Rest_DownDrive_503NamingDriveAndSince) {
  lin1_.SetHealthInfo(Down());
  const auto r = Post("/v1/drives/lin1:moveAbsolute",
                      R"({"position_mm": 10, "velocity_mm_s": 10, "acceleration_mm_s2": 100})");
  EXPECT_EQ(r.status, 503) << r.body;
  EXPECT_EQ(Json(r)["message"], kDownMessage);
  EXPECT_EQ(lin1_.moves(), 0);
}

TEST_F(HealthApiTest, GetDrive_HealthInGrpcAndRestJson) {
  lin1_.SetHealthInfo(Down());
  auto stub = GrpcStub();
  grpc::ClientContext ctx;
  v1::GetDriveRequest g;
  g.set_name("drives/lin1");
  v1::Drive d;
  ASSERT_TRUE(stub->GetDrive(&ctx, g, &d).ok());
  EXPECT_EQ(d.status().health().state(), v1::DOWN);
  EXPECT_EQ(d.status().health().reason(), "5 consecutive time-outs");

  const auto r = Get("/v1/drives/lin1");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = Json(r);
  const auto& health = j["status"]["health"];
  EXPECT_EQ(health["state"], "DOWN") << r.body;
  EXPECT_EQ(health["since"], "2026-12-07T05:12:03Z") << r.body;
  EXPECT_EQ(health["consecutive_failures"], 5) << r.body;
  EXPECT_EQ(health["reason"], "5 consecutive time-outs") << r.body;
}

}  // namespace
}  // namespace drivegw::server
