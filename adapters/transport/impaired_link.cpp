// Seeded impairment decisions: splitmix64, a fixed number of draws per datagram.
#include "adapters/transport/impaired_link.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {
namespace {

double ClampProbability(double p) {
  if (!(p > 0)) return 0;  // also NaN
  return std::min(p, 1.0);
}

absl::Status CheckProbability(const char* field, double p) {
  if (std::isnan(p) || p < 0 || p > 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("impairment.", field, ": ", p, " is outside [0, 1]"));
  }
  return absl::OkStatus();
}

}  // namespace

ImpairedLink::ImpairedLink(const Impairment& impairment)
    : impairment_(impairment), state_(impairment.seed) {
  impairment_.drop_probability = ClampProbability(impairment_.drop_probability);
  impairment_.duplicate_probability = ClampProbability(impairment_.duplicate_probability);
  impairment_.delay_min = std::max(impairment_.delay_min, std::chrono::nanoseconds{0});
  impairment_.delay_max = std::max(impairment_.delay_max, impairment_.delay_min);
}

absl::Status ImpairedLink::Validate(const Impairment& impairment) {
  if (auto s = CheckProbability("drop_probability", impairment.drop_probability); !s.ok()) {
    return s;
  }
  if (auto s = CheckProbability("duplicate_probability", impairment.duplicate_probability);
      !s.ok()) {
    return s;
  }
  if (impairment.delay_min.count() < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("impairment.delay_min: ", impairment.delay_min.count(), " ns is negative"));
  }
  if (impairment.delay_max < impairment.delay_min) {
    return absl::InvalidArgumentError(
        absl::StrCat("impairment.delay_max: ", impairment.delay_max.count(),
                     " ns is below delay_min ", impairment.delay_min.count(), " ns"));
  }
  return absl::OkStatus();
}

uint64_t ImpairedLink::Next() {
  // splitmix64 (Steele, Lea, Flood 2014): fixed output for a seed on every platform, unlike the
  // std:: distributions.
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double ImpairedLink::NextUnit() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

std::chrono::nanoseconds ImpairedLink::NextDelay() {
  const uint64_t r = Next();
  const auto span = static_cast<uint64_t>((impairment_.delay_max - impairment_.delay_min).count());
  if (span == 0) return impairment_.delay_min;
  // Modulo bias is at most span / 2^64: irrelevant for test delays.
  const uint64_t offset = r % (span + 1);  // span <= INT64_MAX, so no overflow
  return impairment_.delay_min + std::chrono::nanoseconds(static_cast<int64_t>(offset));
}

ImpairmentDecision ImpairedLink::Decide() {
  // Always four draws, so decision n depends only on (seed, n).
  const double drop_draw = NextUnit();
  const double duplicate_draw = NextUnit();
  const std::chrono::nanoseconds delay = NextDelay();
  const std::chrono::nanoseconds duplicate_delay = NextDelay();

  ImpairmentDecision d;
  ++counters_.decided;
  if (drop_draw < impairment_.drop_probability) {
    d.drop = true;
    ++counters_.dropped;
    return d;
  }
  d.delay = delay;
  if (delay.count() > 0) ++counters_.delayed;
  if (duplicate_draw < impairment_.duplicate_probability) {
    d.duplicate = true;
    d.duplicate_delay = duplicate_delay;
    ++counters_.duplicated;
  }
  return d;
}

bool ImpairedLink::transparent() const {
  return impairment_.drop_probability == 0 && impairment_.duplicate_probability == 0 &&
         impairment_.delay_max.count() == 0;
}

}  // namespace drivegw::transport
