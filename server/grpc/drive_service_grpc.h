// Thin gRPC callback service: decodes the call context, runs the core (blocking work on the
// worker pool), and finishes with ToGrpcStatus. No logic lives here.
#pragma once

#include <memory>
#include <string_view>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/core/idempotency.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/watch_reactor.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// WatchDrives is a raw (ByteBuffer) method: its streams write bytes serialised once per snapshot
// for all of them (server/grpc/watch_reactor.h, decision 1341); the wire format is unchanged.
class DriveServiceGrpc final : public v1::DriveService::WithRawCallbackMethod_WatchDrives<
                                   v1::DriveService::CallbackService> {
 public:
  // The full names of the methods this service registers raw, for whoever inspects messages by
  // method (ops::RpcMetrics must not read a ByteBuffer as a protobuf Message).
  static constexpr std::string_view kRawMethods[] = {"/drivegw.v1.DriveService/WatchDrives"};

  // `idempotency` may be null (no idempotent retries, decision 020).
  // Every call is authorised by `auth` (decision 015).
  DriveServiceGrpc(DriveServiceCore& core, WorkerPool& pool, const CallAuth& auth,
                   IdempotencyCache* idempotency = nullptr)
      : core_(core), pool_(pool), auth_(auth), idempotency_(idempotency) {}

  grpc::ServerUnaryReactor* ListDrives(grpc::CallbackServerContext* ctx,
                                       const v1::ListDrivesRequest* req,
                                       v1::ListDrivesResponse* resp) override;
  grpc::ServerUnaryReactor* GetDrive(grpc::CallbackServerContext* ctx,
                                     const v1::GetDriveRequest* req, v1::Drive* resp) override;
  grpc::ServerWriteReactor<grpc::ByteBuffer>* WatchDrives(grpc::CallbackServerContext* ctx,
                                                          const grpc::ByteBuffer* req) override;
  grpc::ServerUnaryReactor* Enable(grpc::CallbackServerContext* ctx, const v1::EnableRequest* req,
                                   v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* Disable(grpc::CallbackServerContext* ctx, const v1::DisableRequest* req,
                                    v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* Home(grpc::CallbackServerContext* ctx, const v1::HomeRequest* req,
                                 v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* MoveAbsolute(grpc::CallbackServerContext* ctx,
                                         const v1::MoveAbsoluteRequest* req,
                                         v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* MoveRelative(grpc::CallbackServerContext* ctx,
                                         const v1::MoveRelativeRequest* req,
                                         v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* MoveVelocity(grpc::CallbackServerContext* ctx,
                                         const v1::MoveVelocityRequest* req,
                                         v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* MoveCoordinated(grpc::CallbackServerContext* ctx,
                                            const v1::MoveCoordinatedRequest* req,
                                            v1::MoveCoordinatedResponse* resp) override;
  grpc::ServerUnaryReactor* Stop(grpc::CallbackServerContext* ctx, const v1::StopRequest* req,
                                 v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* AcknowledgeFault(grpc::CallbackServerContext* ctx,
                                             const v1::AcknowledgeFaultRequest* req,
                                             v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* GetCommand(grpc::CallbackServerContext* ctx,
                                       const v1::GetCommandRequest* req,
                                       v1::CommandHandle* resp) override;
  grpc::ServerUnaryReactor* ReadParameter(grpc::CallbackServerContext* ctx,
                                          const v1::ReadParameterRequest* req,
                                          v1::Parameter* resp) override;
  grpc::ServerUnaryReactor* WriteParameter(grpc::CallbackServerContext* ctx,
                                           const v1::WriteParameterRequest* req,
                                           v1::Parameter* resp) override;
  grpc::ServerUnaryReactor* SendNativeCommand(grpc::CallbackServerContext* ctx,
                                              const v1::SendNativeCommandRequest* req,
                                              v1::NativeCommandResponse* resp) override;
  // Client streaming (no REST binding): server/grpc/cyclic_reactor.h.
  grpc::ServerReadReactor<v1::CyclicSetpointRequest>* StreamCyclicSetpoints(
      grpc::CallbackServerContext* ctx, v1::CyclicStreamSummary* resp) override;

 private:
  DriveServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
  IdempotencyCache* idempotency_;
  WatchServing watch_;  // the shared ticker and wire bytes of every WatchDrives stream
};

}  // namespace drivegw::server
