// Readiness for GET /readyz (issue 7 "Operations"; decision 021): ready once storage is open and
// every configured drive has been tried (activation attempted, whatever its outcome), and not
// any more once shutdown began. Thread-safe; the gateway marks, the REST route asks.
#pragma once

#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace drivegw::ops {

class Readiness {
 public:
  void SetStorageOpen(bool open);
  // The drives that must be tried; replaces an earlier list.
  void ExpectDrives(const std::vector<std::string>& names);
  void MarkDriveTried(const std::string& name);
  void SetShuttingDown();

  // OK when ready; Unavailable naming the first reason otherwise ("storage not open",
  // "drives not tried yet: s1, d1", "shutting down").
  absl::Status Check() const;

 private:
  mutable std::mutex mu_;
  bool storage_open_ = false;
  bool shutting_down_ = false;
  std::vector<std::string> expected_;
  std::set<std::string> tried_;
};

}  // namespace drivegw::ops
