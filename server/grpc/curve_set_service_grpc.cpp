// CurveSetServiceGrpc: one line per RPC into the core, each on the worker pool.
#include "server/grpc/curve_set_service_grpc.h"

#include "server/grpc/drive_service_grpc.h"  // ContextFrom
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

// Runs fn(ctx) on the worker pool (SQLite, drive calls) and finishes from there.
template <typename Resp, typename Fn>
grpc::ServerUnaryReactor* Offload(WorkerPool& pool, grpc::CallbackServerContext* ctx, Resp* resp,
                                  Fn fn) {
  auto* reactor = ctx->DefaultReactor();
  CallContext cc = ContextFrom(*ctx);
  pool.Post([reactor, resp, fn = std::move(fn), cc = std::move(cc)]() mutable {
    auto result = fn(cc);
    if (result.ok()) *resp = *std::move(result);
    reactor->Finish(ToGrpcStatus(result.status()));
  });
  return reactor;
}

}  // namespace

#define DGW_CS_RPC(Method, Req, Resp)                                                         \
  grpc::ServerUnaryReactor* CurveSetServiceGrpc::Method(grpc::CallbackServerContext* ctx,     \
                                                        const v1::Req* req, v1::Resp* resp) { \
    return Offload(pool_, ctx, resp,                                                          \
                   [this, req](const CallContext& c) { return core_.Method(*req, c); });      \
  }
DGW_CURVE_SET_RPCS(DGW_CS_RPC)
#undef DGW_CS_RPC

}  // namespace drivegw::server
