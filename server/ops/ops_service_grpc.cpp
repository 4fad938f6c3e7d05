// OpsServiceGrpc: one line per RPC into the core, through CallAuth.
#include "server/ops/ops_service_grpc.h"

namespace drivegw::server {

grpc::ServerUnaryReactor* OpsServiceGrpc::SetWireTrace(grpc::CallbackServerContext* ctx,
                                                       const v1::SetWireTraceRequest* req,
                                                       v1::SetWireTraceResponse* resp) {
  return Offload(auth_, FullMethod(v1::OpsService::service_full_name(), "SetWireTrace"), pool_, ctx,
                 resp, [this, req](const CallContext& c) { return core_.SetWireTrace(*req, c); });
}

grpc::ServerUnaryReactor* OpsServiceGrpc::GetReadiness(grpc::CallbackServerContext* ctx,
                                                       const v1::GetReadinessRequest* req,
                                                       v1::Readiness* resp) {
  return Inline(auth_, FullMethod(v1::OpsService::service_full_name(), "GetReadiness"), ctx, resp,
                [this, req](const CallContext& c) { return core_.GetReadiness(*req, c); });
}

}  // namespace drivegw::server
