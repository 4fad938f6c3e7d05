// JSON text of the parameter-set columns: a version's values and an operation's per-drive results.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "storage/parameter_set_repo.h"

namespace drivegw::storage {

// [{"parameter":"$14.vmax","id":14,"value":300}, ...]. InvalidArgument when a text is not UTF-8.
absl::StatusOr<std::string> ValuesToJson(const std::vector<ParameterValue>& values);
// DataLoss naming `what` (e.g. "set 'x' version 3") when the text is not of that shape.
absl::StatusOr<std::vector<ParameterValue>> ValuesFromJson(std::string_view json,
                                                           std::string_view what);

// [{"drive":"x1","state":"APPLIED","pre_image":[...],"written":[...],"failed_parameter":"",
//   "error":""}, ...]
absl::StatusOr<std::string> DrivesToJson(const std::vector<ApplyDriveResult>& drives);
absl::StatusOr<std::vector<ApplyDriveResult>> DrivesFromJson(std::string_view json,
                                                             std::string_view what);

}  // namespace drivegw::storage
