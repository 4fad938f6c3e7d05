// A fixed pool of threads for work that blocks on a drive (Enable waits for the state machine,
// moves wait for the count echo), so gRPC's callback threads never block.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "adapters/core/executor.h"

namespace drivegw::server {

// Also the Executor the Drive seam completes asynchronous commands on (adapters/core/executor.h).
class WorkerPool final : public Executor {
 public:
  explicit WorkerPool(int threads);
  ~WorkerPool() override;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Runs `task` on a pool thread; tasks queued after Shutdown() run inline on the caller.
  void Post(std::function<void()> task) override;
  void Shutdown();

 private:
  void Run();
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace drivegw::server
