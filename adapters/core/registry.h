// Family name -> factory. Filled by the composition root (server/), so core never includes a
// family and a family never includes another.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"

namespace drivegw {

using DriveFactory =
    std::function<absl::StatusOr<std::unique_ptr<Drive>>(const DriveConfig&, const Clock&)>;

class DriveRegistry {
 public:
  void Register(std::string family, DriveFactory factory) {
    factories_[std::move(family)] = std::move(factory);
  }
  std::vector<std::string> Families() const {
    std::vector<std::string> out;
    for (const auto& [name, f] : factories_) out.push_back(name);
    return out;
  }
  absl::StatusOr<std::unique_ptr<Drive>> Create(const DriveConfig& config, const Clock& clock) const {
    auto it = factories_.find(config.family);
    if (it == factories_.end()) {
      return absl::InvalidArgumentError(absl::StrCat("drive '", config.name, "'.family: '",
                                                     config.family, "' is not one of [",
                                                     absl::StrJoin(Families(), ", "), "]"));
    }
    return it->second(config, clock);
  }

 private:
  std::map<std::string, DriveFactory> factories_;
};

}  // namespace drivegw
