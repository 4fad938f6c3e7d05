// LinMotUdpDrive::MoveAsync (decision 1301) over real loopback UDP against the simulated LinMot
// drive: the completion comes once, on the executor, with what Move would return — the ACTIVE
// handle, DeadlineExceeded without a count echo in time, Unavailable when the link drops,
// FailedPrecondition on deactivation — and a second operation waits for a pending one.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "adapters/core/clock.h"
#include "adapters/core/executor.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/server.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::linmot::linudp {
namespace {

using namespace std::chrono_literals;
using sim::linmot::LinMotServer;
using sim::linmot::SimOptions;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;  // bound for conditions that hold within a second

// One worker thread draining a queue: the executor the completions must run on.
class ThreadExecutor final : public Executor {
 public:
  ThreadExecutor() : thread_([this] { Run(); }) {}
  ~ThreadExecutor() override {
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void Post(std::function<void()> task) override {
    {
      std::lock_guard lock(mu_);
      queue_.push_back(std::move(task));
    }
    cv_.notify_all();
  }
  std::thread::id id() const { return thread_.get_id(); }

 private:
  void Run() {
    std::unique_lock lock(mu_);
    for (;;) {
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;
      auto task = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      task();
      lock.lock();
    }
  }
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  bool stopping_ = false;
  std::thread thread_;
};

// What one completion delivered, and on which thread; Wait blocks with a deadline.
class Completion {
 public:
  Drive::CommandCompletion Callback() {
    return [this](absl::StatusOr<CommandInfo> r) {
      std::lock_guard lock(mu_);
      ++calls_;
      result_ = std::move(r);
      thread_ = std::this_thread::get_id();
      cv_.notify_all();
    };
  }
  absl::StatusOr<CommandInfo> Wait() {
    std::unique_lock lock(mu_);
    if (!cv_.wait_for(lock, kWait, [&] { return result_.has_value(); })) {
      return absl::InternalError("test: no completion within 10 s");
    }
    return *result_;
  }
  int calls() const {
    std::lock_guard lock(mu_);
    return calls_;
  }
  std::thread::id thread() const {
    std::lock_guard lock(mu_);
    return thread_;
  }

 private:
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::optional<absl::StatusOr<CommandInfo>> result_;
  int calls_ = 0;
  std::thread::id thread_;
};

class LinMotUdpMoveAsyncTest : public ::testing::Test {
 protected:
  void Start(std::chrono::milliseconds reply_timeout = 30ms,
             std::chrono::milliseconds accept = 100ms) {
    SimOptions o = test_support::LinUdpSimOptions();
    auto server = LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    DriveConfig c = test_support::LinUdpDriveConfig(server_->port());
    c.timeouts.accept = accept;
    c.linudp->reply_timeout = reply_timeout;
    auto drive = CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::move(*drive);
    ASSERT_TRUE(drive_->Activate().ok());
  }
  void TearDown() override {
    if (drive_) drive_->Deactivate();
  }
  void EnableOrDie() {
    auto r = drive_->Enable();
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(r->state, CommandState::kDone);
  }
  CommandInfo WaitFinal(uint64_t id) { return test_support::WaitCommandFinal(*drive_, id, kWait); }

  ThreadExecutor executor_;
  std::unique_ptr<LinMotServer> server_;
  std::unique_ptr<Drive> drive_;
};

TEST_F(LinMotUdpMoveAsyncTest, Accepted_CompletesOnceWithActiveHandleOnTheExecutor) {
  Start();
  EnableOrDie();
  Completion done;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, done.Callback());
  absl::StatusOr<CommandInfo> r = done.Wait();
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->kind, "MoveAbsolute");
  EXPECT_EQ(r->state, CommandState::kActive);
  EXPECT_EQ(done.thread(), executor_.id());
  EXPECT_EQ(WaitFinal(r->id).state, CommandState::kDone);
  EXPECT_NEAR(server_->Snapshot().device.demand_position_mm, 60, 1e-3);
  EXPECT_EQ(done.calls(), 1);
}

TEST_F(LinMotUdpMoveAsyncTest, ManyInARow_EveryOneAcceptedAndTheLastOneDone) {
  Start();
  EnableOrDie();
  uint64_t last = 0;
  for (int i = 0; i < 20; ++i) {  // more than the 1..15 count ring (D-09)
    Completion done;
    drive_->MoveAsync(MoveAbsolute{i % 2 == 0 ? 40.0 : 60.0, 1000, 10000, 10000}, executor_,
                      done.Callback());
    absl::StatusOr<CommandInfo> r = done.Wait();
    ASSERT_TRUE(r.ok()) << "move " << i << ": " << r.status();
    EXPECT_EQ(r->state, CommandState::kActive);
    last = r->id;
  }
  EXPECT_EQ(WaitFinal(last).state, CommandState::kDone);
}

TEST_F(LinMotUdpMoveAsyncTest, NotEnabled_FailedPreconditionLikeMove_NoHandle) {
  Start();
  test_support::WaitStatus(
      *drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, kWait);
  Completion done;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, done.Callback());
  absl::StatusOr<CommandInfo> r = done.Wait();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(r.status().message(), HasSubstr("needs main state 8"));
  EXPECT_EQ(done.thread(), executor_.id());
  EXPECT_FALSE(drive_->GetStatus().last_command.has_value() &&
               drive_->GetStatus().last_command->kind == "MoveAbsolute");
}

TEST_F(LinMotUdpMoveAsyncTest, NoEchoBeforeTheAcceptanceTimeout_DeadlineExceededHandleError) {
  // Replies arrive, but each 150 ms late: the echo of the command cannot be seen within the 50 ms
  // acceptance time-out (D-11), and the link stays up (reply time-out 1 s).
  Start(/*reply_timeout=*/1000ms, /*accept=*/50ms);
  EnableOrDie();
  server_->SetReplyDelay(150ms);
  Completion done;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, done.Callback());
  absl::StatusOr<CommandInfo> r = done.Wait();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded) << r.status();
  EXPECT_THAT(r.status().message(), HasSubstr("not accepted within 50 ms"));
  ASSERT_TRUE(drive_->GetStatus().last_command.has_value());
  EXPECT_EQ(drive_->GetStatus().last_command->state, CommandState::kError);
  server_->SetReplyDelay(0ms);
  // An RTC round trip drains the replies still delayed; then the operation is free again and a
  // blocking move runs normally.
  ASSERT_TRUE(drive_->ReadParameter({sim::linmot::upid::kPredefVelocity, false}).ok());
  auto next = drive_->Move(MoveAbsolute{30, 500, 5000, 5000});
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_EQ(WaitFinal(next->id).state, CommandState::kDone);
}

TEST_F(LinMotUdpMoveAsyncTest, LinkLostMidCommand_UnavailableHandleError) {
  Start(/*reply_timeout=*/30ms, /*accept=*/2000ms);
  EnableOrDie();
  server_->SetAnswering(false);  // the link is still up: the move starts, its echo never comes
  Completion done;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, done.Callback());
  absl::StatusOr<CommandInfo> r = done.Wait();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kUnavailable) << r.status();
  EXPECT_THAT(r.status().message(), HasSubstr("lost"));
  ASSERT_TRUE(drive_->GetStatus().last_command.has_value());
  EXPECT_EQ(drive_->GetStatus().last_command->kind, "MoveAbsolute");
  EXPECT_EQ(drive_->GetStatus().last_command->state, CommandState::kError);
  EXPECT_EQ(done.calls(), 1);
}

TEST_F(LinMotUdpMoveAsyncTest, DeactivatedWhilePending_FailedPreconditionDriveDeactivated) {
  Start(/*reply_timeout=*/1000ms, /*accept=*/2000ms);
  EnableOrDie();
  server_->SetAnswering(false);
  Completion done;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, done.Callback());
  drive_->Deactivate();
  absl::StatusOr<CommandInfo> r = done.Wait();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition) << r.status();
  EXPECT_THAT(r.status().message(), HasSubstr("drive deactivated"));
  EXPECT_EQ(done.calls(), 1);
}

TEST_F(LinMotUdpMoveAsyncTest, SecondOperationWhilePending_WaitsItsTurnThenRuns) {
  // Replies 40 ms late: the first move is still waiting for its echo when the others arrive.
  Start(/*reply_timeout=*/1000ms, /*accept=*/1000ms);
  EnableOrDie();
  server_->SetReplyDelay(40ms);
  Completion first, second;
  drive_->MoveAsync(MoveAbsolute{60, 500, 5000, 5000}, executor_, first.Callback());
  // The second one falls back to the blocking Move on the executor and waits there for the
  // first one's echo (one operation at a time), then supersedes it.
  drive_->MoveAsync(MoveAbsolute{70, 500, 5000, 5000}, executor_, second.Callback());
  absl::StatusOr<CommandInfo> a = first.Wait();
  absl::StatusOr<CommandInfo> b = second.Wait();
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_EQ(a->state, CommandState::kActive);  // accepted before the second one started
  EXPECT_EQ(b->state, CommandState::kActive);
  EXPECT_GT(b->id, a->id);
  server_->SetReplyDelay(0ms);
  EXPECT_EQ(WaitFinal(b->id).state, CommandState::kDone);
  EXPECT_EQ(drive_->GetCommand(a->id)->state, CommandState::kAborted);  // superseded (PLCopen)
  EXPECT_NEAR(server_->Snapshot().device.demand_position_mm, 70, 1e-3);
}

}  // namespace
}  // namespace drivegw::linmot::linudp
