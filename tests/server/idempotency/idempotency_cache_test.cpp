// IdempotencyCache and the RunIdempotent hook: first result returned for a retry, different body
// refused naming the key, concurrent retries wait for the first call (a latch holds it), refusals
// forgotten, TTL on a ManualClock, LRU bound, reads never recorded.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "drivegw/v1/drive.pb.h"
#include "server/core/idempotency.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr char kMove[] = "drivegw.v1.DriveService/MoveAbsolute";

CallContext Keyed(std::string key, std::string principal = "anonymous") {
  CallContext c;
  c.principal = std::move(principal);
  c.idempotency_key = std::move(key);
  return c;
}

v1::MoveAbsoluteRequest Move(double mm) {
  v1::MoveAbsoluteRequest r;
  r.set_name("drives/x1");
  r.set_position_mm(mm);
  return r;
}

// A "drive" that hands out command ids 1, 2, ... and counts its calls.
struct Counter {
  std::atomic<int> calls{0};
  absl::StatusOr<v1::CommandHandle> operator()() {
    v1::CommandHandle h;
    h.set_name("drives/x1/commands/" + std::to_string(++calls));
    return h;
  }
};

TEST(RunIdempotent, Retry_ReturnsFirstResultWithoutRunningAgain) {
  IdempotencyCache cache;
  Counter drive;
  const CallContext c = Keyed("k-1");
  auto first = RunIdempotent(&cache, kMove, Move(10), c, [&] { return drive(); });
  auto retry = RunIdempotent(&cache, kMove, Move(10), c, [&] { return drive(); });
  ASSERT_TRUE(first.ok() && retry.ok());
  EXPECT_EQ(retry->name(), first->name());
  EXPECT_EQ(drive.calls, 1);
  // No key, another key, another principal or another method: runs.
  EXPECT_TRUE(RunIdempotent(&cache, kMove, Move(10), Keyed(""), [&] { return drive(); }).ok());
  EXPECT_TRUE(RunIdempotent(&cache, kMove, Move(10), Keyed("k-2"), [&] { return drive(); }).ok());
  EXPECT_TRUE(
      RunIdempotent(&cache, kMove, Move(10), Keyed("k-1", "bob"), [&] { return drive(); }).ok());
  EXPECT_TRUE(RunIdempotent(&cache, "drivegw.v1.DriveService/MoveRelative", Move(10), c, [&] {
                return drive();
              }).ok());
  EXPECT_EQ(drive.calls, 5);
}

TEST(RunIdempotent, DifferentBody_InvalidArgumentNamingTheKey) {
  IdempotencyCache cache;
  Counter drive;
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(10), Keyed("k-1"), [&] { return drive(); }).ok());
  const absl::Status s =
      RunIdempotent(&cache, kMove, Move(20), Keyed("k-1"), [&] { return drive(); }).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()), HasSubstr("idempotency key 'k-1'"));
  EXPECT_THAT(std::string(s.message()), HasSubstr("MoveAbsolute"));
  EXPECT_EQ(drive.calls, 1);
}

// Decision 1452: a key longer than kMaxIdempotencyKeyBytes is refused before the call runs,
// naming the header and the limit; the limit itself is accepted; reads ignore keys entirely.
TEST(RunIdempotent, OversizedKey_InvalidArgumentNamingHeaderAndLimit) {
  IdempotencyCache cache;
  Counter drive;
  const std::string longest(kMaxIdempotencyKeyBytes, 'k');
  EXPECT_TRUE(RunIdempotent(&cache, kMove, Move(10), Keyed(longest), [&] { return drive(); }).ok());
  const absl::Status s = RunIdempotent(&cache, kMove, Move(10), Keyed(longest + "k"), [&] {
                           return drive();
                         }).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(std::string(s.message()), "Idempotency-Key: 257 bytes exceeds the limit of 256 bytes");
  EXPECT_EQ(drive.calls, 1);
  // Refused without a cache too: the limit belongs to the API, not to this gateway's cache.
  EXPECT_EQ(RunIdempotent(nullptr, kMove, Move(10), Keyed(longest + "k"), [&] { return drive(); })
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(RunIdempotent(&cache, "drivegw.v1.DriveService/GetDrive", Move(10),
                            Keyed(longest + "k"), [&] { return drive(); })
                  .ok());
  EXPECT_EQ(drive.calls, 2);
}

TEST(RunIdempotent, ConcurrentRetry_WaitsForTheFirstCall) {
  IdempotencyCache cache;
  std::mutex mu;
  std::condition_variable cv;
  bool release = false;
  std::atomic<int> calls{0};
  auto slow = [&]() -> absl::StatusOr<v1::CommandHandle> {
    ++calls;
    std::unique_lock lock(mu);
    cv.wait(lock, [&] { return release; });
    v1::CommandHandle h;
    h.set_name("drives/x1/commands/7");
    return h;
  };
  absl::StatusOr<v1::CommandHandle> a, b;
  std::thread first([&] { a = RunIdempotent(&cache, kMove, Move(10), Keyed("k"), slow); });
  // The first call is inside `slow` before the retry starts.
  while (calls.load() == 0) std::this_thread::yield();
  std::atomic<bool> second_done{false};
  std::thread second([&] {
    b = RunIdempotent(&cache, kMove, Move(10), Keyed("k"), slow);
    second_done = true;
  });
  EXPECT_FALSE(second_done.load());
  {
    std::lock_guard lock(mu);
    release = true;
  }
  cv.notify_all();
  first.join();
  second.join();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(b->name(), a->name());
  EXPECT_EQ(calls.load(), 1);
}

TEST(RunIdempotent, RefusalIsForgotten_EffectfulErrorIsKept) {
  IdempotencyCache cache;
  int calls = 0;
  auto refuse = [&]() -> absl::StatusOr<v1::CommandHandle> {
    ++calls;
    return absl::FailedPreconditionError("drive 'x1' is leased by 'a'");
  };
  EXPECT_FALSE(RunIdempotent(&cache, kMove, Move(1), Keyed("k"), refuse).ok());
  EXPECT_FALSE(RunIdempotent(&cache, kMove, Move(1), Keyed("k"), refuse).ok());
  EXPECT_EQ(calls, 2);  // the retry ran: nothing had happened
  auto timeout = [&]() -> absl::StatusOr<v1::CommandHandle> {
    ++calls;
    return absl::DeadlineExceededError("homing took too long");
  };
  EXPECT_EQ(RunIdempotent(&cache, kMove, Move(1), Keyed("t"), timeout).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(RunIdempotent(&cache, kMove, Move(1), Keyed("t"), timeout).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(calls, 3);  // the drive may have acted: the outcome is kept
}

TEST(RunIdempotent, ReadOnlyMethods_NeverRecorded) {
  IdempotencyCache cache;
  Counter drive;
  v1::GetDriveRequest get;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(RunIdempotent(&cache, "drivegw.v1.DriveService/GetCommand", get, Keyed("k"), [&] {
                  return drive();
                }).ok());
  }
  EXPECT_EQ(drive.calls, 2);
  EXPECT_EQ(cache.size(), 0u);
  EXPECT_TRUE(IsReadOnlyMethod("drivegw.v1.ParameterSetService/ListOperations"));
  EXPECT_FALSE(IsReadOnlyMethod("drivegw.v1.ParameterSetService/ApplyParameterSet"));
  EXPECT_FALSE(IsReadOnlyMethod("drivegw.v1.CurveSetService/RunCurve"));
}

TEST(IdempotencyCache, Ttl_OnTheInjectedClock) {
  ManualClock clock;
  IdempotencyCache cache(IdempotencyOptions{.ttl = 24h}, clock);
  Counter drive;
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("k"), [&] { return drive(); }).ok());
  clock.Advance(24h - 1s);
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("k"), [&] { return drive(); }).ok());
  EXPECT_EQ(drive.calls, 1);
  clock.Advance(1s);
  auto again = RunIdempotent(&cache, kMove, Move(1), Keyed("k"), [&] { return drive(); });
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->name(), "drives/x1/commands/2");
  EXPECT_EQ(drive.calls, 2);
}

TEST(IdempotencyCache, Lru_BoundedEntryCount) {
  IdempotencyCache cache(IdempotencyOptions{.max_entries = 3});
  Counter drive;
  for (const char* k : {"a", "b", "c"}) {
    ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed(k), [&] { return drive(); }).ok());
  }
  // "a" used again, so "b" is the least recently used when "d" arrives.
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("a"), [&] { return drive(); }).ok());
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("d"), [&] { return drive(); }).ok());
  EXPECT_EQ(cache.size(), 3u);
  EXPECT_EQ(drive.calls, 4);
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("a"), [&] { return drive(); }).ok());
  EXPECT_EQ(drive.calls, 4);  // still kept
  ASSERT_TRUE(RunIdempotent(&cache, kMove, Move(1), Keyed("b"), [&] { return drive(); }).ok());
  EXPECT_EQ(drive.calls, 5);  // evicted: ran again
}

}  // namespace
}  // namespace drivegw::server
