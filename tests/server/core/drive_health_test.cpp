// Decision 1431 at the service core: a DOWN drive is refused with UNAVAILABLE naming it, since
// when (RFC 3339 UTC) and why, before the family is called; DEMOTED/UP drives and drives without
// health go through; Stop is never refused; the refusal is audited like any other result.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "server/core/convert.h"
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
using ::testing::HasSubstr;

HealthInfo Down() {
  HealthInfo h;
  h.state = HealthState::kDown;
  h.since = std::chrono::sys_days{std::chrono::year{2026} / 12 / 7} + std::chrono::hours(5) +
            std::chrono::minutes(12) + std::chrono::seconds(3);
  h.consecutive_failures = 3;
  h.reason = "3 consecutive time-outs";
  return h;
}

class DriveHealthCoreTest : public ::testing::Test {
 protected:
  DriveHealthCoreTest() : x1_(fleet_.Add("x1", "linmot", false)) {}

  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    core_ = std::make_unique<DriveServiceCore>(fleet_.drives(), audit_.get());
  }

  absl::Status MoveAbsolute() {
    v1::MoveAbsoluteRequest r;
    r.set_name("drives/x1");
    r.set_position_mm(10);
    r.set_velocity_mm_s(10);
    r.set_acceleration_mm_s2(100);
    return core_->MoveAbsolute(r, ctx_).status();
  }

  FakeFleet fleet_;
  FakeDrive& x1_;
  CallContext ctx_{"alice", "ipv4:10.0.0.7:5555", "grpc"};
  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::unique_ptr<DriveServiceCore> core_;
};

TEST_F(DriveHealthCoreTest, Down_MoveRefusedUnavailableNamingDriveSinceAndCause) {
  x1_.SetHealthInfo(Down());
  absl::Status s = MoveAbsolute();
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(s.message(),
            "drive 'x1' is DOWN since 2026-12-07T05:12:03Z (3 consecutive time-outs): "
            "move_absolute refused");
  EXPECT_EQ(x1_.moves(), 0) << "the family was called for a DOWN drive";
  auto records = audit_->Query({});
  ASSERT_TRUE(records.ok());
  auto it = std::find_if(records->begin(), records->end(),
                         [](const storage::AuditRecord& a) { return a.action == "MoveAbsolute"; });
  ASSERT_NE(it, records->end());
  EXPECT_EQ(it->result_code, static_cast<int>(absl::StatusCode::kUnavailable));
  EXPECT_THAT(it->result_message, HasSubstr("is DOWN since"));
}

TEST_F(DriveHealthCoreTest, Down_EveryCommandAndParameterAccessRefused) {
  x1_.SetHealthInfo(Down());
  v1::EnableRequest e;
  e.set_name("drives/x1");
  EXPECT_THAT(std::string(core_->Enable(e, ctx_).status().message()),
              HasSubstr(": enable refused"));
  v1::HomeRequest h;
  h.set_name("x1");
  EXPECT_EQ(core_->Home(h, ctx_).status().code(), absl::StatusCode::kUnavailable);
  v1::AcknowledgeFaultRequest a;
  a.set_name("x1");
  EXPECT_THAT(std::string(core_->AcknowledgeFault(a, ctx_).status().message()),
              HasSubstr("acknowledge_fault refused"));
  v1::ReadParameterRequest rp;
  rp.set_name("x1");
  rp.set_parameter_id(0x1450);
  absl::Status read = core_->ReadParameter(rp, ctx_).status();
  EXPECT_EQ(read.code(), absl::StatusCode::kUnavailable) << read;
  v1::WriteParameterRequest wp;
  wp.set_name("x1");
  wp.set_parameter_id(0x1450);
  wp.set_value(1);
  absl::Status write = core_->WriteParameter(wp, ctx_).status();
  EXPECT_EQ(write.code(), absl::StatusCode::kUnavailable) << write;
  EXPECT_THAT(std::string(write.message()), HasSubstr("write_parameter refused"));
}

TEST_F(DriveHealthCoreTest, Down_StopStillReachesTheDrive) {
  x1_.SetHealthInfo(Down());
  v1::StopRequest r;
  r.set_name("x1");
  absl::StatusOr<v1::CommandHandle> h = core_->Stop(r, ctx_);
  EXPECT_TRUE(h.ok()) << h.status();
  EXPECT_EQ(x1_.moves(), 1);
}

// Decision 1491: a cyclic stream moves the axis like a move does, so a DOWN drive refuses it
// before the family's StartCyclic is called; nothing is started and the refusal is audited.
TEST_F(DriveHealthCoreTest, Down_CyclicStreamRefusedBeforeTheFamilyStartsIt) {
  x1_.SetCyclic(true);
  x1_.SetHealthInfo(Down());
  v1::CyclicSetpointRequest first;
  first.set_name("drives/x1");
  first.set_mode(v1::CYCLIC_POSITION);
  auto stream = core_->StartCyclicSetpoints(first, ctx_);
  ASSERT_FALSE(stream.ok());
  EXPECT_EQ(stream.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(stream.status().message(),
            "drive 'x1' is DOWN since 2026-12-07T05:12:03Z (3 consecutive time-outs): "
            "stream_cyclic_setpoints refused");
  EXPECT_EQ(x1_.calls(), 0) << "StartCyclic reached the family of a DOWN drive";
  EXPECT_FALSE(x1_.cyclic().has_value());
  auto records = audit_->Query({});
  ASSERT_TRUE(records.ok());
  auto it = std::find_if(records->begin(), records->end(), [](const storage::AuditRecord& a) {
    return a.action == kCyclicAuditAction;
  });
  ASSERT_NE(it, records->end());
  EXPECT_EQ(it->result_code, static_cast<int>(absl::StatusCode::kUnavailable));

  // The same stream starts once the drive is no longer DOWN.
  HealthInfo up = Down();
  up.state = HealthState::kUp;
  x1_.SetHealthInfo(up);
  stream = core_->StartCyclicSetpoints(first, ctx_);
  ASSERT_TRUE(stream.ok()) << stream.status();
  EXPECT_EQ(x1_.calls(), 1);
}

// Decision 1431, kept by 1491: native commands are diagnostics on a failing link, never refused.
TEST_F(DriveHealthCoreTest, Down_NativeCommandStillReachesTheDrive) {
  x1_.SetHealthInfo(Down());
  v1::SendNativeCommandRequest r;
  r.set_name("x1");
  r.mutable_linmot_rtc()->set_command_id(0x10);
  absl::StatusOr<v1::NativeCommandResponse> reply = core_->SendNativeCommand(r, ctx_);
  EXPECT_TRUE(reply.ok()) << reply.status();
  EXPECT_TRUE(x1_.native().has_value());
}

TEST_F(DriveHealthCoreTest, UpDemotedOrNoHealth_CallsGoThrough) {
  EXPECT_TRUE(MoveAbsolute().ok());  // no health reported (a family without supervision)
  HealthInfo h = Down();
  h.state = HealthState::kDemoted;
  x1_.SetHealthInfo(h);
  EXPECT_TRUE(MoveAbsolute().ok());
  h.state = HealthState::kUp;
  x1_.SetHealthInfo(h);
  EXPECT_TRUE(MoveAbsolute().ok());
  EXPECT_EQ(x1_.moves(), 3);
}

TEST_F(DriveHealthCoreTest, GetDrive_ReportsHealthStateSinceAndReason) {
  x1_.SetHealthInfo(Down());
  v1::GetDriveRequest r;
  r.set_name("drives/x1");
  auto d = core_->GetDrive(r, ctx_);
  ASSERT_TRUE(d.ok()) << d.status();
  ASSERT_TRUE(d->status().has_health());
  EXPECT_EQ(d->status().health().state(), v1::DOWN);
  EXPECT_EQ(
      d->status().health().since().seconds(),
      std::chrono::duration_cast<std::chrono::seconds>(Down().since.time_since_epoch()).count());
  EXPECT_EQ(d->status().health().consecutive_failures(), 3u);
  EXPECT_EQ(d->status().health().reason(), "3 consecutive time-outs");
  x1_.SetHealthInfo(std::nullopt);
  d = core_->GetDrive(r, ctx_);
  ASSERT_TRUE(d.ok());
  EXPECT_FALSE(d->status().has_health());
}

}  // namespace
}  // namespace drivegw::server
