// Counters of the WebSocket status stream (decision 504), read by tests and diagnostics.
#pragma once

#include <atomic>
#include <cstdint>

namespace drivegw::rest {

struct WsStats {
  std::atomic<uint64_t> sessions{0};          // WebSocket handshakes accepted
  std::atomic<int64_t> open_calls{0};         // WatchDrives calls of WebSocket sessions running
  std::atomic<uint64_t> frames_sent{0};       // status and error frames written
  std::atomic<uint64_t> frames_coalesced{0};  // status snapshots replaced by a newer one unsent
  std::atomic<uint64_t> max_pending{0};       // most snapshots one session ever held unsent

  void NotePending(uint64_t n) {
    uint64_t seen = max_pending.load();
    while (n > seen && !max_pending.compare_exchange_weak(seen, n)) {
    }
  }
};

}  // namespace drivegw::rest
