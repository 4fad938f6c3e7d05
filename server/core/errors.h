// Error construction for the service core: absl::Status with google.rpc detail payloads, so
// every front end (gRPC, REST) reports the field and the limit the same way.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"

namespace drivegw::server {

// Payload type URLs; the gRPC edge packs payloads with these URLs into google.rpc.Status.
inline constexpr std::string_view kBadRequestUrl = "type.googleapis.com/google.rpc.BadRequest";
inline constexpr std::string_view kErrorInfoUrl = "type.googleapis.com/google.rpc.ErrorInfo";

struct FieldViolation {
  std::string field;
  std::string description;
};

// InvalidArgument (or `code`) whose message is "field: description" and whose payload is a
// google.rpc.BadRequest naming the field.
absl::Status FieldError(std::string_view field, std::string_view description,
                        absl::StatusCode code = absl::StatusCode::kInvalidArgument);
absl::Status FieldErrors(const std::vector<FieldViolation>& violations,
                         absl::StatusCode code = absl::StatusCode::kInvalidArgument);

// Attaches google.rpc.ErrorInfo{reason, domain "drivegw", metadata} — used for the drive's own
// fault code (e.g. LinMot error code) riding along with a FailedPrecondition.
absl::Status WithErrorInfo(absl::Status status, std::string_view reason,
                           const std::vector<std::pair<std::string, std::string>>& metadata);

}  // namespace drivegw::server
