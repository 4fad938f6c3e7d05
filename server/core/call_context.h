// Who is calling, as the front end saw it; shared by the core and its per-stream objects.
#pragma once

#include <string>

namespace drivegw::server {

// principal is "anonymous" until authentication.
struct CallContext {
  std::string principal = "anonymous";
  // The principal's role name ("viewer", "operator", "engineer", "admin"); "" before
  // authentication (issue 7).
  std::string role;
  std::string source_address;
  std::string transport;  // "grpc" or "rest"
  // Client-chosen key of a mutating call (gRPC metadata / HTTP header `idempotency-key`): a retry
  // with the same key returns the first result (issue 7). "" = none.
  std::string idempotency_key;
  // Control lease id the caller presents (gRPC metadata `x-drivegw-lease`, HTTP header
  // `X-Drivegw-Lease`): proves holding a drive's lease, decision 019. "" = none.
  std::string lease_id;
};

}  // namespace drivegw::server
