// The drive's error log: a ring of the last errors with operating-time stamps (RTC 0x70-0x73).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

namespace drivegw::sim::linmot {

struct ErrorLogEntry {
  uint16_t code = 0;
  // linmot-linudp.md §5.3 note: "time high" = 32-bit hours, "time low" = 32-bit milliseconds
  // (within the hour) of the drive's operating time.
  uint32_t hours = 0;
  uint32_t milliseconds = 0;
};

// Entry 0 is the most recent error (docs/decisions/603-linmot-sim-rtc-channel.md). Survives
// simulated reboots (it is the drive's flash log); the counters are 16-bit on the wire.
class ErrorLog {
 public:
  static constexpr size_t kCapacity = 20;

  void Add(uint16_t code, uint64_t operating_ms) {
    entries_.push_front(ErrorLogEntry{code, static_cast<uint32_t>(operating_ms / 3'600'000),
                                      static_cast<uint32_t>(operating_ms % 3'600'000)});
    if (entries_.size() > kCapacity) entries_.pop_back();
    ++occurred_;
  }
  // Number of entries held (<= kCapacity) and of errors ever logged.
  size_t logged() const { return entries_.size(); }
  uint32_t occurred() const { return occurred_; }
  std::optional<ErrorLogEntry> Entry(size_t n) const {
    if (n >= entries_.size()) return std::nullopt;
    return entries_[n];
  }

 private:
  std::deque<ErrorLogEntry> entries_;
  uint32_t occurred_ = 0;
};

}  // namespace drivegw::sim::linmot
