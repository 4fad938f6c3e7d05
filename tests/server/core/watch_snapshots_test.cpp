// WatchSnapshots (issue 10, P5): one conversion per drive snapshot for every watch stream, rebuilt
// for a new sequence or once older than the stream's period, never replaced by an older sequence.
#include "server/core/watch_snapshots.h"

#include <gtest/gtest.h>

#include <chrono>

#include "tests/server/core/fake_drive.h"

namespace drivegw::server {
namespace {

using test_support::FakeDrive;
using namespace std::chrono_literals;

DriveStatus At(uint64_t sequence, double position_mm) {
  DriveStatus s;
  s.sequence = sequence;
  s.position_mm = position_mm;
  return s;
}

// A conversion that counts its calls and carries the link counter it was built with.
struct Builder {
  int calls = 0;
  uint64_t requests = 0;
  v1::DriveStatus operator()(const DriveStatus& s) {
    ++calls;
    v1::DriveStatus p;
    p.set_name("drives/x1");
    p.set_position_mm(s.position_mm);
    p.set_sequence(s.sequence);
    p.mutable_link()->set_requests(requests);
    return p;
  }
};

TEST(WatchSnapshotsTest, Get_SameSequence_SharesOneConversion) {
  FakeDrive drive(FakeDrive::Config("x1", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus s = At(7, 12.5);
  auto first = cache.Get(
      drive, s, [&] { return b(s); }, 1h);
  auto second = cache.Get(
      drive, s, [&] { return b(s); }, 1h);
  EXPECT_EQ(b.calls, 1);
  EXPECT_EQ(first.proto, second.proto);
  EXPECT_EQ(first.key, second.key);
  EXPECT_DOUBLE_EQ(second.proto->position_mm(), 12.5);
}

TEST(WatchSnapshotsTest, Get_NewSequence_Rebuilds) {
  FakeDrive drive(FakeDrive::Config("x1", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus s1 = At(1, 1.0), s2 = At(2, 2.0);
  auto a = cache.Get(
      drive, s1, [&] { return b(s1); }, 1h);
  auto c = cache.Get(
      drive, s2, [&] { return b(s2); }, 1h);
  EXPECT_EQ(b.calls, 2);
  EXPECT_NE(*a.key, *c.key);
  EXPECT_DOUBLE_EQ(c.proto->position_mm(), 2.0);
}

TEST(WatchSnapshotsTest, Get_KeyIgnoresSequenceAndLink_SameContentSameKey) {
  FakeDrive drive(FakeDrive::Config("x1", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus s1 = At(1, 5.0), s2 = At(2, 5.0);
  auto a = cache.Get(
      drive, s1, [&] { return b(s1); }, 1h);
  b.requests = 99;  // link counters moved on, position did not: not a new snapshot (decision 507)
  auto c = cache.Get(
      drive, s2, [&] { return b(s2); }, 1h);
  EXPECT_NE(a.key, c.key);
  EXPECT_EQ(*a.key, *c.key);
  EXPECT_EQ(c.proto->link().requests(), 99u);
}

TEST(WatchSnapshotsTest, Get_OlderSequence_DoesNotReplaceNewer) {
  FakeDrive drive(FakeDrive::Config("x1", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus newer = At(5, 5.0), older = At(4, 4.0);
  cache.Get(
      drive, newer, [&] { return b(newer); }, 1h);
  auto late = cache.Get(
      drive, older, [&] { return b(older); }, 1h);  // a slow stream's read
  EXPECT_DOUBLE_EQ(late.proto->position_mm(), 4.0);
  auto again = cache.Get(
      drive, newer, [&] { return b(newer); }, 1h);
  EXPECT_EQ(b.calls, 2);  // the newer entry stayed cached
  EXPECT_DOUBLE_EQ(again.proto->position_mm(), 5.0);
}

TEST(WatchSnapshotsTest, Get_OlderThanMaxAge_RebuildsForFreshLinkCounters) {
  FakeDrive drive(FakeDrive::Config("x1", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus s = At(3, 3.0);
  cache.Get(
      drive, s, [&] { return b(s); }, 1h);
  b.requests = 42;
  auto fresh = cache.Get(
      drive, s, [&] { return b(s); }, 0ns);  // any age is too old
  EXPECT_EQ(b.calls, 2);
  EXPECT_EQ(fresh.proto->link().requests(), 42u);
}

TEST(WatchSnapshotsTest, Get_TwoDrives_CachedApart) {
  FakeDrive x1(FakeDrive::Config("x1", "linmot"), false);
  FakeDrive x2(FakeDrive::Config("x2", "linmot"), false);
  WatchSnapshots cache;
  Builder b;
  const DriveStatus s1 = At(1, 1.0), s2 = At(1, 9.0);
  cache.Get(
      x1, s1, [&] { return b(s1); }, 1h);
  auto other = cache.Get(
      x2, s2, [&] { return b(s2); }, 1h);
  EXPECT_EQ(b.calls, 2);
  EXPECT_DOUBLE_EQ(other.proto->position_mm(), 9.0);
}

}  // namespace
}  // namespace drivegw::server
