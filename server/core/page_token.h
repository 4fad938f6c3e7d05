// Page tokens of ListParameterSets and ListCurveSets: the last set name of the page before.
#pragma once

#include <optional>
#include <string>

#include "absl/status/statusor.h"

namespace drivegw::server {

// The longest set name storage accepts (storage/versioned_set_store.cpp `ValidateName`), so the
// longest token a List call hands out.
inline constexpr size_t kMaxSetPageTokenBytes = 128;

// The set name `token` carries; nullopt for "" (the first page). Anything a List call cannot
// have handed out — longer than a set name, or a character outside [A-Za-z0-9._-] — is
// INVALID_ARGUMENT naming `page_token` and the rule, instead of silently paging from an
// arbitrary position (decision 1494).
absl::StatusOr<std::optional<std::string>> SetPageToken(const std::string& token);

}  // namespace drivegw::server
