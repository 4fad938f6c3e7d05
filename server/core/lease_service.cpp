// LeaseServiceCore: request checks, LeaseManager calls, API conversion and audit.
#include "server/core/lease_service.h"

#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "server/core/audit.h"
#include "server/core/convert.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

google::protobuf::Timestamp ToTimestamp(absl::Time t) {
  return google::protobuf::util::TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(t));
}

// `with_id`: only the holder's own Acquire/Renew answers carry the id (decision 019).
v1::Lease ToProto(const LeaseInfo& l, bool with_id) {
  v1::Lease p;
  if (with_id) p.set_lease_id(l.lease_id);
  p.set_drive(DriveResourceName(l.drive));
  p.set_holder(l.holder);
  *p.mutable_acquire_time() = ToTimestamp(l.acquire_time);
  *p.mutable_expire_time() = ToTimestamp(l.expire_time);
  p.set_ttl_s(ToSeconds(l.ttl));
  return p;
}

// The audit request of a renew/release: the lease id is a bearer secret, so never logged.
std::string RedactedJson(const google::protobuf::Message& m) {
  std::unique_ptr<google::protobuf::Message> copy(m.New());
  copy->CopyFrom(m);
  const auto* field = copy->GetDescriptor()->FindFieldByName("lease_id");
  if (field != nullptr) copy->GetReflection()->ClearField(copy.get(), field);
  return ToAuditJson(*copy);
}

}  // namespace

absl::StatusOr<Duration> LeaseTtl(const std::string& field, double ttl_s, Duration if_zero) {
  if (!std::isfinite(ttl_s) || ttl_s < 0) {
    return FieldError(field, absl::StrCat(ttl_s, " is not a time to live in seconds"));
  }
  if (ttl_s == 0) return if_zero;
  const Duration ttl = FromSeconds(ttl_s);
  if (ttl < LeaseManager::kMinTtl || ttl > LeaseManager::kMaxTtl) {
    return FieldError(field,
                      absl::StrCat(ttl_s, " is outside ", ToSeconds(LeaseManager::kMinTtl), "..",
                                   ToSeconds(LeaseManager::kMaxTtl), " s"),
                      absl::StatusCode::kOutOfRange);
  }
  return ttl;
}

LeaseServiceCore::LeaseServiceCore(LeaseManager& leases,
                                   const std::vector<std::shared_ptr<Drive>>& drives,
                                   storage::AuditLog* audit)
    : leases_(leases), audit_(audit) {
  for (const auto& d : drives) drives_[d->config().name] = true;
}

absl::StatusOr<v1::Lease> LeaseServiceCore::AcquireLease(const v1::AcquireLeaseRequest& r,
                                                         const CallContext& c) {
  absl::string_view id = r.name();
  if (absl::StartsWith(id, "drives/")) id.remove_prefix(7);
  const std::string drive(id);
  absl::StatusOr<v1::Lease> out = [&]() -> absl::StatusOr<v1::Lease> {
    if (drive.empty() || absl::StrContains(drive, '/')) {
      return FieldError("name", absl::StrCat("'", r.name(), "' is not \"drives/{drive}\""));
    }
    if (drives_.count(drive) == 0) {
      return absl::NotFoundError(absl::StrCat("name: drives/", drive, " is not configured"));
    }
    auto ttl = LeaseTtl("ttl_s", r.ttl_s(), LeaseManager::kDefaultTtl);
    if (!ttl.ok()) return ttl.status();
    auto lease = leases_.Acquire(drive, c, *ttl);
    if (!lease.ok()) return lease.status();
    return ToProto(*lease, true);
  }();
  WriteAudit(audit_, c, drive, "AcquireLease", ToAuditJson(r), out.status());
  return out;
}

absl::StatusOr<v1::Lease> LeaseServiceCore::RenewLease(const v1::RenewLeaseRequest& r,
                                                       const CallContext& c) {
  std::string drive;
  absl::StatusOr<v1::Lease> out = [&]() -> absl::StatusOr<v1::Lease> {
    if (r.lease_id().empty()) return FieldError("lease_id", "is required");
    auto ttl = LeaseTtl("ttl_s", r.ttl_s(), Duration::zero());
    if (!ttl.ok()) return ttl.status();
    auto lease = leases_.Renew(r.lease_id(), c, *ttl);
    if (!lease.ok()) return lease.status();
    drive = lease->drive;
    return ToProto(*lease, true);
  }();
  WriteAudit(audit_, c, drive, "RenewLease", RedactedJson(r), out.status());
  return out;
}

absl::StatusOr<v1::ReleaseLeaseResponse> LeaseServiceCore::ReleaseLease(
    const v1::ReleaseLeaseRequest& r, const CallContext& c) {
  std::string drive;
  absl::StatusOr<v1::ReleaseLeaseResponse> out = [&]() -> absl::StatusOr<v1::ReleaseLeaseResponse> {
    if (r.lease_id().empty()) return FieldError("lease_id", "is required");
    auto lease = leases_.Release(r.lease_id(), c);
    if (!lease.ok()) return lease.status();
    drive = lease->drive;
    v1::ReleaseLeaseResponse resp;
    *resp.mutable_lease() = ToProto(*lease, false);
    return resp;
  }();
  WriteAudit(audit_, c, drive, "ReleaseLease", RedactedJson(r), out.status());
  return out;
}

absl::StatusOr<v1::ListLeasesResponse> LeaseServiceCore::ListLeases(const v1::ListLeasesRequest&,
                                                                    const CallContext&) {
  v1::ListLeasesResponse resp;
  for (const LeaseInfo& l : leases_.List()) *resp.add_leases() = ToProto(l, false);
  return resp;
}

}  // namespace drivegw::server
