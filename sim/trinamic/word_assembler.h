// WordAssembler: frames the serial byte stream of one simulated PACK into 9-byte command words,
// with the `$41` packet timeout measured from a word's first byte and the break that discards a
// partial word (trinamic-sixpack.md §2.3, L275-279, L375; G-04, G-39; decision 1037).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/trinamic/codec.h"

namespace drivegw::sim::trinamic {

struct AssemblerCounters {
  uint64_t words = 0;             // complete words the codec decoded
  uint64_t words_dropped = 0;     // complete words the codec refused (unknown opcode, G-06)
  uint64_t partial_timeouts = 0;  // partial words discarded by the packet timeout (L279)
  uint64_t breaks = 0;            // partial words discarded by a break (L279)
};

// Not thread-safe: the owning server serialises calls.
class WordAssembler {
 public:
  using OnWord = std::function<void(const drivegw::trinamic::Command&)>;

  // Bytes received at `now`; `timeout` is the packet abort timeout in force. Every complete word
  // the codec accepts goes to `on_word`, in order.
  void Feed(std::span<const uint8_t> bytes, TimePoint now, Duration timeout, const OnWord& on_word);
  // A received break: the partial word is not interpreted (L279).
  void Break();
  // Drops the partial word without counting (reset, power loss).
  void Clear() { partial_.clear(); }
  // True once the partial word is older than `timeout` at `now` (the tunnel flush, L317).
  bool Expired(TimePoint now, Duration timeout) const {
    return !partial_.empty() && now - partial_since_ > timeout;
  }
  size_t partial_size() const { return partial_.size(); }
  const AssemblerCounters& counters() const { return counters_; }

 private:
  std::vector<uint8_t> partial_;
  TimePoint partial_since_{};
  AssemblerCounters counters_;
};

}  // namespace drivegw::sim::trinamic
