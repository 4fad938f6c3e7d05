// DriveServiceGrpc: one line per RPC into the core; blocking calls run on the worker pool.
#include "server/grpc/drive_service_grpc.h"

#include "server/grpc/call_auth.h"
#include "server/grpc/cyclic_reactor.h"
#include "server/grpc/inline_completion.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

// The full method name the role table knows this service's `method` by.
std::string RpcName(const char* method) {
  return FullMethod(v1::DriveService::service_full_name(), method);
}

}  // namespace

grpc::ServerUnaryReactor* DriveServiceGrpc::ListDrives(grpc::CallbackServerContext* ctx,
                                                       const v1::ListDrivesRequest* req,
                                                       v1::ListDrivesResponse* resp) {
  return Inline(auth_, RpcName("ListDrives"), ctx, resp,
                [&](const CallContext& c) { return core_.ListDrives(*req, c); });
}
grpc::ServerUnaryReactor* DriveServiceGrpc::GetDrive(grpc::CallbackServerContext* ctx,
                                                     const v1::GetDriveRequest* req,
                                                     v1::Drive* resp) {
  return Inline(auth_, RpcName("GetDrive"), ctx, resp,
                [&](const CallContext& c) { return core_.GetDrive(*req, c); });
}
grpc::ServerUnaryReactor* DriveServiceGrpc::GetCommand(grpc::CallbackServerContext* ctx,
                                                       const v1::GetCommandRequest* req,
                                                       v1::CommandHandle* resp) {
  return Inline(auth_, RpcName("GetCommand"), ctx, resp,
                [&](const CallContext& c) { return core_.GetCommand(*req, c); });
}
grpc::ServerWriteReactor<grpc::ByteBuffer>* DriveServiceGrpc::WatchDrives(
    grpc::CallbackServerContext* ctx, const grpc::ByteBuffer* req) {
  absl::StatusOr<CallContext> cc = auth_.Authorize(*ctx, RpcName("WatchDrives"));
  if (!cc.ok()) return new RefusedWriter<grpc::ByteBuffer>(cc.status());  // deletes itself
  absl::StatusOr<v1::WatchDrivesRequest> r = ParseWatchRequest(*req);
  if (!r.ok()) return new RefusedWriter<grpc::ByteBuffer>(r.status());
  return watch_.Start(core_.OpenWatch(*r, *cc));  // deletes itself in OnDone
}

grpc::ServerReadReactor<v1::CyclicSetpointRequest>* DriveServiceGrpc::StreamCyclicSetpoints(
    grpc::CallbackServerContext* ctx, v1::CyclicStreamSummary* resp) {
  absl::StatusOr<CallContext> cc = auth_.Authorize(*ctx, RpcName("StreamCyclicSetpoints"));
  if (!cc.ok()) return new RefusedReader<v1::CyclicSetpointRequest>(cc.status());  // deletes itself
  return NewCyclicSetpointReactor(core_, pool_, ctx, resp, *std::move(cc));
}

// MoveAbsolute without a blocked worker (issue 10, P1; decision 1301): the drive sends the command
// at once and the reply is finished from its completion after the durable audit entry — on this
// callback thread when the drive answers within 1 ms (decision 1302), else on a pool thread. Only a
// call that needs the blocking hooks keeps the pool path: an idempotency key (IdempotencyCache::Run
// waits for the first call) goes through DGW_OFFLOAD's path below, and a bearer token
// (TokenRepo::Verify reads SQLite) is checked on the pool, which then only starts the move.
// Otherwise the credentials are checked here as Inline does (in memory).
grpc::ServerUnaryReactor* DriveServiceGrpc::MoveAbsolute(grpc::CallbackServerContext* ctx,
                                                         const v1::MoveAbsoluteRequest* req,
                                                         v1::CommandHandle* resp) {
  static const std::string kMethod = RpcName("MoveAbsolute");
  CallCredentials credentials = CallAuth::Credentials(*ctx, kMethod);
  if (idempotency_ != nullptr && !credentials.base.idempotency_key.empty()) {
    return Offload(auth_, kMethod, pool_, ctx, resp, [this, req](const CallContext& c) {
      return RunIdempotent(idempotency_, "drivegw.v1.DriveService/MoveAbsolute", *req, c,
                           [&] { return core_.MoveAbsolute(*req, c); });
    });
  }
  auto* reactor = ctx->DefaultReactor();
  // `req` and `resp` stay valid until Finish; the completion runs once, on `executor`: inline on
  // this thread when the drive answers within InlineCompletion::kMaxWait (decision 1302), else on
  // a pool thread. The completion keeps the executor alive until the drive posted it.
  auto start = [this, reactor, req, resp](const CallCredentials& credentials, bool may_wait) {
    absl::StatusOr<CallContext> cc = auth_.Check(credentials);
    if (!cc.ok()) {
      reactor->Finish(ToGrpcStatus(cc.status()));
      return;
    }
    auto finish = [reactor, resp](absl::StatusOr<v1::CommandHandle> handle) {
      if (handle.ok()) *resp = *std::move(handle);
      reactor->Finish(ToGrpcStatus(handle.status()));
    };
    if (!may_wait) {  // already on a pool thread: complete on the pool
      core_.MoveAbsoluteAsync(*req, *cc, pool_, std::move(finish));
      return;
    }
    auto executor = std::make_shared<InlineCompletion>(pool_);
    core_.MoveAbsoluteAsync(
        *req, *cc, *executor,
        [finish = std::move(finish), executor](absl::StatusOr<v1::CommandHandle> handle) mutable {
          finish(std::move(handle));
        });
    executor->WaitAndRun();
  };
  if (!credentials.authorization.empty()) {
    pool_.Post([start, credentials = std::move(credentials)] { start(credentials, false); });
  } else {
    start(credentials, true);
  }
  return reactor;
}

// Every offloaded call passes the idempotency hook (decision 020; reads pass straight through).
#define DGW_OFFLOAD(Method, Req, Resp)                                                            \
  grpc::ServerUnaryReactor* DriveServiceGrpc::Method(grpc::CallbackServerContext* ctx,            \
                                                     const Req* req, Resp* resp) {                \
    return Offload(auth_, RpcName(#Method), pool_, ctx, resp, [this, req](const CallContext& c) { \
      return RunIdempotent(idempotency_, "drivegw.v1.DriveService/" #Method, *req, c,             \
                           [&] { return core_.Method(*req, c); });                                \
    });                                                                                           \
  }

DGW_OFFLOAD(Enable, v1::EnableRequest, v1::CommandHandle)
DGW_OFFLOAD(Disable, v1::DisableRequest, v1::CommandHandle)
DGW_OFFLOAD(Home, v1::HomeRequest, v1::CommandHandle)
DGW_OFFLOAD(MoveRelative, v1::MoveRelativeRequest, v1::CommandHandle)
DGW_OFFLOAD(MoveVelocity, v1::MoveVelocityRequest, v1::CommandHandle)
DGW_OFFLOAD(MoveCoordinated, v1::MoveCoordinatedRequest, v1::MoveCoordinatedResponse)
DGW_OFFLOAD(Stop, v1::StopRequest, v1::CommandHandle)
DGW_OFFLOAD(AcknowledgeFault, v1::AcknowledgeFaultRequest, v1::CommandHandle)
DGW_OFFLOAD(ReadParameter, v1::ReadParameterRequest, v1::Parameter)
DGW_OFFLOAD(WriteParameter, v1::WriteParameterRequest, v1::Parameter)
DGW_OFFLOAD(SendNativeCommand, v1::SendNativeCommandRequest, v1::NativeCommandResponse)
#undef DGW_OFFLOAD

}  // namespace drivegw::server
