// SharedIoLoop: one epoll thread serving the UDP sockets of every simulated LinMot drive in the
// process. `drivegw-sim linmot --count 200` used to run 200 receive threads, and every telegram
// woke a different one: the simulator then spent most of its CPU in context switches and became
// the bottleneck of the 2 ms cyclic benchmark (issue 10, P2; docs/performance.md).
#pragma once

#include <functional>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "absl/status/status.h"

namespace drivegw::sim::linmot {

class SharedIoLoop {
 public:
  // Called on the loop thread when the descriptor is readable, and every ~1 ms while it last
  // returned true (delayed replies waiting for their time on the injected clock).
  using Handler = std::function<bool()>;

  static SharedIoLoop& Instance();  // started on first use, lives until the process ends

  // Starts watching `fd` (level-triggered, readable). Internal when epoll refuses it.
  absl::Status Add(int fd, Handler handler);
  // Stops watching `fd`. When it returns, the handler does not run and will not run again.
  // Must not be called from a handler.
  void Remove(int fd);

 private:
  struct Entry {
    Handler handler;
    bool pending = false;
  };
  SharedIoLoop();
  void Run();

  int epoll_fd_ = -1;
  std::mutex mu_;  // entries_; held while handlers run, so Remove waits for a running one
  std::unordered_map<int, Entry> entries_;
  std::thread thread_;
};

}  // namespace drivegw::sim::linmot
