// Seeded, deterministic fault injector for datagram links (drop, duplicate, delay), I/O free:
// the caller (a test or the simulator) asks for a decision per datagram and applies it.
#pragma once

#include <chrono>
#include <cstdint>

#include "absl/status/status.h"

namespace drivegw::transport {

struct Impairment {
  double drop_probability = 0;       // [0, 1]
  double duplicate_probability = 0;  // [0, 1], among datagrams not dropped
  std::chrono::nanoseconds delay_min{0};
  std::chrono::nanoseconds delay_max{0};  // >= delay_min; each copy draws uniformly in between
  uint64_t seed = 1;
};

// What to do with one datagram. Dropped: nothing else applies. Otherwise send it after `delay`
// and, when `duplicate`, a second copy after `duplicate_delay` (which may reorder them).
struct ImpairmentDecision {
  bool drop = false;
  bool duplicate = false;
  std::chrono::nanoseconds delay{0};
  std::chrono::nanoseconds duplicate_delay{0};
  friend bool operator==(const ImpairmentDecision&, const ImpairmentDecision&) = default;
};

struct ImpairedLinkCounters {
  uint64_t decided = 0;
  uint64_t dropped = 0;
  uint64_t duplicated = 0;
  uint64_t delayed = 0;  // datagrams with a non-zero delay on the first copy
};

// Decision n depends only on the seed and n: every decision draws the same number of random
// values whatever the probabilities, so changing one probability does not reshuffle the others.
// Not thread-safe (one link per direction, owned by one thread).
class ImpairedLink {
 public:
  // Probabilities outside [0, 1] are clamped, a negative delay_min becomes 0 and delay_max is
  // raised to delay_min; Validate() reports such inputs instead, for configuration checks.
  explicit ImpairedLink(const Impairment& impairment);

  // InvalidArgument naming the field: "impairment.drop_probability: 1.5 is outside [0, 1]".
  static absl::Status Validate(const Impairment& impairment);

  ImpairmentDecision Decide();

  // True when no datagram can be dropped, duplicated or delayed.
  bool transparent() const;
  const Impairment& impairment() const { return impairment_; }
  const ImpairedLinkCounters& counters() const { return counters_; }

 private:
  uint64_t Next();    // splitmix64
  double NextUnit();  // [0, 1)
  std::chrono::nanoseconds NextDelay();

  Impairment impairment_;
  uint64_t state_;
  ImpairedLinkCounters counters_;
};

}  // namespace drivegw::transport
