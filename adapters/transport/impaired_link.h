// Seeded, deterministic fault injector for datagram links (drop, duplicate, delay, reorder,
// corrupt), I/O free: the caller (a transport decorator, a simulator, a test) asks for a decision
// per datagram/frame and applies it. docs/decisions/1421-fault-injection-decorators.md says what
// each fault models on UDP, CAN and serial links.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::transport {

struct Impairment {
  double drop_probability = 0;       // [0, 1]
  double duplicate_probability = 0;  // [0, 1], among datagrams not dropped
  std::chrono::nanoseconds delay_min{0};
  std::chrono::nanoseconds delay_max{0};  // >= delay_min; each copy draws uniformly in between
  double reorder_probability = 0;  // [0, 1], among datagrams not dropped: held back, sent after
                                   // the next one
  double corrupt_probability = 0;  // [0, 1], among datagrams not dropped: a copy with one bit
                                   // flipped (or cut short, per medium) is sent instead
  uint64_t seed = 1;
};

// The impairment that does nothing (drop=0, ..., seed kept).
bool IsTransparent(const Impairment& impairment);

// "drop=0.1,duplicate=0.05,reorder=0.02,corrupt=0.01,delay=1ms..5ms,seed=7": the text form of a
// simulator's --impair switch and of test-bench configuration. Keys may appear in any order and
// are optional (absent = 0; seed default 1); delay is "X" or "X..Y" with unit ns, us, ms or s.
// InvalidArgument naming the key ("impair drop: '1.5' is outside [0, 1]", "impair: unknown key
// 'lose' (drop, duplicate, reorder, corrupt, delay, seed)"); the result passes Validate.
absl::StatusOr<Impairment> ParseImpairment(std::string_view spec);

// The inverse of ParseImpairment for logs and test output: "drop=0.1,corrupt=0.01,seed=7"
// (zero fields left out).
std::string ImpairmentString(const Impairment& impairment);

// What to do with one datagram. Dropped: nothing else applies. Otherwise send it after `delay`
// and, when `duplicate`, a second copy after `duplicate_delay` (which may reorder them).
struct ImpairmentDecision {
  bool drop = false;
  bool duplicate = false;
  std::chrono::nanoseconds delay{0};
  std::chrono::nanoseconds duplicate_delay{0};
  // Hold this datagram back and send it right after the next one (explicit reorder; the caller
  // releases a held datagram after the next send, or when the link goes idle for good).
  bool reorder = false;
  // Send a corrupted copy instead: `corrupt_bits` is a seeded value the caller maps to a bit
  // position (FlipBit) or a length (Truncate).
  bool corrupt = false;
  uint64_t corrupt_bits = 0;
  friend bool operator==(const ImpairmentDecision&, const ImpairmentDecision&) = default;
};

struct ImpairedLinkCounters {
  uint64_t decided = 0;
  uint64_t dropped = 0;
  uint64_t duplicated = 0;
  uint64_t delayed = 0;  // datagrams with a non-zero delay on the first copy
  uint64_t reordered = 0;
  uint64_t corrupted = 0;
};

// Corruptions a caller applies to its own copy of the bytes. FlipBit flips bit
// (corrupt_bits mod 8*size) (nothing for empty input); Truncate keeps the first
// (corrupt_bits mod size) bytes, i.e. always removes at least one byte.
void FlipBit(std::span<uint8_t> bytes, uint64_t corrupt_bits);
size_t TruncatedLength(size_t size, uint64_t corrupt_bits);

// Decision n depends only on the seed and n: every decision draws the same number of random
// values whatever the probabilities, so changing one probability does not reshuffle the others.
// Reorder and corrupt draw from a second stream (seeded from the same seed), so adding them
// kept every drop/duplicate/delay decision of the existing seeded tests (decision 1421).
// Not thread-safe (one link per direction, owned by one thread).
class ImpairedLink {
 public:
  // Probabilities outside [0, 1] are clamped, a negative delay_min becomes 0 and delay_max is
  // raised to delay_min; Validate() reports such inputs instead, for configuration checks.
  explicit ImpairedLink(const Impairment& impairment);

  // InvalidArgument naming the field: "impairment.drop_probability: 1.5 is outside [0, 1]".
  static absl::Status Validate(const Impairment& impairment);

  ImpairmentDecision Decide();

  // True when no datagram can be dropped, duplicated, delayed, reordered or corrupted.
  bool transparent() const;
  const Impairment& impairment() const { return impairment_; }
  const ImpairedLinkCounters& counters() const { return counters_; }

 private:
  static uint64_t Next(uint64_t& state);  // splitmix64
  uint64_t Next() { return Next(state_); }
  double NextUnit();  // [0, 1)
  std::chrono::nanoseconds NextDelay();

  Impairment impairment_;
  uint64_t state_;
  uint64_t aux_state_;  // reorder/corrupt stream
  ImpairedLinkCounters counters_;
};

}  // namespace drivegw::transport
