// The simulators' CAN receive loop (sim/canopen SlaveServer, sim/trinamic TrinamicCanServer):
// header-only so it needs no library of its own.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>

#include "adapters/transport/can_channel.h"

namespace drivegw::sim {

// Until `stop`: receives with `idle_wait` and hands the frame (nullopt when none came, so the
// server can advance its clock) to `on_receive`. A receive error goes to `on_error`, then the loop
// waits 20 ms so a broken channel does not become a busy loop (real time; Stop still joins
// promptly).
template <typename OnError, typename OnReceive>
void RunCanReceiveLoop(transport::CanChannel& channel, std::chrono::nanoseconds idle_wait,
                       const std::atomic<bool>& stop, OnError on_error, OnReceive on_receive) {
  std::mutex backoff_mu;
  std::condition_variable backoff_cv;
  while (!stop.load()) {
    auto received = channel.Receive(idle_wait);
    if (!received.ok()) {
      on_error();
      std::unique_lock lock(backoff_mu);
      backoff_cv.wait_for(lock, std::chrono::milliseconds(20), [&stop] { return stop.load(); });
      continue;
    }
    on_receive(*received);
  }
}

}  // namespace drivegw::sim
