// WordAssembler: 9-byte word framing with packet timeout and break (§2.3, L279, L375).
#include "sim/trinamic/word_assembler.h"

namespace drivegw::sim::trinamic {

void WordAssembler::Feed(std::span<const uint8_t> bytes, TimePoint now, Duration timeout,
                         const OnWord& on_word) {
  for (uint8_t b : bytes) {
    // A word must be complete within the packet timeout, measured from its first byte (L279).
    if (Expired(now, timeout)) {
      partial_.clear();
      ++counters_.partial_timeouts;
    }
    if (partial_.empty()) partial_since_ = now;
    partial_.push_back(b);
    if (partial_.size() < drivegw::trinamic::kCommandSize) continue;
    auto command = drivegw::trinamic::DecodeCommand(partial_);
    partial_.clear();
    if (!command.ok()) {
      ++counters_.words_dropped;  // not executed, no answer (L279, G-06)
      continue;
    }
    ++counters_.words;
    on_word(*command);
  }
}

void WordAssembler::Break() {
  if (!partial_.empty()) ++counters_.breaks;
  partial_.clear();
}

}  // namespace drivegw::sim::trinamic
