// Seeded impairment decisions: splitmix64, a fixed number of draws per datagram; the text form.
#include "adapters/transport/impaired_link.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

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

// The second stream's seed: the first 64 bits of the fractional part of sqrt(2) (SHA-512's first
// IV word), so it never coincides with the first stream for any seed.
constexpr uint64_t kAuxSeedMix = 0x6A09E667F3BCC908ULL;

}  // namespace

bool IsTransparent(const Impairment& i) {
  return i.drop_probability == 0 && i.duplicate_probability == 0 && i.delay_max.count() <= 0 &&
         i.reorder_probability == 0 && i.corrupt_probability == 0;
}

void FlipBit(std::span<uint8_t> bytes, uint64_t corrupt_bits) {
  if (bytes.empty()) return;
  const uint64_t bit = corrupt_bits % (bytes.size() * 8);
  bytes[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
}

size_t TruncatedLength(size_t size, uint64_t corrupt_bits) {
  return size == 0 ? 0 : static_cast<size_t>(corrupt_bits % size);
}

ImpairedLink::ImpairedLink(const Impairment& impairment)
    : impairment_(impairment), state_(impairment.seed), aux_state_(impairment.seed ^ kAuxSeedMix) {
  impairment_.drop_probability = ClampProbability(impairment_.drop_probability);
  impairment_.duplicate_probability = ClampProbability(impairment_.duplicate_probability);
  impairment_.reorder_probability = ClampProbability(impairment_.reorder_probability);
  impairment_.corrupt_probability = ClampProbability(impairment_.corrupt_probability);
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
  if (auto s = CheckProbability("reorder_probability", impairment.reorder_probability); !s.ok()) {
    return s;
  }
  if (auto s = CheckProbability("corrupt_probability", impairment.corrupt_probability); !s.ok()) {
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

uint64_t ImpairedLink::Next(uint64_t& state) {
  // splitmix64 (Steele, Lea, Flood 2014): fixed output for a seed on every platform, unlike the
  // std:: distributions.
  uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
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
  // Always three draws from the second stream.
  const double reorder_draw = static_cast<double>(Next(aux_state_) >> 11) * 0x1.0p-53;
  const double corrupt_draw = static_cast<double>(Next(aux_state_) >> 11) * 0x1.0p-53;
  const uint64_t corrupt_bits = Next(aux_state_);

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
  if (reorder_draw < impairment_.reorder_probability) {
    d.reorder = true;
    ++counters_.reordered;
  }
  if (corrupt_draw < impairment_.corrupt_probability) {
    d.corrupt = true;
    d.corrupt_bits = corrupt_bits;
    ++counters_.corrupted;
  }
  return d;
}

bool ImpairedLink::transparent() const { return IsTransparent(impairment_); }

namespace {

absl::Status SpecError(absl::string_view key, absl::string_view value, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat("impair ", key, ": '", value, "' ", why));
}

absl::StatusOr<std::chrono::nanoseconds> ParseSpecDuration(absl::string_view key,
                                                           absl::string_view text) {
  struct Unit {
    const char* suffix;
    double ns;
  };
  // Longest suffix first: "ms" before "s".
  static constexpr Unit kUnits[] = {{"ns", 1}, {"us", 1e3}, {"ms", 1e6}, {"s", 1e9}};
  for (const Unit& u : kUnits) {
    if (!absl::EndsWith(text, u.suffix)) continue;
    double v = 0;
    if (!absl::SimpleAtod(text.substr(0, text.size() - absl::string_view(u.suffix).size()), &v) ||
        !std::isfinite(v) || v < 0 || v > 60e9 / u.ns) {
      return SpecError(key, text, "is not a duration in [0, 60 s]");
    }
    return std::chrono::nanoseconds(static_cast<int64_t>(std::llround(v * u.ns)));
  }
  return SpecError(key, text, "needs a unit (ns, us, ms or s)");
}

}  // namespace

absl::StatusOr<Impairment> ParseImpairment(std::string_view spec_std) {
  const absl::string_view spec(spec_std.data(), spec_std.size());
  Impairment imp;
  if (spec.empty()) return absl::InvalidArgumentError("impair: empty (e.g. drop=0.1,seed=7)");
  for (absl::string_view item : absl::StrSplit(spec, ',')) {
    const size_t eq = item.find('=');
    if (eq == absl::string_view::npos) {
      return absl::InvalidArgumentError(absl::StrCat("impair: '", item, "' is not key=value"));
    }
    const absl::string_view key = item.substr(0, eq);
    const absl::string_view value = item.substr(eq + 1);
    double* probability = nullptr;
    if (key == "drop") {
      probability = &imp.drop_probability;
    } else if (key == "duplicate") {
      probability = &imp.duplicate_probability;
    } else if (key == "reorder") {
      probability = &imp.reorder_probability;
    } else if (key == "corrupt") {
      probability = &imp.corrupt_probability;
    } else if (key == "seed") {
      if (!absl::SimpleAtoi(value, &imp.seed)) {
        return SpecError(key, value, "is not an unsigned 64-bit integer");
      }
      continue;
    } else if (key == "delay") {
      const size_t dots = value.find("..");
      const absl::string_view lo = value.substr(0, dots);
      const absl::string_view hi = dots == absl::string_view::npos ? lo : value.substr(dots + 2);
      auto min = ParseSpecDuration(key, lo);
      if (!min.ok()) return min.status();
      auto max = ParseSpecDuration(key, hi);
      if (!max.ok()) return max.status();
      if (*max < *min) return SpecError(key, value, "has its maximum below its minimum");
      imp.delay_min = *min;
      imp.delay_max = *max;
      continue;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          "impair: unknown key '", key, "' (drop, duplicate, reorder, corrupt, delay, seed)"));
    }
    if (!absl::SimpleAtod(value, probability) || std::isnan(*probability) || *probability < 0 ||
        *probability > 1) {
      return SpecError(key, value, "is outside [0, 1]");
    }
  }
  if (absl::Status s = ImpairedLink::Validate(imp); !s.ok()) return s;
  return imp;
}

std::string ImpairmentString(const Impairment& i) {
  std::string out;
  auto add = [&](const char* key, double p) {
    if (p != 0) absl::StrAppend(&out, out.empty() ? "" : ",", key, "=", p);
  };
  add("drop", i.drop_probability);
  add("duplicate", i.duplicate_probability);
  add("reorder", i.reorder_probability);
  add("corrupt", i.corrupt_probability);
  if (i.delay_max.count() > 0) {
    absl::StrAppend(&out, out.empty() ? "" : ",", "delay=", i.delay_min.count(), "ns..",
                    i.delay_max.count(), "ns");
  }
  absl::StrAppend(&out, out.empty() ? "" : ",", "seed=", i.seed);
  return out;
}

}  // namespace drivegw::transport
