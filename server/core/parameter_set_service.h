// The core of ParameterSetService (issue 6, decision 011), behind both gRPC and REST: resolves
// every parameter through the family catalogue (canonical name + id stored), validates values on
// create/update/import, captures/diffs/applies through ParameterApplier, and writes one audit
// entry (with before/after, or the diff) for every mutating call.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "adapters/core/parameter_catalogue.h"
#include "drivegw/v1/parameter_sets.pb.h"
#include "server/core/call_context.h"
#include "server/core/lease_manager.h"
#include "server/core/parameter_apply.h"
#include "storage/parameter_set_repo.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

class ParameterSetServiceCore {
 public:
  // Every reference must outlive the core; `audit` may be null (tests without storage).
  ParameterSetServiceCore(storage::ParameterSetRepo& repo, ParameterApplier& applier,
                          const CatalogueList& catalogues,
                          std::vector<std::shared_ptr<Drive>> drives, storage::AuditLog* audit,
                          const LeaseManager* leases = nullptr);

  absl::StatusOr<v1::ListParameterDefinitionsResponse> ListParameterDefinitions(
      const v1::ListParameterDefinitionsRequest& r, const CallContext& c);
  absl::StatusOr<v1::ParameterSet> CreateParameterSet(const v1::CreateParameterSetRequest& r,
                                                      const CallContext& c);
  absl::StatusOr<v1::ParameterSet> GetParameterSet(const v1::GetParameterSetRequest& r,
                                                   const CallContext& c);
  absl::StatusOr<v1::ListParameterSetsResponse> ListParameterSets(
      const v1::ListParameterSetsRequest& r, const CallContext& c);
  absl::StatusOr<v1::ParameterSet> UpdateParameterSet(const v1::UpdateParameterSetRequest& r,
                                                      const CallContext& c);
  absl::StatusOr<v1::DeleteParameterSetResponse> DeleteParameterSet(
      const v1::DeleteParameterSetRequest& r, const CallContext& c);
  absl::StatusOr<v1::ListParameterSetVersionsResponse> ListParameterSetVersions(
      const v1::ListParameterSetVersionsRequest& r, const CallContext& c);
  absl::StatusOr<v1::ParameterSetVersion> GetParameterSetVersion(
      const v1::GetParameterSetVersionRequest& r, const CallContext& c);
  // Blocks on the drive (reads).
  absl::StatusOr<v1::ParameterSet> CaptureParameterSet(const v1::CaptureParameterSetRequest& r,
                                                       const CallContext& c);
  // Blocks on the drive when comparing with one.
  absl::StatusOr<v1::DiffParameterSetResponse> DiffParameterSet(
      const v1::DiffParameterSetRequest& r, const CallContext& c);
  // Returns the operation at once; the writes run in the applier's background thread.
  absl::StatusOr<v1::Operation> ApplyParameterSet(const v1::ApplyParameterSetRequest& r,
                                                  const CallContext& c);
  absl::StatusOr<v1::Operation> GetOperation(const v1::GetOperationRequest& r,
                                             const CallContext& c);
  // Applies the pre-images of a finished operation (decision 1441); needs the drives' leases
  // like an apply.
  absl::StatusOr<v1::Operation> RestoreOperation(const v1::RestoreOperationRequest& r,
                                                 const CallContext& c);
  // Start-up: RUNNING operations of a previous process become INTERRUPTED, one audit entry each.
  // Call before the API serves. Returns how many there were.
  absl::StatusOr<int> MarkInterrupted();
  absl::StatusOr<v1::ListOperationsResponse> ListOperations(const v1::ListOperationsRequest& r,
                                                            const CallContext& c);
  absl::StatusOr<v1::ParameterSet> ImportParameterSet(const v1::ImportParameterSetRequest& r,
                                                      const CallContext& c);
  absl::StatusOr<v1::ExportParameterSetResponse> ExportParameterSet(
      const v1::ExportParameterSetRequest& r, const CallContext& c);

 private:
  absl::StatusOr<const ParameterCatalogue*> Catalogue(const std::string& field,
                                                      const std::string& family) const;
  // Resolves names to canonical name + id and validates every value; errors name
  // `field`[i] ("parameter_set.parameters[2].value"), the parameter and the limit.
  absl::Status Resolve(const std::string& field, const ParameterCatalogue& catalogue,
                       std::vector<storage::ParameterValue>& values) const;
  absl::StatusOr<Drive*> FindDrive(const std::string& field, const std::string& name) const;
  // A set at `version` (0 = newest) as the applier takes it.
  absl::StatusOr<storage::ParameterSet> SetAt(const std::string& name, int version,
                                              const char* version_field = "version");
  // Create-or-new-version used by create, capture and import; audits `action`.
  absl::StatusOr<v1::ParameterSet> Store(const std::string& action, storage::ParameterSet set,
                                         bool create, const std::string& etag,
                                         const std::string& comment, const CallContext& c);
  void Audit(const CallContext& c, const std::string& drive, const std::string& action,
             const std::string& json, const absl::Status& result);

  storage::ParameterSetRepo& repo_;
  ParameterApplier& applier_;
  const CatalogueList& catalogues_;
  std::vector<std::shared_ptr<Drive>> drives_;
  std::map<std::string, Drive*> by_name_;
  storage::AuditLog* audit_;
  const LeaseManager* leases_;  // may be null; checked before an apply writes (decision 019)
};

// "parameterSets/x" or "x" -> "x"; InvalidArgument naming `field` otherwise.
absl::StatusOr<std::string> ParameterSetId(const std::string& field, const std::string& name);

}  // namespace drivegw::server
