// Thin gRPC callback service over CurveSetServiceCore (issue 6 "Curve sets"): every call runs on
// the worker pool (SQLite, curve transfers and drive commands block) and finishes with
// ToGrpcStatus. No logic lives here.
#pragma once

#include "drivegw/v1/curve_sets.grpc.pb.h"
#include "server/core/curve_set_service.h"
#include "server/core/idempotency.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// Every CurveSetService RPC once: (method, request, response); the header declares and the .cpp
// defines each through this list.
#define DGW_CURVE_SET_RPCS(X)                                                        \
  X(CreateCurveSet, CreateCurveSetRequest, CurveSet)                                 \
  X(GetCurveSet, GetCurveSetRequest, CurveSet)                                       \
  X(ListCurveSets, ListCurveSetsRequest, ListCurveSetsResponse)                      \
  X(UpdateCurveSet, UpdateCurveSetRequest, CurveSet)                                 \
  X(DeleteCurveSet, DeleteCurveSetRequest, DeleteCurveSetResponse)                   \
  X(ListCurveSetVersions, ListCurveSetVersionsRequest, ListCurveSetVersionsResponse) \
  X(GetCurveSetVersion, GetCurveSetVersionRequest, CurveSetVersion)                  \
  X(GetCurvePlot, GetCurvePlotRequest, CurvePlot)                                    \
  X(ValidateCurveSet, ValidateCurveSetRequest, ValidateCurveSetResponse)             \
  X(DownloadCurve, DownloadCurveRequest, DownloadCurveResponse)                      \
  X(RunCurve, RunCurveRequest, CommandHandle)

class CurveSetServiceGrpc final : public v1::CurveSetService::CallbackService {
 public:
  // Every call is authorised by `auth` (decision 015); `idempotency` may be null (no idempotent
  // retries, decision 020).
  CurveSetServiceGrpc(CurveSetServiceCore& core, WorkerPool& pool, const CallAuth& auth,
                      IdempotencyCache* idempotency = nullptr)
      : core_(core), pool_(pool), auth_(auth), idempotency_(idempotency) {}

#define DGW_CS_RPC(Method, Req, Resp)                                                    \
  grpc::ServerUnaryReactor* Method(grpc::CallbackServerContext* ctx, const v1::Req* req, \
                                   v1::Resp* resp) override;
  DGW_CURVE_SET_RPCS(DGW_CS_RPC)
#undef DGW_CS_RPC

 private:
  CurveSetServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
  IdempotencyCache* idempotency_;
};

}  // namespace drivegw::server
