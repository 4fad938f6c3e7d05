// DriveServiceCore::StartCyclicSetpoints and CyclicSetpointStream: the first message chooses the
// drive and the mode, every set point is checked against the axis (INVALID_ARGUMENT naming
// setpoints[i].value), an error closes the cyclic command before it is reported, the summary
// carries the drive's stats, and each stream writes exactly one audit entry
// (docs/decisions/008-cyclic-setpoint-stream.md).
#include "server/core/cyclic_stream.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "server/core/drive_service.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/server/core/core_test_support.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using test_support::FakeCyclicStream;
using test_support::FakeDrive;
using test_support::FakeFleet;
using test_support::ViolationField;
using ::testing::HasSubstr;

v1::CyclicSetpointRequest First(const std::string& drive, v1::CyclicMode mode) {
  v1::CyclicSetpointRequest r;
  r.set_name(drive);
  r.set_mode(mode);
  return r;
}

v1::CyclicSetpointRequest Point(double value, double feed_forward = 0) {
  v1::CyclicSetpointRequest r;
  r.mutable_setpoint()->set_value(value);
  r.mutable_setpoint()->set_velocity_mm_s(feed_forward);
  return r;
}

// The summary an ended-with-error stream carries as a payload.
std::optional<v1::CyclicStreamSummary> SummaryOf(const absl::Status& s) {
  auto payload =
      s.GetPayload(absl::string_view(kCyclicSummaryUrl.data(), kCyclicSummaryUrl.size()));
  if (!payload) return std::nullopt;
  v1::CyclicStreamSummary summary;
  if (!summary.ParseFromString(std::string(*payload))) return std::nullopt;
  return summary;
}

class CyclicStreamTest : public ::testing::Test {
 protected:
  CyclicStreamTest()
      : st_(fleet_.Add("st1", "stober", false)), lin_(fleet_.Add("lin1", "linmot", false)) {
    st_.SetCyclic(true, FakeCyclicStream::Options{.late = 1, .missing = 4});
    st_.SetState(DriveState::kEnabled);
  }

  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    core_ = std::make_unique<DriveServiceCore>(fleet_.drives(), audit_.get());
  }

  absl::StatusOr<std::unique_ptr<CyclicSetpointStream>> Start(const v1::CyclicSetpointRequest& r) {
    return core_->StartCyclicSetpoints(r, CallContext{"alice", "ipv4:10.0.0.7:5555", "grpc"});
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
  FakeDrive& st_;
  FakeDrive& lin_;
  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::unique_ptr<DriveServiceCore> core_;
};

TEST_F(CyclicStreamTest, Position_SetPointsReachDriveInOrder_SummaryFromTheDrive) {
  v1::CyclicSetpointRequest first = First("drives/st1", v1::CYCLIC_POSITION);
  first.mutable_setpoint()->set_value(10);
  auto stream = Start(first);
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->Next(Point(10.5, 250)).ok());
  // Later messages may repeat the drive (either spelling) and the mode.
  v1::CyclicSetpointRequest repeat = Point(11);
  repeat.set_name("st1");
  repeat.set_mode(v1::CYCLIC_POSITION);
  ASSERT_TRUE((*stream)->Next(repeat).ok());
  EXPECT_EQ((*stream)->accepted(), 3u);
  auto summary = (*stream)->End(absl::OkStatus());
  ASSERT_TRUE(summary.ok()) << summary.status();

  auto rec = st_.cyclic();
  ASSERT_TRUE(rec.has_value());
  EXPECT_EQ(rec->mode, CyclicMode::kPosition);
  ASSERT_EQ(rec->setpoints.size(), 3u);
  EXPECT_EQ(rec->setpoints[0].value, 10);
  EXPECT_EQ(rec->setpoints[1].value, 10.5);
  EXPECT_EQ(rec->setpoints[1].velocity_mm_s, 250);
  EXPECT_EQ(rec->setpoints[2].value, 11);
  EXPECT_EQ(rec->closes, 1);

  EXPECT_EQ(summary->name(), "drives/st1");
  EXPECT_EQ(summary->command().name(), "drives/st1/commands/7");
  EXPECT_EQ(summary->command().kind(), "CyclicPosition");
  EXPECT_EQ(summary->command().state(), v1::DONE);
  EXPECT_EQ(summary->stats().received(), 3u);
  EXPECT_EQ(summary->stats().sent(), 2u);
  EXPECT_EQ(summary->stats().late(), 1u);
  EXPECT_EQ(summary->stats().missing(), 4u);
  EXPECT_EQ(summary->stats().cycle_us(), 2000u);
  EXPECT_EQ(summary->state(), v1::ENABLED);
}

TEST_F(CyclicStreamTest, Audit_OneEntryWithStartAndSummary) {
  auto stream = Start(First("st1", v1::CYCLIC_VELOCITY));
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->Next(Point(-20)).ok());
  EXPECT_TRUE(AuditRecords().empty());  // written when the stream ends, once
  ASSERT_TRUE((*stream)->End(absl::OkStatus()).ok());
  stream->reset();
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].action, "StreamCyclicSetpoints");
  EXPECT_EQ(records[0].drive, "st1");
  EXPECT_EQ(records[0].principal, "alice");
  EXPECT_EQ(records[0].result_code, 0);
  EXPECT_THAT(records[0].request_json,
              HasSubstr("\"start\":{\"name\":\"st1\",\"mode\":\"CYCLIC_VELOCITY\"}"));
  EXPECT_THAT(records[0].request_json, HasSubstr("\"summary\":"));
  EXPECT_THAT(records[0].request_json, HasSubstr("\"received\":\"1\""));
}

TEST_F(CyclicStreamTest, PositionBeyondAxis_InvalidArgumentNamingIndex_CommandClosedFirst) {
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->Next(Point(1)).ok());
  ASSERT_TRUE((*stream)->Next(Point(2)).ok());
  absl::Status bad = (*stream)->Next(Point(100.5));
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);  // not OUT_OF_RANGE in a stream
  EXPECT_EQ(ViolationField(bad), "setpoints[2].value");
  EXPECT_THAT(bad.message(), HasSubstr("100.5 exceeds axis max_mm 100"));
  EXPECT_EQ(st_.cyclic()->setpoints.size(), 2u);  // the bad one never reached the drive

  auto ended = (*stream)->End(bad);
  EXPECT_EQ(ended.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(ended.status()), "setpoints[2].value");
  EXPECT_EQ(st_.cyclic()->closes, 1);
  auto summary = SummaryOf(ended.status());
  ASSERT_TRUE(summary.has_value());
  EXPECT_EQ(summary->stats().received(), 2u);
  EXPECT_EQ(summary->command().state(), v1::DONE);
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kInvalidArgument));
  EXPECT_THAT(records[0].result_message, HasSubstr("setpoints[2].value"));
}

TEST_F(CyclicStreamTest, PositionBelowAxis_AndNonFinite_Refused) {
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  absl::Status below = (*stream)->Next(Point(-0.1));
  EXPECT_EQ(ViolationField(below), "setpoints[0].value");
  EXPECT_THAT(below.message(), HasSubstr("is below axis min_mm 0"));
  absl::Status nan = (*stream)->Next(Point(std::nan("")));
  EXPECT_EQ(nan.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(nan.message(), HasSubstr("not a finite number"));
  absl::Status ff = (*stream)->Next(Point(5, std::numeric_limits<double>::infinity()));
  EXPECT_EQ(ViolationField(ff), "setpoints[0].velocity_mm_s");
  absl::Status fast_ff = (*stream)->Next(Point(5, -501));
  EXPECT_EQ(ViolationField(fast_ff), "setpoints[0].velocity_mm_s");
  EXPECT_THAT(fast_ff.message(), HasSubstr("exceeds axis max_velocity_mm_s 500"));
  EXPECT_TRUE(st_.cyclic()->setpoints.empty());
}

TEST_F(CyclicStreamTest, Velocity_MagnitudeAgainstAxisMax_FeedForwardRefused) {
  auto stream = Start(First("st1", v1::CYCLIC_VELOCITY));
  ASSERT_TRUE(stream.ok()) << stream.status();
  EXPECT_TRUE((*stream)->Next(Point(-500)).ok());  // signed; the limit is on |v|
  EXPECT_TRUE((*stream)->Next(Point(500)).ok());
  absl::Status fast = (*stream)->Next(Point(-500.5));
  EXPECT_EQ(fast.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(fast), "setpoints[2].value");
  EXPECT_THAT(fast.message(), HasSubstr("exceeds axis max_velocity_mm_s 500"));
  absl::Status ff = (*stream)->Next(Point(10, 10));
  EXPECT_EQ(ViolationField(ff), "setpoints[2].velocity_mm_s");
  EXPECT_THAT(ff.message(), HasSubstr("belongs to CYCLIC_POSITION"));
  EXPECT_EQ(st_.cyclic()->mode, CyclicMode::kVelocity);
  EXPECT_EQ(st_.cyclic()->setpoints.size(), 2u);
}

TEST_F(CyclicStreamTest, LaterMessage_WithoutSetPoint_OrAnotherDriveOrMode_Refused) {
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->Next(Point(3)).ok());
  v1::CyclicSetpointRequest empty;
  absl::Status missing = (*stream)->Next(empty);
  EXPECT_EQ(ViolationField(missing), "setpoints[1]");
  EXPECT_THAT(missing.message(), HasSubstr("every message after the first carries a set point"));
  v1::CyclicSetpointRequest other = Point(3);
  other.set_name("drives/lin1");
  absl::Status name = (*stream)->Next(other);
  EXPECT_EQ(ViolationField(name), "name");
  EXPECT_THAT(name.message(), HasSubstr("differs from the stream's drive drives/st1"));
  v1::CyclicSetpointRequest mode = Point(3);
  mode.set_mode(v1::CYCLIC_VELOCITY);
  EXPECT_EQ(ViolationField((*stream)->Next(mode)), "mode");
  EXPECT_EQ(st_.cyclic()->setpoints.size(), 1u);
}

TEST_F(CyclicStreamTest, FirstMessage_NoMode_InvalidArgument_NothingStarted_Audited) {
  auto stream = Start(First("st1", v1::CYCLIC_MODE_UNSPECIFIED));
  EXPECT_EQ(stream.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(stream.status()), "mode");
  EXPECT_THAT(stream.status().message(), HasSubstr("CYCLIC_POSITION or CYCLIC_VELOCITY"));
  EXPECT_FALSE(st_.cyclic().has_value());
  auto unknown = Start(First("st1", static_cast<v1::CyclicMode>(9)));
  EXPECT_THAT(unknown.status().message(), HasSubstr("9 is not a CyclicMode"));
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].action, "StreamCyclicSetpoints");
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kInvalidArgument));
  EXPECT_THAT(records[0].request_json, HasSubstr("\"start\":"));
}

TEST_F(CyclicStreamTest, FirstMessage_BadSetPoint_NeverStartsTheCommand) {
  v1::CyclicSetpointRequest first = First("st1", v1::CYCLIC_POSITION);
  first.mutable_setpoint()->set_value(250);
  auto stream = Start(first);
  EXPECT_EQ(stream.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(stream.status()), "setpoints[0].value");
  EXPECT_FALSE(st_.cyclic().has_value());
}

TEST_F(CyclicStreamTest, UnknownDrive_NotFound_MissingName_InvalidArgument) {
  auto ghost = Start(First("drives/ghost", v1::CYCLIC_POSITION));
  EXPECT_EQ(ghost.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(ghost.status().message(), HasSubstr("drives/ghost is not configured"));
  auto none = Start(First("", v1::CYCLIC_POSITION));
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(none.status()), "name");
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[1].drive, "drives/ghost");  // unresolved names as given (newest first)
}

TEST_F(CyclicStreamTest, FamilyWithoutCyclicChannel_Unimplemented) {
  auto stream = Start(First("lin1", v1::CYCLIC_VELOCITY));
  EXPECT_EQ(stream.status().code(), absl::StatusCode::kUnimplemented);
  EXPECT_THAT(stream.status().message(), HasSubstr("has no cyclic set-point channel"));
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].drive, "lin1");
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kUnimplemented));
}

TEST_F(CyclicStreamTest, DriveRefusesPush_ErrorReportedAfterClose) {
  st_.SetCyclic(true, FakeCyclicStream::Options{.fail_at = 2});
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->Next(Point(1)).ok());
  ASSERT_TRUE((*stream)->Next(Point(2)).ok());
  absl::Status fault = (*stream)->Next(Point(3));
  EXPECT_EQ(fault.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ((*stream)->accepted(), 2u);
  auto ended = (*stream)->End(fault);
  EXPECT_EQ(ended.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(ended.status().message(), HasSubstr("following error"));
  EXPECT_EQ(st_.cyclic()->closes, 1);
  ASSERT_TRUE(SummaryOf(ended.status()).has_value());
}

TEST_F(CyclicStreamTest, FirstSetPointRefusedByDrive_ClosedAndReported) {
  st_.SetCyclic(true, FakeCyclicStream::Options{.fail_at = 0});
  v1::CyclicSetpointRequest first = First("st1", v1::CYCLIC_POSITION);
  first.mutable_setpoint()->set_value(1);
  auto stream = Start(first);
  EXPECT_EQ(stream.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(st_.cyclic()->closes, 1);
  EXPECT_TRUE(SummaryOf(stream.status()).has_value());
  EXPECT_EQ(AuditRecords().size(), 1u);
}

TEST_F(CyclicStreamTest, EndTwice_FailedPrecondition_AuditOnce) {
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  ASSERT_TRUE((*stream)->End(absl::OkStatus()).ok());
  EXPECT_EQ((*stream)->End(absl::OkStatus()).status().code(),
            absl::StatusCode::kFailedPrecondition);
  stream->reset();
  EXPECT_EQ(st_.cyclic()->closes, 1);
  EXPECT_EQ(AuditRecords().size(), 1u);
}

TEST_F(CyclicStreamTest, DestroyedWithoutEnd_ClosedAndAuditedAsCancelled) {
  {
    auto stream = Start(First("st1", v1::CYCLIC_POSITION));
    ASSERT_TRUE(stream.ok()) << stream.status();
    ASSERT_TRUE((*stream)->Next(Point(4)).ok());
  }
  EXPECT_EQ(st_.cyclic()->closes, 1);
  EXPECT_FALSE(st_.cyclic()->destroyed_open);
  auto records = AuditRecords();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].result_code, static_cast<int>(absl::StatusCode::kCancelled));
}

TEST_F(CyclicStreamTest, Shutdown_NextSetPointUnavailable) {
  auto stream = Start(First("st1", v1::CYCLIC_POSITION));
  ASSERT_TRUE(stream.ok()) << stream.status();
  core_->Shutdown();
  EXPECT_EQ((*stream)->Next(Point(4)).code(), absl::StatusCode::kUnavailable);
  EXPECT_TRUE(st_.cyclic()->setpoints.empty());
  EXPECT_EQ(Start(First("st1", v1::CYCLIC_POSITION)).status().code(),
            absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace drivegw::server
