// LeaseServiceGrpc: one line per RPC into the core, each on the worker pool (an idempotent retry
// may wait for its first call there).
#include "server/grpc/lease_service_grpc.h"

namespace drivegw::server {

#define DGW_LEASE_RPC(Method, Req, Resp)                                                          \
  grpc::ServerUnaryReactor* LeaseServiceGrpc::Method(grpc::CallbackServerContext* ctx,            \
                                                     const v1::Req* req, v1::Resp* resp) {        \
    return Offload(auth_, FullMethod(v1::LeaseService::service_full_name(), #Method), pool_, ctx, \
                   resp, [this, req](const CallContext& c) {                                      \
                     return RunIdempotent(idempotency_, "drivegw.v1.LeaseService/" #Method, *req, \
                                          c, [&] { return core_.Method(*req, c); });              \
                   });                                                                            \
  }
DGW_LEASE_RPCS(DGW_LEASE_RPC)
#undef DGW_LEASE_RPC

}  // namespace drivegw::server
