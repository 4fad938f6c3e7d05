// CurveSetServiceGrpc: one line per RPC into the core, each on the worker pool.
#include "server/grpc/curve_set_service_grpc.h"

namespace drivegw::server {
#define DGW_CS_RPC(Method, Req, Resp)                                                           \
  grpc::ServerUnaryReactor* CurveSetServiceGrpc::Method(grpc::CallbackServerContext* ctx,       \
                                                        const v1::Req* req, v1::Resp* resp) {   \
    return Offload(auth_, FullMethod(v1::CurveSetService::service_full_name(), #Method), pool_, \
                   ctx, resp, [this, req](const CallContext& c) {                               \
                     return RunIdempotent(idempotency_, "drivegw.v1.CurveSetService/" #Method,  \
                                          *req, c, [&] { return core_.Method(*req, c); });      \
                   });                                                                          \
  }
DGW_CURVE_SET_RPCS(DGW_CS_RPC)
#undef DGW_CS_RPC

}  // namespace drivegw::server
