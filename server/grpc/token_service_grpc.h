// Thin gRPC callback service over auth::TokenServiceCore (proto drivegw/v1/auth.proto): every
// call is authorised by CallAuth (admin) and runs on the worker pool (SQLite). No logic here.
#pragma once

#include "drivegw/v1/auth.grpc.pb.h"
#include "server/auth/token_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// Every TokenService RPC once: (method, request, response).
#define DGW_TOKEN_RPCS(X)                                 \
  X(CreateToken, CreateTokenRequest, CreateTokenResponse) \
  X(ListTokens, ListTokensRequest, ListTokensResponse)    \
  X(RevokeToken, RevokeTokenRequest, Token)

class TokenServiceGrpc final : public v1::TokenService::CallbackService {
 public:
  TokenServiceGrpc(auth::TokenServiceCore& core, WorkerPool& pool, const CallAuth& auth)
      : core_(core), pool_(pool), auth_(auth) {}

#define DGW_TOKEN_RPC(Method, Req, Resp)                                                 \
  grpc::ServerUnaryReactor* Method(grpc::CallbackServerContext* ctx, const v1::Req* req, \
                                   v1::Resp* resp) override;
  DGW_TOKEN_RPCS(DGW_TOKEN_RPC)
#undef DGW_TOKEN_RPC
  // The caller's principal and role as CallAuth found them (no core, no storage).
  grpc::ServerUnaryReactor* WhoAmI(grpc::CallbackServerContext* ctx, const v1::WhoAmIRequest* req,
                                   v1::WhoAmIResponse* resp) override;

 private:
  auth::TokenServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
};

}  // namespace drivegw::server
