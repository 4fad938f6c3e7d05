// Applying a parameter set to drives safely (issue 6): validate every value against the family's
// catalogue first, read the pre-image, write, read back and compare every value, and on any failure
// restore the pre-image on that drive; the operation (with its pre-images) is stored as it runs:
// a drive's pre-image is stored (drive APPLYING) before its first write, so a process that dies
// mid-apply leaves a RUNNING row that start-up reports INTERRUPTED (decision 1441).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "adapters/core/parameter_catalogue.h"
#include "storage/parameter_set_repo.h"

namespace drivegw::server {

struct ApplyRequest {
  storage::ParameterSet set;   // the version to apply (values resolved: id filled in)
  std::vector<Drive*> drives;  // each must be of set.family
  bool dry_run = false;        // read and compare only: report what would change, write nothing
  std::string principal;
  // Restore of a pre-image (decision 1441): when not empty, one value list per drive (same
  // order as `drives`) replaces set.values, and `restores` names the operation ("op-7").
  std::vector<std::vector<storage::ParameterValue>> per_drive_values;
  std::string restores;
};

// What one drive would get (dry run) or got: per parameter current vs set value.
struct ParameterChange {
  std::string parameter;
  uint32_t id = 0;
  int64_t current = 0;
  int64_t target = 0;
  bool differs = false;
};

class ParameterApplier {
 public:
  // `repo` and `catalogues` must outlive the applier.
  ParameterApplier(storage::ParameterSetRepo& repo, const CatalogueList& catalogues);
  ~ParameterApplier();  // waits for running operations to finish

  // Checks the request synchronously (family match, every value against the catalogue: an
  // InvalidArgument naming the parameter, drive and limit, nothing written), stores the operation
  // RUNNING and returns it; the work continues on a background thread (one per operation, drives in
  // sequence) updating the stored operation as each drive finishes. `on_done` (optional) is called
  // with the final operation.
  absl::StatusOr<storage::ApplyOperation> Start(
      ApplyRequest request, std::function<void(const storage::ApplyOperation&)> on_done = nullptr);
  // Runs the same steps on the caller's thread and returns the final operation (tests, bench).
  absl::StatusOr<storage::ApplyOperation> Run(ApplyRequest request);

  // Set vs drive: reads every parameter of `set` from `drive` (no writes).
  absl::StatusOr<std::vector<ParameterChange>> Diff(const storage::ParameterSet& set, Drive& drive);
  // The catalogue of a family; NotFound naming it.
  absl::StatusOr<const ParameterCatalogue*> Catalogue(const std::string& family) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drivegw::server
