// TokenServiceGrpc: one line per RPC into the core, each authorised and on the worker pool.
#include "server/grpc/token_service_grpc.h"

namespace drivegw::server {

#define DGW_TOKEN_RPC(Method, Req, Resp)                                                          \
  grpc::ServerUnaryReactor* TokenServiceGrpc::Method(grpc::CallbackServerContext* ctx,            \
                                                     const v1::Req* req, v1::Resp* resp) {        \
    return Offload(auth_, FullMethod(v1::TokenService::service_full_name(), #Method), pool_, ctx, \
                   resp, [this, req](const CallContext& c) { return core_.Method(*req, c); });    \
  }
DGW_TOKEN_RPCS(DGW_TOKEN_RPC)
#undef DGW_TOKEN_RPC

grpc::ServerUnaryReactor* TokenServiceGrpc::WhoAmI(grpc::CallbackServerContext* ctx,
                                                   const v1::WhoAmIRequest* /*req*/,
                                                   v1::WhoAmIResponse* resp) {
  const bool enabled = auth_.authenticator().enabled();
  return Inline(auth_, FullMethod(v1::TokenService::service_full_name(), "WhoAmI"), ctx, resp,
                [enabled](const CallContext& c) -> absl::StatusOr<v1::WhoAmIResponse> {
                  v1::WhoAmIResponse r;
                  r.set_principal(c.principal);
                  r.set_role(c.role);
                  r.set_auth_enabled(enabled);
                  return r;
                });
}

}  // namespace drivegw::server
