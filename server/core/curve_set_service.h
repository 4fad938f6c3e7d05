// The core of CurveSetService (issue 6 "Curve sets", decision 014), behind both gRPC and REST:
// CRUD + versions on CurveSetRepo with every shape violation reported at once, plots of one curve,
// validation against a drive's axis naming the field and the limit, DownloadCurve / RunCurve on a
// drive (checked against its axis first, decision 013), and one audit entry for every mutating
// call (create/update/delete with before/after; download with curve ID, hash and drive; run with
// drive, curve and command).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "server/core/call_context.h"
#include "server/core/lease_manager.h"
#include "storage/curve_set_repo.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

class CurveSetServiceCore {
 public:
  // `repo` must outlive the core; `audit` may be null (tests without storage); `leases` (may be
  // null: none) is checked before DownloadCurve and RunCurve touch a drive (decision 019).
  CurveSetServiceCore(storage::CurveSetRepo& repo, std::vector<std::shared_ptr<Drive>> drives,
                      storage::AuditLog* audit, const LeaseManager* leases = nullptr);

  absl::StatusOr<v1::CurveSet> CreateCurveSet(const v1::CreateCurveSetRequest& r,
                                              const CallContext& c);
  absl::StatusOr<v1::CurveSet> GetCurveSet(const v1::GetCurveSetRequest& r, const CallContext& c);
  absl::StatusOr<v1::ListCurveSetsResponse> ListCurveSets(const v1::ListCurveSetsRequest& r,
                                                          const CallContext& c);
  absl::StatusOr<v1::CurveSet> UpdateCurveSet(const v1::UpdateCurveSetRequest& r,
                                              const CallContext& c);
  absl::StatusOr<v1::DeleteCurveSetResponse> DeleteCurveSet(const v1::DeleteCurveSetRequest& r,
                                                            const CallContext& c);
  absl::StatusOr<v1::ListCurveSetVersionsResponse> ListCurveSetVersions(
      const v1::ListCurveSetVersionsRequest& r, const CallContext& c);
  absl::StatusOr<v1::CurveSetVersion> GetCurveSetVersion(const v1::GetCurveSetVersionRequest& r,
                                                         const CallContext& c);
  absl::StatusOr<v1::CurvePlot> GetCurvePlot(const v1::GetCurvePlotRequest& r,
                                             const CallContext& c);
  absl::StatusOr<v1::ValidateCurveSetResponse> ValidateCurveSet(
      const v1::ValidateCurveSetRequest& r, const CallContext& c);
  // Blocks on the drive (curve service transfer and read-back).
  absl::StatusOr<v1::DownloadCurveResponse> DownloadCurve(const v1::DownloadCurveRequest& r,
                                                          const CallContext& c);
  // Returns once the drive accepted the curve (the handle is ACTIVE or already final).
  absl::StatusOr<v1::CommandHandle> RunCurve(const v1::RunCurveRequest& r, const CallContext& c);

 private:
  // The curves of a set at `version` (0 = newest); `version_out` gets the version number.
  absl::StatusOr<std::vector<Curve>> CurvesAt(const std::string& name, int version,
                                              int* version_out);
  // One named curve of a set (version) and its index; NotFound naming the set and the curve.
  absl::StatusOr<Curve> CurveAt(const std::string& name, const std::string& curve, int version,
                                int* version_out, size_t* index_out);
  absl::StatusOr<Drive*> FindDrive(const std::string& field, const std::string& name) const;
  // Create (update false) or conditional Update of the set `in` for `action`, with its one audit
  // entry: the request when refused, the set before (Update) and after when stored.
  absl::StatusOr<v1::CurveSet> StoreCurveSet(const char* action,
                                             const google::protobuf::Message& request,
                                             const v1::CurveSet& in, bool update,
                                             const std::string& etag, const std::string& comment,
                                             const CallContext& c);

  // What a download or run addresses, filled as far as it could be resolved (the audit entry
  // names as much as is known even when a later step failed).
  struct CurveTarget {
    std::string drive_name;  // the request's text until the drive is found, then its name
    Drive* drive = nullptr;
    std::string set;  // set id, once valid
    int version = 0;  // once the curve was found
    size_t index = 0;
    Curve curve;
  };
  // Finds the drive, honours its lease (decision 019), loads the curve and checks it against the
  // drive's axis (decision 013: a curve the axis cannot follow never reaches the drive).
  absl::Status ResolveTarget(const std::string& drive, const std::string& set,
                             const std::string& curve, int version, const CallContext& c,
                             CurveTarget* target);

  storage::CurveSetRepo& repo_;
  std::vector<std::shared_ptr<Drive>> drives_;
  std::map<std::string, Drive*> by_name_;
  storage::AuditLog* audit_;
  const LeaseManager* leases_;
};

// "curveSets/x" or "x" -> "x"; InvalidArgument naming `field` otherwise.
absl::StatusOr<std::string> CurveSetId(const std::string& field, const std::string& name);

// Every problem of `set` without an axis (shape, LinMot ranges, unique names and IDs), or with
// `axis` also stroke/velocity/acceleration at every point: one violation per problem, field
// "curves[i].<sub>" below `field_prefix` ("curve_set." or ""), description
// "curves[i] 'name': <sub>: <value> <limit>".
std::vector<v1::CurveViolation> CurveSetViolations(const std::vector<Curve>& curves,
                                                   const AxisConfig* axis,
                                                   const std::string& field_prefix);
// OK for no violations; else `code` with the first description (and "(and N more)") as message
// and every violation in a google.rpc.BadRequest.
absl::Status ViolationsStatus(const std::vector<v1::CurveViolation>& violations,
                              absl::StatusCode code);

}  // namespace drivegw::server
