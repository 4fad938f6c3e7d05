// ParameterSetServiceGrpc: one line per RPC into the core, each on the worker pool.
#include "server/grpc/parameter_set_service_grpc.h"

namespace drivegw::server {
#define DGW_PS_RPC(Method, Req, Resp)                                                              \
  grpc::ServerUnaryReactor* ParameterSetServiceGrpc::Method(grpc::CallbackServerContext* ctx,      \
                                                            const v1::Req* req, v1::Resp* resp) {  \
    return Offload(auth_, FullMethod(v1::ParameterSetService::service_full_name(), #Method),       \
                   pool_, ctx, resp, [this, req](const CallContext& c) {                           \
                     return RunIdempotent(idempotency_, "drivegw.v1.ParameterSetService/" #Method, \
                                          *req, c, [&] { return core_.Method(*req, c); });         \
                   });                                                                             \
  }
DGW_PARAMETER_SET_RPCS(DGW_PS_RPC)
#undef DGW_PS_RPC

}  // namespace drivegw::server
