// gRPC side of StreamCyclicSetpoints: a callback-API client-streaming reactor over the core's
// CyclicSetpointStream (docs/decisions/008-cyclic-setpoint-stream.md).
#pragma once

#include <grpcpp/grpcpp.h>

#include "drivegw/v1/drive.pb.h"
#include "server/core/drive_service.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// Starts reading at once and deletes itself in OnDone (callback API ownership). `cc` is the
// call's authorised context (CallAuth::Authorize, decision 015).
grpc::ServerReadReactor<v1::CyclicSetpointRequest>* NewCyclicSetpointReactor(
    DriveServiceCore& core, WorkerPool& pool, grpc::CallbackServerContext* ctx,
    v1::CyclicStreamSummary* response, CallContext cc);

}  // namespace drivegw::server
