// DriveServiceCore::MoveCoordinated: the group reaches the first drive in request order, handles
// map back to their drives, every refusal names the field and the limit, families without
// interpolation answer UNIMPLEMENTED, and each call writes one audit entry.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "server/core/drive_service.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/server/core/core_test_support.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using test_support::FakeDrive;
using test_support::FakeFleet;
using test_support::ViolationField;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

v1::MoveCoordinatedRequest Request(std::vector<std::pair<std::string, double>> targets,
                                   double v = 50, double a = 500) {
  v1::MoveCoordinatedRequest r;
  for (auto& [name, pos] : targets) {
    auto* t = r.add_targets();
    t->set_name(name);
    t->set_position_mm(pos);
  }
  r.set_velocity_mm_s(v);
  r.set_acceleration_mm_s2(a);
  return r;
}

class MoveCoordinatedTest : public ::testing::Test {
 protected:
  MoveCoordinatedTest()
      : x_(fleet_.Add("feeder-x", "trinamic", true)),
        y_(fleet_.Add("feeder-y", "trinamic", true)),
        z_(fleet_.Add("feeder-z", "trinamic", true)),
        lin_(fleet_.Add("lin1", "linmot", false)),
        lin2_(fleet_.Add("lin2", "linmot", false)) {}

  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    core_ = std::make_unique<DriveServiceCore>(fleet_.drives(), audit_.get());
  }

  absl::StatusOr<v1::MoveCoordinatedResponse> Call(const v1::MoveCoordinatedRequest& r) {
    return core_->MoveCoordinated(r, CallContext{"alice", "ipv4:10.0.0.7:5555", "grpc"});
  }

  // The calls' entries, without the hash chain's own (genesis anchor, decision 017).
  std::vector<storage::AuditRecord> AuditRecords() {
    auto records = audit_->Query({});
    EXPECT_TRUE(records.ok()) << records.status();
    std::vector<storage::AuditRecord> out;
    for (auto& r : records.ok() ? *records : std::vector<storage::AuditRecord>{}) {
      if (r.principal != storage::AuditLog::kSystemPrincipal) out.push_back(std::move(r));
    }
    return out;
  }

  FakeFleet fleet_;
  FakeDrive& x_;
  FakeDrive& y_;
  FakeDrive& z_;
  FakeDrive& lin_;
  FakeDrive& lin2_;
  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::unique_ptr<DriveServiceCore> core_;
};

TEST_F(MoveCoordinatedTest, Ok_FirstTargetGetsGroupInRequestOrder_HandlesMapToDrives) {
  // Request order y, x, z (not the configured order): y leads, and the group follows the request.
  auto resp =
      Call(Request({{"drives/feeder-y", 20}, {"drives/feeder-x", 10}, {"feeder-z", 30}}, 40, 400));
  ASSERT_TRUE(resp.ok()) << resp.status();
  auto call = y_.coordinated();
  ASSERT_TRUE(call.has_value());
  EXPECT_THAT(call->group, ElementsAre("feeder-y", "feeder-x", "feeder-z"));
  EXPECT_THAT(call->move.positions_mm, ElementsAre(20, 10, 30));
  EXPECT_EQ(call->move.velocity_mm_s, 40);
  EXPECT_EQ(call->move.acceleration_mm_s2, 400);
  EXPECT_EQ(x_.calls(), 0);  // only the first drive runs the group
  EXPECT_EQ(z_.calls(), 0);
  ASSERT_EQ(resp->commands_size(), 3);
  EXPECT_EQ(resp->commands(0).name(), "drives/feeder-y/commands/100");
  EXPECT_EQ(resp->commands(1).name(), "drives/feeder-x/commands/101");
  EXPECT_EQ(resp->commands(2).name(), "drives/feeder-z/commands/102");
  EXPECT_EQ(resp->commands(1).kind(), "MoveCoordinated");
  EXPECT_EQ(resp->commands(1).state(), v1::ACTIVE);
}

TEST_F(MoveCoordinatedTest, Ok_PositionsAtBothAxisEnds_Accepted) {
  auto resp = Call(Request({{"feeder-x", 0}, {"feeder-y", 100}}, 500, 5000));
  EXPECT_TRUE(resp.ok()) << resp.status();
}

TEST_F(MoveCoordinatedTest, Audit_OneEntryNamingEveryDrive) {
  ASSERT_TRUE(Call(Request({{"drives/feeder-y", 20}, {"drives/feeder-x", 10}})).ok());
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].action, "MoveCoordinated");
  EXPECT_EQ(records[0].drive, "feeder-y,feeder-x");
  EXPECT_EQ(records[0].principal, "alice");
  EXPECT_EQ(records[0].result_code, 0);
  EXPECT_THAT(records[0].request_json, HasSubstr("\"position_mm\":20"));
}

TEST_F(MoveCoordinatedTest, Audit_RefusedCall_AlsoOneEntryWithTheCode) {
  auto resp = Call(Request({{"feeder-x", 10}, {"drives/nope", 10}}));
  ASSERT_EQ(resp.status().code(), absl::StatusCode::kNotFound);
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].drive, "feeder-x,drives/nope");  // unresolved names as given
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kNotFound));
}

TEST_F(MoveCoordinatedTest, OneTarget_InvalidArgumentNamingTargets) {
  auto resp = Call(Request({{"feeder-x", 10}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets");
  EXPECT_THAT(resp.status().message(), HasSubstr("at least 2"));
  EXPECT_EQ(x_.calls(), 0);
}

TEST_F(MoveCoordinatedTest, NoTargets_InvalidArgument) {
  auto resp = Call(Request({}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(resp.status().message(), HasSubstr("0 targets"));
}

TEST_F(MoveCoordinatedTest, DuplicateDrive_NamesDuplicateIndexAndFirstOccurrence) {
  // "feeder-x" and "drives/feeder-x" are the same drive.
  auto resp = Call(Request({{"drives/feeder-x", 10}, {"feeder-y", 10}, {"feeder-x", 20}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[2].name");
  EXPECT_THAT(resp.status().message(), HasSubstr("already targets[0]"));
  EXPECT_EQ(x_.calls(), 0);
}

TEST_F(MoveCoordinatedTest, UnknownDrive_NotFoundNamingTheTarget) {
  auto resp = Call(Request({{"feeder-x", 10}, {"drives/ghost", 10}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(resp.status().message(), HasSubstr("move_coordinated.targets[1].name"));
  EXPECT_THAT(resp.status().message(), HasSubstr("drives/ghost"));
}

TEST_F(MoveCoordinatedTest, MalformedName_InvalidArgument) {
  auto resp = Call(Request({{"feeder-x", 10}, {"drives/a/b", 10}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[1].name");
}

TEST_F(MoveCoordinatedTest, PositionBeyondAxis_OutOfRangeNamingTargetField) {
  auto resp = Call(Request({{"feeder-x", 10}, {"feeder-y", 100.5}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[1].position_mm");
  EXPECT_THAT(resp.status().message(), HasSubstr("exceeds axis max_mm 100"));
  EXPECT_EQ(y_.calls() + x_.calls(), 0);
}

TEST_F(MoveCoordinatedTest, PositionBelowAxis_OutOfRange) {
  auto resp = Call(Request({{"feeder-x", -1}, {"feeder-y", 10}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[0].position_mm");
  EXPECT_THAT(resp.status().message(), HasSubstr("below axis min_mm 0"));
}

TEST_F(MoveCoordinatedTest, PositionNaN_InvalidArgument) {
  auto resp = Call(Request({{"feeder-x", 1}, {"feeder-y", std::nan("")}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[1].position_mm");
  EXPECT_THAT(resp.status().message(), HasSubstr("not a finite number"));
}

TEST_F(MoveCoordinatedTest, VelocityZero_InvalidArgument) {
  auto resp = Call(Request({{"feeder-x", 1}, {"feeder-y", 2}}, 0, 500));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.velocity_mm_s");
  EXPECT_THAT(resp.status().message(), HasSubstr("must be greater than 0"));
}

TEST_F(MoveCoordinatedTest, AccelerationInfinite_InvalidArgument) {
  auto resp = Call(
      Request({{"feeder-x", 1}, {"feeder-y", 2}}, 50, std::numeric_limits<double>::infinity()));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.acceleration_mm_s2");
}

class MoveCoordinatedLimitsTest : public MoveCoordinatedTest {
 protected:
  // feeder-slow: max 200 mm/s, 1000 mm/s²; the other axes allow 500 and 5000.
  MoveCoordinatedLimitsTest() : slow_(fleet_.AddConfig(SlowConfig(), true)) {}
  static DriveConfig SlowConfig() {
    DriveConfig c = FakeDrive::Config("feeder-slow", "trinamic");
    c.axis.max_velocity_mm_s = 200;
    c.axis.max_acceleration_mm_s2 = 1000;
    return c;
  }
  FakeDrive& slow_;
};

TEST_F(MoveCoordinatedLimitsTest, VelocityAboveAnyMembersMax_OutOfRangeNamingThatMember) {
  // The leading axis allows 500 mm/s; the second target's axis only 200.
  auto resp = Call(Request({{"feeder-x", 1}, {"drives/feeder-slow", 2}}, 300, 500));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.velocity_mm_s");
  EXPECT_THAT(resp.status().message(),
              HasSubstr("300 exceeds max_velocity_mm_s 200 of targets[1] (drives/feeder-slow)"));
  EXPECT_EQ(x_.calls(), 0);
}

TEST_F(MoveCoordinatedLimitsTest, AccelerationAboveAnyMembersMax_OutOfRangeNamingThatMember) {
  auto resp = Call(Request({{"feeder-slow", 1}, {"feeder-x", 2}, {"feeder-y", 3}}, 100, 1500));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.acceleration_mm_s2");
  EXPECT_THAT(resp.status().message(),
              HasSubstr("exceeds max_acceleration_mm_s2 1000 of targets[0] (feeder-slow)"));
}

TEST_F(MoveCoordinatedLimitsTest, DynamicsAtTheLowestMembersMax_Accepted) {
  auto resp = Call(Request({{"feeder-x", 1}, {"feeder-slow", 2}}, 200, 1000));
  ASSERT_TRUE(resp.ok()) << resp.status();
  EXPECT_EQ(x_.calls(), 1);
}

TEST_F(MoveCoordinatedTest, MixedFamilies_InvalidArgumentNamingBoth) {
  auto resp = Call(Request({{"feeder-x", 1}, {"lin1", 2}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "move_coordinated.targets[1].name");
  EXPECT_THAT(resp.status().message(), HasSubstr("drives/lin1 is a linmot drive"));
  EXPECT_THAT(resp.status().message(), HasSubstr("(drives/feeder-x) a trinamic drive"));
  EXPECT_EQ(x_.calls(), 0);
}

TEST_F(MoveCoordinatedTest, FamilyWithoutInterpolation_Unimplemented) {
  // The LinMot fakes keep Drive::MoveCoordinated's default.
  auto resp = Call(Request({{"lin1", 10}, {"lin2", 20}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kUnimplemented);
  EXPECT_THAT(resp.status().message(), HasSubstr("family 'linmot'"));
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kUnimplemented));
}

TEST_F(MoveCoordinatedTest, FamilyReturnsWrongHandleCount_Internal) {
  x_.SetHandleCount(1);
  auto resp = Call(Request({{"feeder-x", 10}, {"feeder-y", 20}}));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInternal);
  EXPECT_THAT(resp.status().message(), HasSubstr("1 command handles for a group of 2"));
}

}  // namespace
}  // namespace drivegw::server
