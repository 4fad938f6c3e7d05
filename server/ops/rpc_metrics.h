// Per-RPC metrics (issue 7 "Operations"; decision 021): a gRPC server interceptor that counts
// every call by service, method, transport and status code and times it; calls naming a
// configured drive (the request's `name` field) also count per drive and family. REST calls
// are in-process gRPC calls, so they pass here too (transport="rest").
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include <map>
#include <memory>
#include <string>

#include "server/ops/metrics.h"

namespace drivegw::ops {

// `drive_families`: drive name -> family, for the per-drive series. `registry` must outlive the
// server.
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    Registry& registry, std::map<std::string, std::string> drive_families);

}  // namespace drivegw::ops
