// Import and export of parameter sets as files (issue 6, decision 011): JSON
// {"name", "family", "model", "description", "target_stored", "parameters": [{"parameter",
// "value"}]} and CSV "parameter,value" with a header line and '#' comments. Pure text <-> struct:
// names are resolved and values validated against the catalogue by the service, not here.
#pragma once

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "storage/parameter_set_repo.h"

namespace drivegw::server {

// Parses a file; InvalidArgument naming the line and field ("line 7, field value: 'abc' is not an
// integer"). CSV fills only values (name/family come from the request).
absl::StatusOr<storage::ParameterSet> ParseParameterSetJson(std::string_view content);
absl::StatusOr<storage::ParameterSet> ParseParameterSetCsv(std::string_view content);

std::string ParameterSetToJson(const storage::ParameterSet& set);
std::string ParameterSetToCsv(const storage::ParameterSet& set);

}  // namespace drivegw::server
