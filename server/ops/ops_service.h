// OpsServiceCore (proto drivegw/v1/ops.proto): the per-drive wire trace switch and readiness.
// Front-end independent like the other cores; the gRPC service is ops_service_grpc.h.
#pragma once

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/ops.pb.h"
#include "server/core/call_context.h"
#include "server/ops/readiness.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

class OpsServiceCore {
 public:
  // `audit` may be null (tests without storage).
  OpsServiceCore(std::vector<std::shared_ptr<Drive>> drives, storage::AuditLog* audit,
                 const ops::Readiness& readiness)
      : drives_(std::move(drives)), audit_(audit), readiness_(readiness) {}

  // Drive::SetWireTrace on the named drive; one audit entry (action SetWireTrace) either way.
  absl::StatusOr<v1::SetWireTraceResponse> SetWireTrace(const v1::SetWireTraceRequest& r,
                                                        const CallContext& c);
  absl::StatusOr<v1::Readiness> GetReadiness(const v1::GetReadinessRequest& r,
                                             const CallContext& c);

 private:
  const std::vector<std::shared_ptr<Drive>> drives_;
  storage::AuditLog* const audit_;
  const ops::Readiness& readiness_;
};

}  // namespace drivegw::server
