// The curve runners' shared lifecycle (adapters/core/curve_runner.h): Stop asks the loop to
// leave and joins, the destructor of a runner still running stops it, a new run is refused while
// the latest runner's command runs and joins it once the command ended. Real threads.
#include "adapters/core/curve_runner.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>

namespace drivegw {
namespace {

using namespace std::chrono_literals;

// A runner whose loop waits on a condition variable until asked to stop (like the Trinamic and
// DeviceNet runners), counting how often it was asked.
class WaitingRunner final : public CurveRunnerBase {
 public:
  explicit WaitingRunner(uint64_t id, std::atomic<int>* left) : CurveRunnerBase(id), left_(left) {}
  ~WaitingRunner() override { Stop(); }
  bool running() const { return running_; }

 private:
  void Run() override {
    running_ = true;
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return stop_; });
    running_ = false;
    ++*left_;
  }
  void RequestStop() override { SetStopFlag(mu_, cv_, stop_); }

  std::atomic<int>* const left_;
  std::atomic<bool> running_{false};
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
};

void WaitUntil(const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!done() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
}

TEST(CurveRunnerTest, StopRequestsAndJoins_DestructorStopsARunningThread) {
  std::atomic<int> left{0};
  {
    WaitingRunner r(7, &left);
    EXPECT_EQ(r.id(), 7u);
    r.Start();
    WaitUntil([&] { return r.running(); });
    ASSERT_TRUE(r.running());
    r.Stop();
    EXPECT_EQ(left, 1);  // joined: the loop has left when Stop returns
    r.Stop();            // a second Stop is harmless
  }
  {
    WaitingRunner r(8, &left);
    r.Start();
    WaitUntil([&] { return r.running(); });
  }  // without a Stop the destructor would block on (or abandon) the thread
  EXPECT_EQ(left, 2);
}

TEST(CurveRunnerTest, JoinEndedRunner_RefusesWhileTheCommandRunsThenJoins) {
  std::atomic<int> left{0};
  std::mutex slot_mu;
  std::shared_ptr<WaitingRunner> slot;
  std::map<uint64_t, CommandInfo> commands;
  auto get = [&](uint64_t id) -> std::optional<CommandInfo> {
    auto it = commands.find(id);
    if (it == commands.end()) return std::nullopt;
    return it->second;
  };
  // No runner yet: a run may start.
  EXPECT_TRUE(JoinEndedRunner(slot_mu, slot, get, "drive 'x': RunCurve: ").ok());

  auto runner = std::make_shared<WaitingRunner>(3, &left);
  StoreRunner(slot_mu, slot, runner);
  runner->Start();
  CommandInfo info;
  info.id = 3;
  info.state = CommandState::kActive;
  commands[3] = info;
  const absl::Status refused =
      JoinEndedRunner(slot_mu, slot, get, "drive 'x': RunCurve: ", " (hint)");
  EXPECT_EQ(refused.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(refused.message(),
            "drive 'x': RunCurve: curve command 3 is still running; Stop or Move first (hint)");
  EXPECT_EQ(left, 0);

  // Deactivate stops the latest runner at once.
  StopRunner(slot_mu, slot);
  EXPECT_EQ(left, 1);
  commands[3].state = CommandState::kAborted;
  EXPECT_TRUE(JoinEndedRunner(slot_mu, slot, get, "p: ").ok());
  EXPECT_EQ(LoadRunner(slot_mu, slot), runner);
}

TEST(CurveRunnerTest, StartToleranceAndPrefix) {
  EXPECT_TRUE(CheckStartTolerance("p: ", 0).ok());
  const absl::Status s = CheckStartTolerance("drive 'x': RunCurve: ", -0.5);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "drive 'x': RunCurve: start_tolerance_mm: -0.5 must be >= 0");
  const absl::Status p = PrefixedStatus(absl::OutOfRangeError("leg 2: x"), "drive 'x': ");
  EXPECT_EQ(p.code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(p.message(), "drive 'x': leg 2: x");
}

}  // namespace
}  // namespace drivegw
