// The executor a unary call hands the Drive seam (decision 1302): a completion posted by another
// thread (the drive's I/O thread) before the call's gRPC thread stopped waiting for it — at most
// a short, fixed budget — runs on that gRPC thread, so the reply is finished where gRPC writes it
// at once. Tasks the gRPC thread posts itself (a family's blocking fallback, posted from inside
// MoveAsync) and anything posted after the wait ended go to the worker pool.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include "adapters/core/executor.h"

namespace drivegw::server {

class InlineCompletion final : public Executor {
 public:
  // Bound of the wait on gRPC's callback thread: a LinUDP round trip takes 5-60 µs at p50 on the
  // reference machine and gRPC 1.51 has two callback threads, so 1 ms keeps a silent drive from
  // holding one for longer than a few calls' worth of work (decision 1302).
  static constexpr std::chrono::microseconds kMaxWait{1000};

  // The constructing thread is the owner: the one that calls WaitAndRun.
  explicit InlineCompletion(Executor& fallback)
      : fallback_(fallback), owner_(std::this_thread::get_id()) {}

  void Post(std::function<void()> task) override {
    // The owner's own tasks may block (Drive::MoveAsync's default runs Move): never kept for it.
    if (std::this_thread::get_id() != owner_) {
      std::lock_guard lock(mu_);
      if (open_ && !task_) {
        task_ = std::move(task);
        cv_.notify_one();
        return;
      }
    }
    fallback_.Post(std::move(task));
  }

  // Waits up to `budget` for a task posted by another thread (or takes one posted already) and
  // runs it on the calling thread; afterwards every Post goes to the fallback. Call once, on the
  // owner thread, after the work that will post was started.
  void WaitAndRun(std::chrono::microseconds budget = kMaxWait) {
    std::function<void()> task;
    {
      std::unique_lock lock(mu_);
      cv_.wait_for(lock, budget, [&] { return static_cast<bool>(task_); });
      open_ = false;
      task = std::move(task_);
      task_ = nullptr;
    }
    if (task) task();
  }

 private:
  Executor& fallback_;
  const std::thread::id owner_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool open_ = true;
  std::function<void()> task_;
};

}  // namespace drivegw::server
