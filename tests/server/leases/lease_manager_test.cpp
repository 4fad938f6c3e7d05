// LeaseManager on a ManualClock (expiry is injected time, never slept) and a fixed wall clock:
// conflicts name the holder and the expiry, the holder is told apart by principal or, when every
// caller is anonymous, by the lease id it presents; renew, release, expiry.
#include "server/core/lease_manager.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

CallContext Who(std::string principal, std::string lease_id = "") {
  CallContext c;
  c.principal = std::move(principal);
  c.lease_id = std::move(lease_id);
  return c;
}

class LeaseManagerTest : public ::testing::Test {
 protected:
  // 2026-11-27T16:00:00Z, frozen: the expiry a message names is this plus the ttl.
  static absl::Time Wall() { return absl::FromUnixSeconds(1795795200); }

  ManualClock clock_{TimePoint{} + 1h};
  LeaseManager leases_{clock_, &LeaseManagerTest::Wall};
};

TEST_F(LeaseManagerTest, Acquire_OtherPrincipal_FailedPreconditionNamingHolderAndExpiry) {
  auto lease = leases_.Acquire("x1", Who("mes-line-3"), 30s);
  ASSERT_TRUE(lease.ok()) << lease.status();
  EXPECT_EQ(lease->holder, "mes-line-3");
  EXPECT_EQ(lease->lease_id.size(), 32u);
  const absl::Status s = leases_.CheckControl("x1", Who("hmi-2"));
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.message(), "drive 'x1' is leased by 'mes-line-3' until 2026-11-27T16:00:30Z");
  EXPECT_EQ(leases_.Acquire("x1", Who("hmi-2"), 30s).status().message(), s.message());
  // The holder itself, with or without the id; other drives are free.
  EXPECT_TRUE(leases_.CheckControl("x1", Who("mes-line-3")).ok());
  EXPECT_TRUE(leases_.CheckControl("x1", Who("mes-line-3", lease->lease_id)).ok());
  EXPECT_TRUE(leases_.CheckControl("x2", Who("hmi-2")).ok());
  // A wrong id presented by the holder's principal is not the lease.
  EXPECT_EQ(leases_.CheckControl("x1", Who("mes-line-3", "0123")).code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(LeaseManagerTest, Anonymous_HolderIsWhoPresentsTheLeaseId) {
  auto lease = leases_.Acquire("x1", Who("anonymous"), 10s);
  ASSERT_TRUE(lease.ok()) << lease.status();
  const absl::Status other = leases_.CheckControl("x1", Who("anonymous"));
  EXPECT_EQ(other.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(other.message()), HasSubstr("leased by 'anonymous' until"));
  EXPECT_THAT(std::string(other.message()), HasSubstr("x-drivegw-lease"));
  EXPECT_TRUE(leases_.CheckControl("x1", Who("anonymous", lease->lease_id)).ok());
  // An empty principal counts as anonymous.
  EXPECT_TRUE(leases_.CheckControl("x1", Who("", lease->lease_id)).ok());
  // Acquire again with the id extends the same lease; without it, it is somebody else.
  clock_.Advance(5s);
  auto again = leases_.Acquire("x1", Who("anonymous", lease->lease_id), 20s);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->lease_id, lease->lease_id);
  EXPECT_EQ(leases_.Acquire("x1", Who("anonymous"), 20s).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(LeaseManagerTest, Expiry_OnTheInjectedClock) {
  auto lease = leases_.Acquire("x1", Who("a"), 30s);
  ASSERT_TRUE(lease.ok());
  clock_.Advance(29s);
  EXPECT_EQ(leases_.CheckControl("x1", Who("b")).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(leases_.List().size(), 1u);
  clock_.Advance(1s);
  EXPECT_TRUE(leases_.CheckControl("x1", Who("b")).ok());
  EXPECT_TRUE(leases_.List().empty());
  EXPECT_EQ(leases_.Renew(lease->lease_id, Who("a"), 30s).status().code(),
            absl::StatusCode::kNotFound);
  // Free for the next principal.
  EXPECT_TRUE(leases_.Acquire("x1", Who("b"), 30s).ok());
}

TEST_F(LeaseManagerTest, Renew_ExtendsFromNow) {
  auto lease = leases_.Acquire("x1", Who("a"), 30s);
  ASSERT_TRUE(lease.ok());
  clock_.Advance(20s);
  auto renewed = leases_.Renew(lease->lease_id, Who("a"), Duration::zero());  // keeps 30 s
  ASSERT_TRUE(renewed.ok()) << renewed.status();
  EXPECT_EQ(renewed->ttl, Duration(30s));
  clock_.Advance(20s);  // 40 s after the acquire, 20 s after the renew
  EXPECT_EQ(leases_.CheckControl("x1", Who("b")).code(), absl::StatusCode::kFailedPrecondition);
  clock_.Advance(10s);
  EXPECT_TRUE(leases_.CheckControl("x1", Who("b")).ok());
}

TEST_F(LeaseManagerTest, RenewAndRelease_OtherPrincipal_PermissionDenied) {
  auto lease = leases_.Acquire("x1", Who("a"), 30s);
  ASSERT_TRUE(lease.ok());
  const absl::Status renew = leases_.Renew(lease->lease_id, Who("b"), 30s).status();
  EXPECT_EQ(renew.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(std::string(renew.message()), HasSubstr("held by 'a', not by 'b'"));
  EXPECT_EQ(leases_.Release(lease->lease_id, Who("b")).status().code(),
            absl::StatusCode::kPermissionDenied);
  EXPECT_EQ(leases_.Release("nope", Who("a")).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(LeaseManagerTest, Release_FreesTheDriveAtOnce) {
  auto lease = leases_.Acquire("x1", Who("a"), 30s);
  ASSERT_TRUE(lease.ok());
  auto released = leases_.Release(lease->lease_id, Who("a"));
  ASSERT_TRUE(released.ok()) << released.status();
  EXPECT_EQ(released->drive, "x1");
  EXPECT_TRUE(leases_.CheckControl("x1", Who("b")).ok());
  EXPECT_EQ(leases_.Release(lease->lease_id, Who("a")).status().code(),
            absl::StatusCode::kNotFound);
}

// Gap 12 (docs/reliability.md): an unknown, released or expired lease id is NotFound naming the
// field and the id on Renew and Release; on a drive nobody leases, presenting an unknown id
// changes nothing (the id only tells a holder apart, decision 019).
TEST_F(LeaseManagerTest, UnknownLeaseId_NotFoundNamingIt) {
  EXPECT_EQ(leases_.Renew("nope", Who("mes-line-3"), 30s).status().message(),
            "lease_id: 'nope' is unknown, expired or released");
  EXPECT_EQ(leases_.Release("nope", Who("mes-line-3")).status().code(),
            absl::StatusCode::kNotFound);
  auto lease = leases_.Acquire("x1", Who("mes-line-3"), 30s);
  ASSERT_TRUE(lease.ok()) << lease.status();
  ASSERT_TRUE(leases_.Release(lease->lease_id, Who("mes-line-3")).ok());
  const absl::Status again = leases_.Renew(lease->lease_id, Who("mes-line-3"), 30s).status();
  EXPECT_EQ(again.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(again.message()), HasSubstr(lease->lease_id));
  EXPECT_TRUE(leases_.CheckControl("x1", Who("hmi-2", "nope")).ok());
}

TEST(CheckLease, NoManager_AlwaysOk) { EXPECT_TRUE(CheckLease(nullptr, "x1", Who("anyone")).ok()); }

}  // namespace
}  // namespace drivegw::server
