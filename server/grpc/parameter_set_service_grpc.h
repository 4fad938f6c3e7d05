// Thin gRPC callback service over ParameterSetServiceCore (issue 6): every call runs on the worker
// pool (SQLite and drive reads block) and finishes with ToGrpcStatus. No logic lives here.
#pragma once

#include "drivegw/v1/parameter_sets.grpc.pb.h"
#include "server/core/parameter_set_service.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

class ParameterSetServiceGrpc final : public v1::ParameterSetService::CallbackService {
 public:
  ParameterSetServiceGrpc(ParameterSetServiceCore& core, WorkerPool& pool)
      : core_(core), pool_(pool) {}

#define DGW_PS_RPC(Method, Req, Resp)                                                    \
  grpc::ServerUnaryReactor* Method(grpc::CallbackServerContext* ctx, const v1::Req* req, \
                                   v1::Resp* resp) override;
  DGW_PS_RPC(ListParameterDefinitions, ListParameterDefinitionsRequest,
             ListParameterDefinitionsResponse)
  DGW_PS_RPC(CreateParameterSet, CreateParameterSetRequest, ParameterSet)
  DGW_PS_RPC(GetParameterSet, GetParameterSetRequest, ParameterSet)
  DGW_PS_RPC(ListParameterSets, ListParameterSetsRequest, ListParameterSetsResponse)
  DGW_PS_RPC(UpdateParameterSet, UpdateParameterSetRequest, ParameterSet)
  DGW_PS_RPC(DeleteParameterSet, DeleteParameterSetRequest, DeleteParameterSetResponse)
  DGW_PS_RPC(ListParameterSetVersions, ListParameterSetVersionsRequest,
             ListParameterSetVersionsResponse)
  DGW_PS_RPC(GetParameterSetVersion, GetParameterSetVersionRequest, ParameterSetVersion)
  DGW_PS_RPC(CaptureParameterSet, CaptureParameterSetRequest, ParameterSet)
  DGW_PS_RPC(DiffParameterSet, DiffParameterSetRequest, DiffParameterSetResponse)
  DGW_PS_RPC(ApplyParameterSet, ApplyParameterSetRequest, Operation)
  DGW_PS_RPC(GetOperation, GetOperationRequest, Operation)
  DGW_PS_RPC(ListOperations, ListOperationsRequest, ListOperationsResponse)
  DGW_PS_RPC(ImportParameterSet, ImportParameterSetRequest, ParameterSet)
  DGW_PS_RPC(ExportParameterSet, ExportParameterSetRequest, ExportParameterSetResponse)
#undef DGW_PS_RPC

 private:
  ParameterSetServiceCore& core_;
  WorkerPool& pool_;
};

}  // namespace drivegw::server
