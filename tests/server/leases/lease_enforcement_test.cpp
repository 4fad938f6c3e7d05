// The one lease check (CheckLease) where the cores touch a drive: DriveServiceCore (motion,
// enable/disable, acknowledge, parameter writes, native commands, coordinated moves, cyclic
// streams; Stop stays open), CurveSetServiceCore (download, run), and LeaseServiceCore's checks.
// FakeDrives count the calls that reach them; leases expire on a ManualClock.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>

#include "server/core/curve_set_service.h"
#include "server/core/drive_service.h"
#include "server/core/lease_manager.h"
#include "server/core/lease_service.h"
#include "storage/curve_set_repo.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "tests/server/core/core_test_support.h"
#include "tests/server/curve_sets/curve_drive.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using test_support::FakeDrive;
using test_support::FakeFleet;
using ::testing::HasSubstr;

CallContext Who(std::string principal, std::string lease_id = "") {
  CallContext c;
  c.principal = std::move(principal);
  c.lease_id = std::move(lease_id);
  c.transport = "grpc";
  return c;
}

class LeaseEnforcementTest : public ::testing::Test {
 protected:
  LeaseEnforcementTest()
      : x_(fleet_.Add("feeder-x", "trinamic", true)),
        y_(fleet_.Add("feeder-y", "trinamic", true)),
        core_(fleet_.drives(), nullptr, &leases_),
        lease_core_(leases_, fleet_.drives(), nullptr) {}

  // mes-line-3 takes feeder-x for 30 s.
  std::string Lease() {
    v1::AcquireLeaseRequest r;
    r.set_name("drives/feeder-x");
    r.set_ttl_s(30);
    auto lease = lease_core_.AcquireLease(r, Who("mes-line-3"));
    EXPECT_TRUE(lease.ok()) << lease.status();
    return lease.ok() ? lease->lease_id() : "";
  }
  static void ExpectLeased(const absl::Status& s) {
    EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << s;
    EXPECT_THAT(std::string(s.message()), HasSubstr("drive 'feeder-x' is leased by 'mes-line-3'"));
    EXPECT_THAT(std::string(s.message()), HasSubstr("until 20"));
  }
  v1::MoveAbsoluteRequest Move() {
    v1::MoveAbsoluteRequest r;
    r.set_name("drives/feeder-x");
    r.set_position_mm(10);
    r.set_velocity_mm_s(100);
    r.set_acceleration_mm_s2(1000);
    r.set_deceleration_mm_s2(1000);
    return r;
  }

  ManualClock clock_;
  LeaseManager leases_{clock_};
  FakeFleet fleet_;
  FakeDrive& x_;
  FakeDrive& y_;
  DriveServiceCore core_;
  LeaseServiceCore lease_core_;
};

TEST_F(LeaseEnforcementTest, OtherPrincipal_EveryMutatingCallRefusedNamingTheHolder) {
  Lease();
  const CallContext other = Who("hmi-2");
  ExpectLeased(core_.MoveAbsolute(Move(), other).status());
  v1::EnableRequest en;
  en.set_name("feeder-x");
  ExpectLeased(core_.Enable(en, other).status());
  v1::DisableRequest dis;
  dis.set_name("feeder-x");
  ExpectLeased(core_.Disable(dis, other).status());
  v1::AcknowledgeFaultRequest ack;
  ack.set_name("feeder-x");
  ExpectLeased(core_.AcknowledgeFault(ack, other).status());
  v1::HomeRequest home;
  home.set_name("feeder-x");
  ExpectLeased(core_.Home(home, other).status());
  v1::MoveVelocityRequest vel;
  vel.set_name("feeder-x");
  vel.set_velocity_mm_s(10);
  vel.set_acceleration_mm_s2(100);
  ExpectLeased(core_.MoveVelocity(vel, other).status());
  v1::WriteParameterRequest wp;
  wp.set_name("feeder-x");
  wp.set_parameter_id(4);
  wp.set_value(100);
  ExpectLeased(core_.WriteParameter(wp, other).status());
  EXPECT_FALSE(x_.parameter_id().has_value());  // never reached the drive
  // A coordinated move with the leased drive anywhere in the group.
  v1::MoveCoordinatedRequest mc;
  for (const char* n : {"feeder-y", "feeder-x"}) {
    auto* t = mc.add_targets();
    t->set_name(n);
    t->set_position_mm(5);
  }
  mc.set_velocity_mm_s(100);
  mc.set_acceleration_mm_s2(1000);
  ExpectLeased(core_.MoveCoordinated(mc, other).status());
  // A cyclic stream never starts.
  x_.SetCyclic(true);
  v1::CyclicSetpointRequest first;
  first.set_name("feeder-x");
  first.set_mode(v1::CYCLIC_POSITION);
  ExpectLeased(core_.StartCyclicSetpoints(first, other).status());
  EXPECT_EQ(x_.calls(), 0);
  // Reads and the other drive stay open.
  v1::GetDriveRequest get;
  get.set_name("feeder-x");
  EXPECT_TRUE(core_.GetDrive(get, other).ok());
  v1::EnableRequest en_y;
  en_y.set_name("feeder-y");
  EXPECT_TRUE(core_.Enable(en_y, other).ok());
}

TEST_F(LeaseEnforcementTest, Stop_OpenToEverybody) {
  Lease();
  v1::StopRequest stop;
  stop.set_name("feeder-x");
  auto r = core_.Stop(stop, Who("hmi-2"));
  EXPECT_TRUE(r.ok()) << r.status();
}

TEST_F(LeaseEnforcementTest, Holder_Allowed_AndAnonymousNeedsTheId) {
  const std::string id = Lease();
  EXPECT_TRUE(core_.MoveAbsolute(Move(), Who("mes-line-3")).ok());
  // With auth disabled everybody is anonymous: only the id tells the holder apart.
  v1::AcquireLeaseRequest r;
  r.set_name("feeder-y");
  auto anon = lease_core_.AcquireLease(r, Who("anonymous"));
  ASSERT_TRUE(anon.ok()) << anon.status();
  v1::EnableRequest en;
  en.set_name("feeder-y");
  const absl::Status refused = core_.Enable(en, Who("anonymous")).status();
  EXPECT_EQ(refused.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(refused.message()), HasSubstr("leased by 'anonymous'"));
  EXPECT_TRUE(core_.Enable(en, Who("anonymous", anon->lease_id())).ok());
}

TEST_F(LeaseEnforcementTest, ReleaseAndExpiry_FreeTheDrive) {
  const std::string id = Lease();
  v1::ReleaseLeaseRequest rel;
  rel.set_lease_id(id);
  ASSERT_TRUE(lease_core_.ReleaseLease(rel, Who("mes-line-3")).ok());
  EXPECT_TRUE(core_.MoveAbsolute(Move(), Who("hmi-2")).ok());
  Lease();
  ExpectLeased(core_.MoveAbsolute(Move(), Who("hmi-2")).status());
  clock_.Advance(30s);
  EXPECT_TRUE(core_.MoveAbsolute(Move(), Who("hmi-2")).ok());
}

TEST_F(LeaseEnforcementTest, LeaseService_RequestChecksAndListWithoutIds) {
  v1::AcquireLeaseRequest r;
  r.set_name("drives/nope");
  EXPECT_EQ(lease_core_.AcquireLease(r, Who("a")).status().code(), absl::StatusCode::kNotFound);
  r.set_name("feeder-x");
  r.set_ttl_s(7200);
  const absl::Status ttl = lease_core_.AcquireLease(r, Who("a")).status();
  EXPECT_EQ(ttl.code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(test_support::ViolationField(ttl), "ttl_s");
  r.set_ttl_s(0);  // default 30 s
  auto lease = lease_core_.AcquireLease(r, Who("a"));
  ASSERT_TRUE(lease.ok()) << lease.status();
  EXPECT_DOUBLE_EQ(lease->ttl_s(), 30);
  EXPECT_EQ(lease->drive(), "drives/feeder-x");
  auto list = lease_core_.ListLeases({}, Who("b"));
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->leases_size(), 1);
  EXPECT_EQ(list->leases(0).holder(), "a");
  EXPECT_TRUE(list->leases(0).lease_id().empty());
  v1::RenewLeaseRequest renew;
  EXPECT_EQ(test_support::ViolationField(lease_core_.RenewLease(renew, Who("a")).status()),
            "lease_id");
  renew.set_lease_id(lease->lease_id());
  renew.set_ttl_s(60);
  auto renewed = lease_core_.RenewLease(renew, Who("a"));
  ASSERT_TRUE(renewed.ok()) << renewed.status();
  EXPECT_DOUBLE_EQ(renewed->ttl_s(), 60);
}

// CurveSetServiceCore checks the lease before it touches the drive (download and run).
TEST(CurveSetLeases, DownloadAndRun_OtherPrincipal_Refused) {
  storage::testing::TempDir dir;
  auto db = storage::Db::Open(dir.File("gw.db"));
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE(storage::Migrate(*db).ok());
  storage::CurveSetRepo repo(*db);
  auto x1 = std::make_shared<test_support::CurveDrive>("x1", "linmot", true, true);
  LeaseManager leases;
  CurveSetServiceCore core(repo, {x1}, nullptr, &leases);
  ASSERT_TRUE(leases.Acquire("x1", Who("mes-line-3"), 30s).ok());
  v1::RunCurveRequest run;
  run.set_drive("drives/x1");
  run.set_name("curveSets/press");
  run.set_curve("lift");
  const absl::Status r = core.RunCurve(run, Who("hmi-2")).status();
  EXPECT_EQ(r.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(r.message()), HasSubstr("drive 'x1' is leased by 'mes-line-3'"));
  v1::DownloadCurveRequest dl;
  dl.set_drive("x1");
  dl.set_name("press");
  dl.set_curve("lift");
  EXPECT_EQ(core.DownloadCurve(dl, Who("hmi-2")).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_TRUE(x1->runs().empty());
  EXPECT_TRUE(x1->downloads().empty());
  // The holder gets past the lease (to the missing set).
  EXPECT_EQ(core.RunCurve(run, Who("mes-line-3")).status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace drivegw::server
