// Exclusive control leases, one per drive (issue 7, decision 019): acquire with a time to live,
// renew, release, expiry on the injected monotonic clock (checked lazily on every access, no
// thread per lease), and the one check every mutating drive access passes (CheckLease).
#pragma once

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "adapters/core/clock.h"
#include "server/core/call_context.h"

namespace drivegw::server {

// The principal every caller has while authentication is disabled (call_context.h).
inline constexpr std::string_view kAnonymousPrincipal = "anonymous";

struct LeaseInfo {
  std::string lease_id;  // 32 hex digits, random: presenting it proves holding
  std::string drive;     // "x1"
  std::string holder;    // the principal
  absl::Time acquire_time;
  absl::Time expire_time;  // for messages and the API; expiry itself runs on `deadline`
  Duration ttl{0};
  TimePoint deadline;  // on the manager's clock
};

class LeaseManager {
 public:
  using WallClock = std::function<absl::Time()>;
  static constexpr Duration kDefaultTtl = std::chrono::seconds(30);
  static constexpr Duration kMinTtl = std::chrono::seconds(1);
  static constexpr Duration kMaxTtl = std::chrono::hours(1);

  // `clock` runs expiry (tests pass a ManualClock); `wall` only dates the expiry in messages and
  // in the API. `clock` must outlive the manager.
  explicit LeaseManager(const Clock& clock = SteadyClock::Instance(), WallClock wall = &absl::Now);

  // Takes the lease of `drive` (a configured drive's name; the caller checked it) for `ttl`
  // (kMinTtl..kMaxTtl, the caller checked it). A lease the caller already holds is extended and
  // keeps its id; somebody else's: FailedPrecondition naming the holder and the expiry.
  absl::StatusOr<LeaseInfo> Acquire(const std::string& drive, const CallContext& c, Duration ttl);
  // Extends lease `lease_id` by `ttl` from now (0 = its last ttl). NotFound for an unknown or
  // expired id, PermissionDenied when the caller is not the holder's principal.
  absl::StatusOr<LeaseInfo> Renew(const std::string& lease_id, const CallContext& c, Duration ttl);
  // Ends lease `lease_id`; errors as Renew. Returns the lease as it was.
  absl::StatusOr<LeaseInfo> Release(const std::string& lease_id, const CallContext& c);
  // Every lease in force, by drive name.
  std::vector<LeaseInfo> List() const;

  // OK when `drive` has no lease in force or the caller holds it; else FailedPrecondition
  // "drive 'x1' is leased by 'mes-line-3' until 2026-11-27T16:03:12Z".
  absl::Status CheckControl(std::string_view drive, const CallContext& c) const;

 private:
  // Drops expired leases (caller holds mu_).
  void ExpireLocked() const;
  // The caller holds `lease`: same principal, and the lease id presented (x-drivegw-lease) when
  // the principal is anonymous or when an id was presented at all (decision 019).
  static bool Holds(const LeaseInfo& lease, const CallContext& c);
  absl::Status Conflict(const LeaseInfo& lease) const;

  const Clock& clock_;
  const WallClock wall_;
  mutable std::mutex mu_;
  mutable std::map<std::string, LeaseInfo, std::less<>> by_drive_;  // guarded by mu_
};

// The one check before a mutating drive access (DriveServiceCore, ParameterSetServiceCore,
// CurveSetServiceCore): OK when `leases` is null (no lease manager configured).
absl::Status CheckLease(const LeaseManager* leases, std::string_view drive, const CallContext& c);

// "2026-11-27T16:03:12Z".
std::string FormatUtc(absl::Time t);

}  // namespace drivegw::server
