// Device health shared by every family (issue 11 "Device health";
// docs/decisions/1431-device-health.md): UP / DEMOTED / DOWN per link with a consecutive-failure
// count and a doubling probe back-off. The family keeps its protocol-specific detection (a LinUDP
// time-out, a Trinamic missed reply, a DeviceNet connection time-out, a CANopen heartbeat loss) and
// reports each outcome here; the counting, the back-off and the state come from this one model.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "adapters/core/clock.h"

namespace drivegw {

enum class HealthState {
  kUp,       // exchanges succeed (for up_after without a failure when DEMOTED was entered so)
  kDemoted,  // connecting, failures counting below down_after_failures, or recovering after DOWN
  kDown,     // down_after_failures consecutive failures (or a family's immediate loss signal)
};
const char* ToString(HealthState s);

// The hold before a DEMOTED link (entered by a failure or recovering from DOWN) is UP again,
// every family (decision 1432: at most ~15 health events a minute at the worst loss rate, below
// the event recorder's 20 per drive and minute).
inline constexpr std::chrono::milliseconds kDefaultUpAfter{3000};

// Per drive, config keys `health.*` (docs/config.md). The defaults are the per-family values the
// families used before the shared model (decision 1431), chosen by DefaultHealthConfig.
struct HealthConfig {
  int down_after_failures = 3;
  std::chrono::milliseconds backoff_min{100};   // first probe interval of a DOWN link
  std::chrono::milliseconds backoff_max{5000};  // the doubling stops here
  // DEMOTED -> UP only after successes without a failure for this long; 0 = at the next success
  // (the behaviour of decision 1431). Not for the initial DEMOTED: the first reply is UP at once.
  std::chrono::milliseconds up_after{kDefaultUpAfter};
};

// The `health.*` keys of one drive as given in the file; an absent key takes the family's default.
struct HealthOverrides {
  std::optional<int> down_after_failures;
  std::optional<std::chrono::milliseconds> backoff_min;
  std::optional<std::chrono::milliseconds> backoff_max;
  std::optional<std::chrono::milliseconds> up_after;
};
// `family_default` with the given keys applied.
HealthConfig ResolveHealthConfig(const HealthOverrides& given, HealthConfig family_default);

// The limits every family shares; errors name `key_prefix` + the field and the limit.
absl::Status ValidateHealthConfig(const HealthConfig& c, absl::string_view key_prefix);

// What the API reports (proto DriveHealth): a value, copied into every DriveStatus snapshot.
struct HealthInfo {
  HealthState state = HealthState::kDown;
  // When `state` was entered (wall clock, for the API and the UNAVAILABLE message).
  std::chrono::system_clock::time_point since{};
  // The consecutive failures that led to `state` (frozen while DOWN: failed probes only lengthen
  // the back-off, see HealthModel::failed_probes). While DEMOTED: the longest run since DEMOTED
  // was entered, i.e. how close the link came to DOWN (decision 1432: a shorter run after a
  // success publishes nothing).
  uint32_t consecutive_failures = 0;
  std::string reason;  // the last failure's cause, e.g. "3 consecutive time-outs"

  bool operator==(const HealthInfo&) const = default;
};

// "2026-12-07T05:12:03Z" (RFC 3339, UTC, whole seconds).
std::string FormatRfc3339Utc(std::chrono::system_clock::time_point t);

// The UNAVAILABLE status for a call to a DOWN drive, e.g. "drive 'x1' is DOWN since
// 2026-12-07T05:12:03Z (3 consecutive time-outs): move_absolute refused".
absl::Status DownError(absl::string_view drive, const HealthInfo& h, absl::string_view operation);

// Not thread-safe: the owner (a session, a pack, a drive) calls it under its own lock.
class HealthModel {
 public:
  // Starts DEMOTED ("no reply yet"): connecting, the failures count from here, so a drive that
  // never answers goes DOWN after down_after_failures like one that stopped answering, and a
  // call in the first milliseconds after activation is not refused for a reply not yet due.
  explicit HealthModel(HealthConfig config, const Clock& clock = SteadyClock::Instance());

  // Each returns true when info() changed (the caller then hands it to DriveBase::SetHealth);
  // info() changes only then.
  // A successful exchange: the first reply (initial DEMOTED) is UP at once; DEMOTED entered by a
  // failure is UP at the first success once up_after has passed without a failure since the
  // first success after the last failure (decision 1432); DOWN -> DEMOTED (recovering: the
  // family re-establishes its link, e.g. re-applies parameters), UP after the same hold counted
  // from this success (with up_after 0: at the next success). Reads the clock only while
  // DEMOTED with a hold; nothing while UP.
  bool RecordSuccess();
  // A failed exchange with its cause: UP -> DEMOTED, DEMOTED -> DOWN at down_after_failures
  // consecutive ones; it restarts the hold. While DEMOTED only a run longer than the published
  // consecutive_failures is published. While DOWN (a failed probe) the back-off doubles up to
  // backoff_max.
  bool RecordFailure(absl::string_view reason);
  // A loss the family detects at once (CANopen heartbeat time-out, CAN bus-off, a detected reset
  // to re-initialise): DOWN now, whatever the count.
  bool ForceDown(absl::string_view reason);

  // Delays the next probe of a DOWN link to at least `t` (Trinamic: a PACK boots ca. 1 s after a
  // `$CC` hardware reset, L900).
  void ProbeNotBefore(TimePoint t);
  // True when a DOWN link should be probed now (the back-off passed). Always true when not DOWN.
  bool ProbeDue() const;
  // The moment the next probe is due (now when not DOWN).
  TimePoint next_probe() const;
  // The current probe interval of a DOWN link (backoff_min after going DOWN, doubling).
  std::chrono::milliseconds backoff() const { return backoff_; }
  // Probes that failed since the drive went DOWN.
  uint64_t failed_probes() const { return failed_probes_; }

  HealthState state() const { return info_.state; }
  const HealthInfo& info() const { return info_; }
  const HealthConfig& config() const { return config_; }

 private:
  void Enter(HealthState s);
  void GoDown(absl::string_view reason);
  bool GoUp();

  HealthConfig config_;
  const Clock& clock_;
  HealthInfo info_;
  std::chrono::milliseconds backoff_;
  TimePoint next_probe_{};
  uint64_t failed_probes_ = 0;
  // The current run of consecutive failures (info_.consecutive_failures is what was published).
  uint32_t run_ = 0;
  // Still in the initial DEMOTED: no reply yet, so the first one is UP without a hold.
  bool connecting_ = true;
  // A success since the last failure started the hold; UP at a success from up_at_ on.
  bool holding_ = false;
  TimePoint up_at_{};
};

}  // namespace drivegw
