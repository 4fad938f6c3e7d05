// WatchStream and WatchTicker (issue 10, P5; decision 1341): one write in flight per stream, a
// slow stream skipped and then given the latest snapshot (no backlog), cancellation and shutdown
// finishing only once no write is in flight, and a shared ticker whose slow clients do not hold
// back the others.
#include "server/core/watch_stream.h"

#include <gtest/gtest.h>
#include <pthread.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "server/core/watch_ticker.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;

SharedDriveStatus Snap(const std::string& name, uint64_t sequence) {
  auto s = std::make_shared<v1::DriveStatus>();
  s->set_name(name);
  s->set_sequence(sequence);
  return s;
}

// A source the test feeds, like drives publishing status: a newer snapshot of a drive replaces an
// unsent one; each Next hands out the drives published since the last one, in publishing order.
class QueueSource final : public WatchSource {
 public:
  void Push(SharedDriveStatus s) {
    std::lock_guard lock(mu_);
    for (auto& q : queued_) {
      if (q->name() == s->name()) {
        q = std::move(s);
        return;
      }
    }
    queued_.push_back(std::move(s));
  }
  void End() { ended_ = true; }
  int polls() const { return polls_; }

  void Next(std::vector<SharedDriveStatus>& out) override {
    std::lock_guard lock(mu_);
    ++polls_;
    for (auto& s : queued_) out.push_back(std::move(s));
    queued_.clear();
  }
  bool Ended() const noexcept override { return ended_; }

 private:
  std::mutex mu_;
  std::vector<SharedDriveStatus> queued_;
  std::atomic<bool> ended_{false};
  std::atomic<int> polls_{0};
};

// A source with a new snapshot of one drive at every poll (a drive moving faster than the rate).
class EverChangingSource final : public WatchSource {
 public:
  void Next(std::vector<SharedDriveStatus>& out) override { out.push_back(Snap("x1", ++seq_)); }
  bool Ended() const noexcept override { return false; }

 private:
  uint64_t seq_ = 0;
};

// Records writes; completes them only when told (or at once with `auto_complete`).
class FakeOutput final : public WatchStream::Output {
 public:
  explicit FakeOutput(bool auto_complete = false) : auto_complete_(auto_complete) {}
  void Attach(WatchStream* stream) { stream_ = stream; }

  void StartWrite(const SharedDriveStatus& s) noexcept override {
    EXPECT_FALSE(in_flight_.exchange(true)) << "two writes in flight";
    EXPECT_FALSE(finished_.load()) << "write after Finish";
    {
      std::lock_guard lock(mu_);
      written_.push_back(s);
    }
    cv_.notify_all();
    if (auto_complete_) Complete(true);
  }
  void Finish(const absl::Status& s) noexcept override {
    EXPECT_FALSE(in_flight_.load()) << "Finish while a write is in flight";
    EXPECT_FALSE(finished_.exchange(true)) << "finished twice";
    std::lock_guard lock(mu_);
    status_ = s;
    cv_.notify_all();
  }
  // The transport reports the write done.
  void Complete(bool ok) {
    in_flight_ = false;
    stream_->WriteDone(ok);
  }

  std::vector<uint64_t> sequences() {
    std::lock_guard lock(mu_);
    std::vector<uint64_t> out;
    for (const auto& s : written_) out.push_back(s->sequence());
    return out;
  }
  size_t writes() {
    std::lock_guard lock(mu_);
    return written_.size();
  }
  bool WaitForWrites(size_t n, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return written_.size() >= n; });
  }
  bool finished() const { return finished_.load(); }
  bool in_flight() const { return in_flight_.load(); }
  std::optional<absl::Status> status() {
    std::lock_guard lock(mu_);
    return status_;
  }

 private:
  const bool auto_complete_;
  WatchStream* stream_ = nullptr;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<SharedDriveStatus> written_;
  std::optional<absl::Status> status_;
  std::atomic<bool> in_flight_{false};
  std::atomic<bool> finished_{false};
};

struct Fixture {
  explicit Fixture(bool auto_complete = false) : out(auto_complete) {
    auto src = std::make_unique<QueueSource>();
    source = src.get();
    stream = std::make_shared<WatchStream>(std::move(src), &out);
    out.Attach(stream.get());
  }
  FakeOutput out;
  QueueSource* source;
  std::shared_ptr<WatchStream> stream;
};

TEST(WatchStreamTest, Tick_NothingChanged_WritesNothing) {
  Fixture f;
  EXPECT_TRUE(f.stream->Tick());
  EXPECT_EQ(f.out.writes(), 0u);
  EXPECT_EQ(f.source->polls(), 1);
}

TEST(WatchStreamTest, Tick_OneSnapshotPerTick_RateIsTheTickRate) {
  Fixture f(/*auto_complete=*/true);
  auto src = std::make_unique<EverChangingSource>();
  FakeOutput out(true);
  auto stream = std::make_shared<WatchStream>(std::move(src), &out);
  out.Attach(stream.get());
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(stream->Tick());
  // The drive changed far more often than it was polled: one message per tick, never more.
  EXPECT_EQ(out.sequences(), (std::vector<uint64_t>{1, 2, 3, 4, 5}));
}

TEST(WatchStreamTest, Tick_WriteInFlight_MadeUpWithTheLatestOnCompletion) {
  Fixture f;
  f.source->Push(Snap("x1", 1));
  f.stream->Tick();
  ASSERT_TRUE(f.out.in_flight());
  // The consumer is slow: three snapshots arrive, and three ticks pass, while its write is in
  // flight.
  for (uint64_t seq = 2; seq <= 4; ++seq) {
    f.source->Push(Snap("x1", seq));
    f.stream->Tick();
  }
  EXPECT_EQ(f.source->polls(), 1) << "a busy stream is not polled";
  EXPECT_EQ(f.out.writes(), 1u);
  // The missed ticks are made up by one poll when the write completes: the latest snapshot only
  // (decision 504 item 5), 2 and 3 are never sent and nothing is queued.
  f.out.Complete(true);
  EXPECT_EQ(f.out.sequences(), (std::vector<uint64_t>{1, 4}));
  EXPECT_EQ(f.source->polls(), 2);
  f.out.Complete(true);
  EXPECT_EQ(f.source->polls(), 2) << "no tick was missed during the second write";
  f.stream->Tick();
  EXPECT_EQ(f.out.writes(), 2u) << "nothing new published";
}

TEST(WatchStreamTest, Tick_SeveralDrivesChanged_WritesEachBackToBack) {
  Fixture f;
  f.source->Push(Snap("x1", 1));
  f.source->Push(Snap("x2", 1));
  f.stream->Tick();
  EXPECT_EQ(f.out.writes(), 1u);
  f.out.Complete(true);  // the second drive's snapshot follows on completion, not on a tick
  EXPECT_EQ(f.out.writes(), 2u);
  f.out.Complete(true);
  EXPECT_EQ(f.source->polls(), 1);
}

TEST(WatchStreamTest, Cancel_WriteInFlight_FinishesAfterTheWrite) {
  Fixture f;
  f.source->Push(Snap("x1", 1));
  f.stream->Tick();
  f.stream->Cancel();
  EXPECT_FALSE(f.out.finished()) << "Finish must wait for the write in flight";
  f.out.Complete(false);
  EXPECT_TRUE(f.out.finished());
  ASSERT_TRUE(f.out.status().has_value());
  EXPECT_EQ(f.out.status()->code(), absl::StatusCode::kCancelled);
  f.source->Push(Snap("x1", 2));
  EXPECT_FALSE(f.stream->Tick()) << "the ticker drops a finished stream";
  EXPECT_EQ(f.out.writes(), 1u);
}

TEST(WatchStreamTest, WriteDone_NotOk_FinishesWithoutCancel) {
  Fixture f;
  f.source->Push(Snap("x1", 1));
  f.source->Push(Snap("x2", 1));
  f.stream->Tick();
  f.out.Complete(false);  // the client is gone
  EXPECT_TRUE(f.out.finished());
  EXPECT_EQ(f.out.status()->code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(f.out.writes(), 1u);
}

TEST(WatchStreamTest, Tick_SourceEnded_FinishesOk) {
  Fixture f;
  f.source->End();
  EXPECT_FALSE(f.stream->Tick());
  EXPECT_TRUE(f.out.finished());
  EXPECT_TRUE(f.out.status()->ok());
}

TEST(WatchStreamTest, Tick_SourceEndedDuringWrite_FinishesAfterTheWrite) {
  Fixture f;
  f.source->Push(Snap("x1", 1));
  f.source->Push(Snap("x2", 1));
  f.stream->Tick();
  f.source->End();
  EXPECT_TRUE(f.stream->Tick());
  EXPECT_FALSE(f.out.finished());
  f.out.Complete(true);
  EXPECT_TRUE(f.out.finished()) << "shutdown ends the stream, the queued snapshot is not sent";
  EXPECT_EQ(f.out.writes(), 1u);
}

TEST(WatchStreamTest, Detach_ThenTick_NeverCallsTheOutput) {
  Fixture f;
  f.stream->Detach();
  f.source->Push(Snap("x1", 1));
  EXPECT_FALSE(f.stream->Tick());
  f.stream->Cancel();
  EXPECT_EQ(f.out.writes(), 0u);
  EXPECT_FALSE(f.out.finished());
}

// A client that counts its ticks and ends after `limit` of them.
class CountingClient final : public WatchTicker::Client {
 public:
  explicit CountingClient(int limit) : limit_(limit) {}
  bool Tick() noexcept override { return ++ticks_ < limit_; }
  int ticks() const { return ticks_; }

 private:
  const int limit_;
  std::atomic<int> ticks_{0};
};

bool WaitUntil(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

TEST(WatchTickerTest, Add_ClientReturnsFalse_IsDropped) {
  WatchTicker ticker(1);
  auto c = std::make_shared<CountingClient>(3);
  ticker.Add(1ms, c);
  EXPECT_EQ(ticker.clients(), 1u);
  ASSERT_TRUE(WaitUntil([&] { return ticker.clients() == 0; }, 10s));
  EXPECT_EQ(c->ticks(), 3) << "never ticked after returning false";
}

TEST(WatchTickerTest, Add_TwoPeriods_EachTicksAtItsOwnRate) {
  WatchTicker ticker(1);
  auto fast = std::make_shared<CountingClient>(1 << 30);
  auto slow = std::make_shared<CountingClient>(1 << 30);
  ticker.Add(2ms, fast);
  ticker.Add(1h, slow);
  ASSERT_TRUE(WaitUntil([&] { return fast->ticks() >= 20; }, 20s));
  EXPECT_EQ(slow->ticks(), 0) << "a 1 h period is not due yet";
}

TEST(WatchTickerTest, SlowConsumer_DoesNotStallOthers) {
  WatchTicker ticker(1);
  FakeOutput stuck_out, fast_out(/*auto_complete=*/true);
  auto stuck = std::make_shared<WatchStream>(std::make_unique<EverChangingSource>(), &stuck_out);
  auto fast = std::make_shared<WatchStream>(std::make_unique<EverChangingSource>(), &fast_out);
  stuck_out.Attach(stuck.get());
  fast_out.Attach(fast.get());
  ticker.Add(2ms, stuck);
  ticker.Add(2ms, fast);
  // The stuck consumer never completes its write; the other keeps getting one message per tick.
  ASSERT_TRUE(fast_out.WaitForWrites(20, std::chrono::milliseconds(20000)));
  EXPECT_EQ(stuck_out.writes(), 1u);
  stuck->Detach();  // its transport goes away: the ticker drops it
  fast->Detach();
  ASSERT_TRUE(WaitUntil([&] { return ticker.clients() == 0; }, 10s));
}

// Per-thread CPU (/proc/<pid>/task/*/comm, top -H, perf) tells the ticks from gRPC's threads by
// this name (P5 CPU split, decision 1372).
class NameRecordingClient final : public WatchTicker::Client {
 public:
  bool Tick() noexcept override {
    char name[16] = {};
    ::pthread_getname_np(::pthread_self(), name, sizeof name);
    std::lock_guard lock(mu_);
    name_ = name;
    return false;
  }
  std::string name() {
    std::lock_guard lock(mu_);
    return name_;
  }

 private:
  std::mutex mu_;
  std::string name_;
};

TEST(WatchTickerTest, Tick_RunsOnAThreadNamedWatchTick) {
  WatchTicker ticker(2);
  auto c = std::make_shared<NameRecordingClient>();
  ticker.Add(1ms, c);
  ASSERT_TRUE(WaitUntil([&] { return !c->name().empty(); }, 10s));
  EXPECT_EQ(c->name(), "watch_tick");
}

TEST(WatchTickerTest, Destructor_WithClients_StopsWithoutTicking) {
  auto c = std::make_shared<CountingClient>(1 << 30);
  {
    WatchTicker ticker(2);
    ticker.Add(1h, c);
  }
  EXPECT_EQ(c->ticks(), 0);
  EXPECT_EQ(c.use_count(), 1) << "the ticker released its client";
}

}  // namespace
}  // namespace drivegw::server
