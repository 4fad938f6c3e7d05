// The shared clock of every watch stream (issue 10, P5; decision 1341): a few ticker threads, each
// a timer wheel of period groups, call every registered client once per its period. Replaces one
// sleeping producer thread per stream (1,000 streams at 100 Hz were 100,000 thread wake-ups/s).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace drivegw::server {

class WatchTicker {
 public:
  using Clock = std::chrono::steady_clock;

  class Client {
   public:
    virtual ~Client() = default;
    // Runs on a ticker thread, once per period; must not block (it delays every other client
    // of the thread). Returns false when the client is done: the ticker drops it.
    virtual bool Tick() noexcept = 0;
  };

  // `threads` wheels (at least 1); clients are spread over them round-robin, so the work one
  // tick starts (gRPC writes) runs on as many cores as there are threads.
  explicit WatchTicker(size_t threads = DefaultThreads());
  ~WatchTicker();  // stops the threads and drops every client without a last Tick
  WatchTicker(const WatchTicker&) = delete;
  WatchTicker& operator=(const WatchTicker&) = delete;

  // Ticks `client` every `period` from the next due tick of its period group on (the caller does
  // the immediate first tick itself if it wants one). Clients of one period share the tick.
  void Add(Clock::duration period, std::shared_ptr<Client> client);

  // Clients currently registered (tests, metrics).
  size_t clients() const;

  static size_t DefaultThreads();

 private:
  class Wheel;
  std::vector<std::unique_ptr<Wheel>> wheels_;
  mutable std::mutex mu_;
  size_t next_ = 0;  // round-robin wheel for the next Add
};

}  // namespace drivegw::server
