// The REST front end's direct read path (decision 1331): DriveService's read-only unary methods
// served in process on the Beast thread, through the same CallAuth check, RPC metrics and core
// calls as their gRPC handlers, without the in-process gRPC hop of decision 501.
#pragma once

#include <map>
#include <string>

#include "server/rest/router.h"

namespace drivegw::server {
class CallAuth;
class DriveServiceCore;
}  // namespace drivegw::server
namespace drivegw::ops {
class RpcMetrics;
}

namespace drivegw::rest {

// RouterOptions::direct_unary for ListDrives, GetDrive and GetCommand: the methods whose gRPC
// handlers already run inline (server/grpc/drive_service_grpc.cpp: cheap, non-blocking reads).
// Each call is authorised by `auth` (method role table, "auth.denied" audit), counted and timed
// in `metrics` with transport "rest", and finished with ToGrpcStatus, exactly as the gRPC
// handler and the RPC metrics interceptor do. All three must outlive the REST server.
std::map<std::string, DirectUnary> DriveServiceDirectReads(server::DriveServiceCore& core,
                                                           const server::CallAuth& auth,
                                                           const ops::RpcMetrics& metrics);

}  // namespace drivegw::rest
