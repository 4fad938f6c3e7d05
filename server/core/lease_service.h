// The core of LeaseService (issue 7, decision 019) behind gRPC and REST: checks the request,
// runs the LeaseManager, converts to the API and writes one audit entry per mutating call.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/leases.pb.h"
#include "server/core/call_context.h"
#include "server/core/lease_manager.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

class LeaseServiceCore {
 public:
  // `leases` must outlive the core; `audit` may be null (tests without storage).
  LeaseServiceCore(LeaseManager& leases, const std::vector<std::shared_ptr<Drive>>& drives,
                   storage::AuditLog* audit);

  absl::StatusOr<v1::Lease> AcquireLease(const v1::AcquireLeaseRequest& r, const CallContext& c);
  absl::StatusOr<v1::Lease> RenewLease(const v1::RenewLeaseRequest& r, const CallContext& c);
  absl::StatusOr<v1::ReleaseLeaseResponse> ReleaseLease(const v1::ReleaseLeaseRequest& r,
                                                        const CallContext& c);
  absl::StatusOr<v1::ListLeasesResponse> ListLeases(const v1::ListLeasesRequest& r,
                                                    const CallContext& c);

 private:
  LeaseManager& leases_;
  std::map<std::string, bool> drives_;  // configured drive names
  storage::AuditLog* audit_;
};

// ttl_s of a request: 0 -> `if_zero`; else kMinTtl..kMaxTtl, else OutOfRange naming `field`.
absl::StatusOr<Duration> LeaseTtl(const std::string& field, double ttl_s, Duration if_zero);

}  // namespace drivegw::server
