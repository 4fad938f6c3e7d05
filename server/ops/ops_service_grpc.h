// Thin gRPC callback service over OpsServiceCore, in the pattern of server/grpc/*_grpc.h: every
// call passes CallAuth (the one enforcement point, decision 015); SetWireTrace runs on the worker
// pool (its audit entry writes SQLite), GetReadiness inline.
#pragma once

#include "drivegw/v1/ops.grpc.pb.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"
#include "server/ops/ops_service.h"

namespace drivegw::server {

class OpsServiceGrpc final : public v1::OpsService::CallbackService {
 public:
  OpsServiceGrpc(OpsServiceCore& core, WorkerPool& pool, const CallAuth& auth)
      : core_(core), pool_(pool), auth_(auth) {}

  grpc::ServerUnaryReactor* SetWireTrace(grpc::CallbackServerContext* ctx,
                                         const v1::SetWireTraceRequest* req,
                                         v1::SetWireTraceResponse* resp) override;
  grpc::ServerUnaryReactor* GetReadiness(grpc::CallbackServerContext* ctx,
                                         const v1::GetReadinessRequest* req,
                                         v1::Readiness* resp) override;

 private:
  OpsServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
};

}  // namespace drivegw::server
