// absl::Status (with google.rpc payloads) -> grpc::Status carrying a serialized google.rpc.Status
// in its details, so clients get BadRequest field violations and ErrorInfo.
#pragma once

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace drivegw::server {

grpc::Status ToGrpcStatus(const absl::Status& s);

}  // namespace drivegw::server
