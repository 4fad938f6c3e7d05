// Readiness bookkeeping (readiness.h).
#include "server/ops/readiness.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace drivegw::ops {

void Readiness::SetStorageOpen(bool open) {
  std::lock_guard lock(mu_);
  storage_open_ = open;
}

void Readiness::ExpectDrives(const std::vector<std::string>& names) {
  std::lock_guard lock(mu_);
  expected_ = names;
}

void Readiness::MarkDriveTried(const std::string& name) {
  std::lock_guard lock(mu_);
  tried_.insert(name);
}

void Readiness::SetShuttingDown() {
  std::lock_guard lock(mu_);
  shutting_down_ = true;
}

absl::Status Readiness::Check() const {
  std::lock_guard lock(mu_);
  if (shutting_down_) return absl::UnavailableError("shutting down");
  if (!storage_open_) return absl::UnavailableError("storage not open");
  std::vector<std::string> pending;
  for (const std::string& name : expected_) {
    if (tried_.count(name) == 0) pending.push_back(name);
  }
  if (!pending.empty()) {
    return absl::UnavailableError(
        absl::StrCat("drives not tried yet: ", absl::StrJoin(pending, ", ")));
  }
  return absl::OkStatus();
}

}  // namespace drivegw::ops
