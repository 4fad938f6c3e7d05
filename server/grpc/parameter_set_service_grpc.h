// Thin gRPC callback service over ParameterSetServiceCore (issue 6): every call runs on the worker
// pool (SQLite and drive reads block) and finishes with ToGrpcStatus. No logic lives here.
#pragma once

#include "drivegw/v1/parameter_sets.grpc.pb.h"
#include "server/core/idempotency.h"
#include "server/core/parameter_set_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// Every ParameterSetService RPC once: (method, request, response); the header declares and the
// .cpp defines each through this list.
#define DGW_PARAMETER_SET_RPCS(X)                                                                \
  X(ListParameterDefinitions, ListParameterDefinitionsRequest, ListParameterDefinitionsResponse) \
  X(CreateParameterSet, CreateParameterSetRequest, ParameterSet)                                 \
  X(GetParameterSet, GetParameterSetRequest, ParameterSet)                                       \
  X(ListParameterSets, ListParameterSetsRequest, ListParameterSetsResponse)                      \
  X(UpdateParameterSet, UpdateParameterSetRequest, ParameterSet)                                 \
  X(DeleteParameterSet, DeleteParameterSetRequest, DeleteParameterSetResponse)                   \
  X(ListParameterSetVersions, ListParameterSetVersionsRequest, ListParameterSetVersionsResponse) \
  X(GetParameterSetVersion, GetParameterSetVersionRequest, ParameterSetVersion)                  \
  X(CaptureParameterSet, CaptureParameterSetRequest, ParameterSet)                               \
  X(DiffParameterSet, DiffParameterSetRequest, DiffParameterSetResponse)                         \
  X(ApplyParameterSet, ApplyParameterSetRequest, Operation)                                      \
  X(GetOperation, GetOperationRequest, Operation)                                                \
  X(ListOperations, ListOperationsRequest, ListOperationsResponse)                               \
  X(RestoreOperation, RestoreOperationRequest, Operation)                                        \
  X(ImportParameterSet, ImportParameterSetRequest, ParameterSet)                                 \
  X(ExportParameterSet, ExportParameterSetRequest, ExportParameterSetResponse)

class ParameterSetServiceGrpc final : public v1::ParameterSetService::CallbackService {
 public:
  // Every call is authorised by `auth` (decision 015); `idempotency` may be null (no idempotent
  // retries, decision 020).
  ParameterSetServiceGrpc(ParameterSetServiceCore& core, WorkerPool& pool, const CallAuth& auth,
                          IdempotencyCache* idempotency = nullptr)
      : core_(core), pool_(pool), auth_(auth), idempotency_(idempotency) {}

#define DGW_PS_RPC(Method, Req, Resp)                                                    \
  grpc::ServerUnaryReactor* Method(grpc::CallbackServerContext* ctx, const v1::Req* req, \
                                   v1::Resp* resp) override;
  DGW_PARAMETER_SET_RPCS(DGW_PS_RPC)
#undef DGW_PS_RPC

 private:
  ParameterSetServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
  IdempotencyCache* idempotency_;
};

}  // namespace drivegw::server
