// HealthModel: the one UP/DEMOTED/DOWN state machine every family feeds (decision 1431).
#include "adapters/core/health.h"

#include <algorithm>
#include <cstdint>
#include <ctime>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw {
namespace {
// Limits of the health.* keys (decision 1431): more than 1000 consecutive failures or a probe
// interval above 10 minutes would hide a dead drive for longer than any operator waits.
constexpr int kMaxDownAfterFailures = 1000;
constexpr std::chrono::milliseconds kMaxBackoff{600000};
}  // namespace

const char* ToString(HealthState s) {
  switch (s) {
    case HealthState::kUp:
      return "UP";
    case HealthState::kDemoted:
      return "DEMOTED";
    case HealthState::kDown:
      return "DOWN";
  }
  return "?";
}

HealthConfig ResolveHealthConfig(const HealthOverrides& given, HealthConfig family_default) {
  if (given.down_after_failures) family_default.down_after_failures = *given.down_after_failures;
  if (given.backoff_min) family_default.backoff_min = *given.backoff_min;
  if (given.backoff_max) family_default.backoff_max = *given.backoff_max;
  return family_default;
}

absl::Status ValidateHealthConfig(const HealthConfig& c, absl::string_view key_prefix) {
  if (c.down_after_failures < 1 || c.down_after_failures > kMaxDownAfterFailures) {
    return absl::InvalidArgumentError(absl::StrCat(key_prefix,
                                                   "down_after_failures: ", c.down_after_failures,
                                                   " is outside 1..", kMaxDownAfterFailures));
  }
  if (c.backoff_max.count() < 0 || c.backoff_max > kMaxBackoff) {
    return absl::InvalidArgumentError(absl::StrCat(key_prefix,
                                                   "backoff_max_ms: ", c.backoff_max.count(),
                                                   " is outside 0..", kMaxBackoff.count()));
  }
  if (c.backoff_min.count() < 0 || c.backoff_min > c.backoff_max) {
    return absl::InvalidArgumentError(
        absl::StrCat(key_prefix, "backoff_min_ms: ", c.backoff_min.count(), " is outside 0..",
                     c.backoff_max.count(), " (", key_prefix, "backoff_max_ms)"));
  }
  return absl::OkStatus();
}

std::string FormatRfc3339Utc(std::chrono::system_clock::time_point t) {
  const std::time_t secs =
      std::chrono::system_clock::to_time_t(std::chrono::floor<std::chrono::seconds>(t));
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return absl::StrFormat("%04d-%02d-%02dT%02d:%02d:%02dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                         tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
}

absl::Status DownError(absl::string_view drive, const HealthInfo& h, absl::string_view operation) {
  return absl::UnavailableError(absl::StrCat("drive '", drive, "' is DOWN since ",
                                             FormatRfc3339Utc(h.since), " (", h.reason,
                                             "): ", operation, " refused"));
}

HealthModel::HealthModel(HealthConfig config, const Clock& clock)
    : config_(config), clock_(clock), backoff_(0) {
  info_.state = HealthState::kDemoted;
  info_.since = std::chrono::system_clock::now();
  info_.reason = "no reply yet";
  next_probe_ = clock_.Now();
}

void HealthModel::Enter(HealthState s) {
  info_.state = s;
  info_.since = std::chrono::system_clock::now();
}

bool HealthModel::RecordSuccess() {
  switch (info_.state) {
    case HealthState::kUp:
      return false;
    case HealthState::kDemoted:
      info_.consecutive_failures = 0;
      info_.reason.clear();
      Enter(HealthState::kUp);
      return true;
    case HealthState::kDown:
      // Recovering: one more success before UP, so a single stray reply of a dying drive does not
      // flip it UP, and the family re-establishes its link (Trinamic re-applies parameters) in
      // between.
      backoff_ = config_.backoff_min;
      failed_probes_ = 0;
      info_.consecutive_failures = 0;
      info_.reason = "recovering";
      Enter(HealthState::kDemoted);
      return true;
  }
  return false;
}

void HealthModel::GoDown(absl::string_view reason) {
  info_.reason = std::string(reason);
  backoff_ = config_.backoff_min;
  next_probe_ = clock_.Now() + backoff_;
  Enter(HealthState::kDown);
}

bool HealthModel::RecordFailure(absl::string_view reason) {
  switch (info_.state) {
    case HealthState::kUp:
    case HealthState::kDemoted:
      if (info_.consecutive_failures < UINT32_MAX) ++info_.consecutive_failures;
      info_.reason = absl::StrCat(info_.consecutive_failures, " consecutive ", reason);
      if (static_cast<int64_t>(info_.consecutive_failures) >= config_.down_after_failures) {
        GoDown(info_.reason);
      } else if (info_.state == HealthState::kUp) {
        Enter(HealthState::kDemoted);
      }
      return true;
    case HealthState::kDown:
      // A failed probe: wait twice as long before the next (bounded), so a dead drive on a shared
      // line costs ever less of the line's time. The published info stays as it was when the
      // drive went DOWN (a dead drive probed every cycle must not republish its status each time).
      ++failed_probes_;
      backoff_ = std::min(config_.backoff_max, std::max(config_.backoff_min, backoff_ * 2));
      next_probe_ = clock_.Now() + backoff_;
      return false;
  }
  return false;
}

bool HealthModel::ForceDown(absl::string_view reason) {
  if (info_.state == HealthState::kDown) {
    if (info_.reason == reason) return false;
    info_.reason = std::string(reason);
    return true;
  }
  if (info_.consecutive_failures < UINT32_MAX) ++info_.consecutive_failures;
  GoDown(reason);
  return true;
}

void HealthModel::ProbeNotBefore(TimePoint t) {
  if (info_.state == HealthState::kDown) next_probe_ = std::max(next_probe_, t);
}

bool HealthModel::ProbeDue() const {
  return info_.state != HealthState::kDown || clock_.Now() >= next_probe_;
}

TimePoint HealthModel::next_probe() const {
  return info_.state == HealthState::kDown ? next_probe_ : clock_.Now();
}

}  // namespace drivegw
