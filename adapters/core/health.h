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
  kUp,       // the last exchange succeeded
  kDemoted,  // connecting, failures counting below down_after_failures, or recovering after DOWN
  kDown,     // down_after_failures consecutive failures (or a family's immediate loss signal)
};
const char* ToString(HealthState s);

// Per drive, config keys `health.*` (docs/config.md). The defaults are the per-family values the
// families used before the shared model (decision 1431), chosen by DefaultHealthConfig.
struct HealthConfig {
  int down_after_failures = 3;
  std::chrono::milliseconds backoff_min{100};   // first probe interval of a DOWN link
  std::chrono::milliseconds backoff_max{5000};  // the doubling stops here
};

// The `health.*` keys of one drive as given in the file; an absent key takes the family's default.
struct HealthOverrides {
  std::optional<int> down_after_failures;
  std::optional<std::chrono::milliseconds> backoff_min;
  std::optional<std::chrono::milliseconds> backoff_max;
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
  // the back-off, see HealthModel::failed_probes).
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

  // Each returns true when info() changed (the caller then hands it to DriveBase::SetHealth).
  // A successful exchange: UP from UP or DEMOTED; DOWN -> DEMOTED (recovering: the family
  // re-establishes its link, e.g. re-applies parameters); the next success makes it UP.
  bool RecordSuccess();
  // A failed exchange with its cause: UP -> DEMOTED, DEMOTED -> DOWN at down_after_failures;
  // while DOWN (a failed probe) the back-off doubles up to backoff_max.
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

  HealthConfig config_;
  const Clock& clock_;
  HealthInfo info_;
  std::chrono::milliseconds backoff_;
  TimePoint next_probe_{};
  uint64_t failed_probes_ = 0;
};

}  // namespace drivegw
