// LeaseManager: one lease per drive in a map, expired lazily on every access (decision 019).
#include "server/core/lease_manager.h"

#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::server {
namespace {

// 128 random bits as hex: the id is the holder's proof when every caller is anonymous, so it
// must not be guessable from another lease's id.
std::string NewLeaseId() {
  static std::mutex mu;
  static std::random_device device;
  std::lock_guard lock(mu);
  std::string id;
  for (int i = 0; i < 4; ++i) absl::StrAppend(&id, absl::StrFormat("%08x", device()));
  return id;
}

bool IsAnonymous(const CallContext& c) {
  return c.principal.empty() || c.principal == kAnonymousPrincipal;
}

}  // namespace

std::string FormatUtc(absl::Time t) {
  return absl::FormatTime("%Y-%m-%dT%H:%M:%SZ", t, absl::UTCTimeZone());
}

LeaseManager::LeaseManager(const Clock& clock, WallClock wall)
    : clock_(clock), wall_(std::move(wall)) {}

void LeaseManager::ExpireLocked() const {
  const TimePoint now = clock_.Now();
  for (auto it = by_drive_.begin(); it != by_drive_.end();) {
    it = now >= it->second.deadline ? by_drive_.erase(it) : std::next(it);
  }
}

bool LeaseManager::Holds(const LeaseInfo& lease, const CallContext& c) {
  const std::string_view principal = c.principal.empty() ? kAnonymousPrincipal : c.principal;
  if (principal != lease.holder) return false;
  if (!c.lease_id.empty()) return c.lease_id == lease.lease_id;
  return !IsAnonymous(c);
}

absl::Status LeaseManager::Conflict(const LeaseInfo& lease) const {
  std::string msg = absl::StrCat("drive '", lease.drive, "' is leased by '", lease.holder,
                                 "' until ", FormatUtc(lease.expire_time));
  if (lease.holder == kAnonymousPrincipal) {
    absl::StrAppend(&msg,
                    " (the holder presents the lease id: gRPC metadata x-drivegw-lease, HTTP "
                    "header X-Drivegw-Lease)");
  }
  return absl::FailedPreconditionError(msg);
}

absl::StatusOr<LeaseInfo> LeaseManager::Acquire(const std::string& drive, const CallContext& c,
                                                Duration ttl) {
  std::lock_guard lock(mu_);
  ExpireLocked();
  const TimePoint now = clock_.Now();
  const absl::Time wall = wall_();
  auto it = by_drive_.find(drive);
  if (it != by_drive_.end()) {
    if (!Holds(it->second, c)) return Conflict(it->second);
    it->second.ttl = ttl;
    it->second.deadline = now + ttl;
    it->second.expire_time = wall + absl::FromChrono(ttl);
    return it->second;
  }
  LeaseInfo lease;
  lease.lease_id = NewLeaseId();
  lease.drive = drive;
  lease.holder = c.principal.empty() ? std::string(kAnonymousPrincipal) : c.principal;
  lease.acquire_time = wall;
  lease.expire_time = wall + absl::FromChrono(ttl);
  lease.ttl = ttl;
  lease.deadline = now + ttl;
  by_drive_[drive] = lease;
  return lease;
}

absl::StatusOr<LeaseInfo> LeaseManager::Renew(const std::string& lease_id, const CallContext& c,
                                              Duration ttl) {
  std::lock_guard lock(mu_);
  ExpireLocked();
  for (auto& [drive, lease] : by_drive_) {
    if (lease.lease_id != lease_id) continue;
    const std::string_view principal = c.principal.empty() ? kAnonymousPrincipal : c.principal;
    if (principal != lease.holder) {
      return absl::PermissionDeniedError(absl::StrCat("lease of drive '", drive, "' is held by '",
                                                      lease.holder, "', not by '",
                                                      std::string(principal), "'"));
    }
    if (ttl > Duration::zero()) lease.ttl = ttl;
    lease.deadline = clock_.Now() + lease.ttl;
    lease.expire_time = wall_() + absl::FromChrono(lease.ttl);
    return lease;
  }
  return absl::NotFoundError(
      absl::StrCat("lease_id: '", lease_id, "' is unknown, expired or released"));
}

absl::StatusOr<LeaseInfo> LeaseManager::Release(const std::string& lease_id, const CallContext& c) {
  std::lock_guard lock(mu_);
  ExpireLocked();
  for (auto it = by_drive_.begin(); it != by_drive_.end(); ++it) {
    if (it->second.lease_id != lease_id) continue;
    const std::string_view principal = c.principal.empty() ? kAnonymousPrincipal : c.principal;
    if (principal != it->second.holder) {
      return absl::PermissionDeniedError(absl::StrCat("lease of drive '", it->first,
                                                      "' is held by '", it->second.holder,
                                                      "', not by '", std::string(principal), "'"));
    }
    LeaseInfo out = std::move(it->second);
    by_drive_.erase(it);
    return out;
  }
  return absl::NotFoundError(
      absl::StrCat("lease_id: '", lease_id, "' is unknown, expired or released"));
}

std::vector<LeaseInfo> LeaseManager::List() const {
  std::lock_guard lock(mu_);
  ExpireLocked();
  std::vector<LeaseInfo> out;
  for (const auto& [drive, lease] : by_drive_) out.push_back(lease);
  return out;
}

absl::Status LeaseManager::CheckControl(std::string_view drive, const CallContext& c) const {
  std::lock_guard lock(mu_);
  ExpireLocked();
  auto it = by_drive_.find(drive);
  if (it == by_drive_.end() || Holds(it->second, c)) return absl::OkStatus();
  return Conflict(it->second);
}

absl::Status CheckLease(const LeaseManager* leases, std::string_view drive, const CallContext& c) {
  return leases == nullptr ? absl::OkStatus() : leases->CheckControl(drive, c);
}

}  // namespace drivegw::server
