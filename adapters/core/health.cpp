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
// The same bound for the hold before UP (decision 1432).
constexpr std::chrono::milliseconds kMaxUpAfter{600000};
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
  if (given.up_after) family_default.up_after = *given.up_after;
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
  if (c.up_after.count() < 0 || c.up_after > kMaxUpAfter) {
    return absl::InvalidArgumentError(absl::StrCat(key_prefix, "up_after_ms: ", c.up_after.count(),
                                                   " is outside 0..", kMaxUpAfter.count()));
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

bool HealthModel::GoUp() {
  info_.consecutive_failures = 0;
  info_.reason.clear();
  connecting_ = false;
  holding_ = false;
  Enter(HealthState::kUp);
  return true;
}

bool HealthModel::RecordSuccess() {
  switch (info_.state) {
    case HealthState::kUp:
      return false;
    case HealthState::kDemoted:
      run_ = 0;
      // Connecting is not flapping: the first reply is UP at once (decision 1432), as is any
      // success without a hold (decision 1431's behaviour).
      if (connecting_ || config_.up_after.count() == 0) return GoUp();
      if (!holding_) {
        // The first success after a failure starts the hold; one clock read per success while
        // it runs, none while UP.
        holding_ = true;
        up_at_ = clock_.Now() + config_.up_after;
        return false;
      }
      if (clock_.Now() < up_at_) return false;
      return GoUp();
    case HealthState::kDown:
      // Recovering: one more success before UP, so a single stray reply of a dying drive does not
      // flip it UP, and the family re-establishes its link (Trinamic re-applies parameters) in
      // between. The hold counts from this success (decision 1432: a link that was lost is the
      // likeliest to be lost again; with up_after 0 the next success is UP, as in 1431).
      backoff_ = config_.backoff_min;
      failed_probes_ = 0;
      run_ = 0;
      info_.consecutive_failures = 0;
      info_.reason = "recovering";
      holding_ = true;
      if (config_.up_after.count() > 0) up_at_ = clock_.Now() + config_.up_after;
      Enter(HealthState::kDemoted);
      return true;
  }
  return false;
}

void HealthModel::GoDown(absl::string_view reason) {
  info_.consecutive_failures = run_;
  info_.reason = std::string(reason);
  // Back from DOWN is recovering, not connecting: the hold applies (decision 1432).
  connecting_ = false;
  holding_ = false;
  backoff_ = config_.backoff_min;
  next_probe_ = clock_.Now() + backoff_;
  Enter(HealthState::kDown);
}

bool HealthModel::RecordFailure(absl::string_view reason) {
  switch (info_.state) {
    case HealthState::kUp:
    case HealthState::kDemoted:
      holding_ = false;  // a failure restarts the hold (decision 1432)
      if (run_ < UINT32_MAX) ++run_;
      if (static_cast<int64_t>(run_) >= config_.down_after_failures) {
        GoDown(absl::StrCat(run_, " consecutive ", reason));
        return true;
      }
      // While DEMOTED only a run longer than the one published is news (closer to DOWN): a
      // single lost exchange of a link DEMOTED for loss publishes nothing, so the changes per
      // DEMOTED spell are at most down_after_failures (decision 1432).
      if (info_.state == HealthState::kDemoted && run_ <= info_.consecutive_failures) return false;
      info_.consecutive_failures = run_;
      info_.reason = absl::StrCat(run_, " consecutive ", reason);
      if (info_.state == HealthState::kUp) Enter(HealthState::kDemoted);
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
  if (run_ < UINT32_MAX) ++run_;
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
