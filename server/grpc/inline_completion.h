// The executor a unary call hands the Drive seam (decision 1302): a completion posted while the
// call's gRPC thread still waits for it — at most a short, fixed budget — runs on that thread,
// so the reply is finished where gRPC can write it at once; anything posted before the wait began
// or after it ended goes to the worker pool, as every completion did before.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>

#include "adapters/core/executor.h"

namespace drivegw::server {

class InlineCompletion final : public Executor {
 public:
  // Bound of the wait on gRPC's callback thread: a LinUDP round trip takes 5-60 µs at p50 on the
  // reference machine and gRPC 1.51 has two callback threads, so 1 ms keeps a silent drive from
  // holding one for longer than a few calls' worth of work (decision 1302).
  static constexpr std::chrono::microseconds kMaxWait{1000};

  explicit InlineCompletion(Executor& fallback) : fallback_(fallback) {}

  // While WaitAndRun waits: hands `task` to it. Otherwise (before the wait, e.g. a family's
  // blocking fallback posted from inside MoveAsync, or after it): the fallback executor.
  void Post(std::function<void()> task) override {
    {
      std::lock_guard lock(mu_);
      if (waiting_ && !task_) {
        task_ = std::move(task);
        cv_.notify_one();
        return;
      }
    }
    fallback_.Post(std::move(task));
  }

  // True while WaitAndRun waits (tests hand a task over only then).
  bool waiting() const {
    std::lock_guard lock(mu_);
    return waiting_;
  }

  // Waits up to `budget` for a task and runs it on the calling thread; afterwards every Post
  // goes to the fallback. Call once, after the work that will post was started.
  void WaitAndRun(std::chrono::microseconds budget = kMaxWait) {
    std::function<void()> task;
    {
      std::unique_lock lock(mu_);
      waiting_ = true;
      cv_.wait_for(lock, budget, [&] { return static_cast<bool>(task_); });
      waiting_ = false;
      task = std::move(task_);
      task_ = nullptr;
    }
    if (task) task();
  }

 private:
  Executor& fallback_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool waiting_ = false;
  std::function<void()> task_;
};

}  // namespace drivegw::server
