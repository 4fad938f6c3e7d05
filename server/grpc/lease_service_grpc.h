// Thin gRPC callback service over LeaseServiceCore (issue 7, decision 019): every call runs on
// the worker pool (an idempotent retry may wait for its first call) and finishes with
// ToGrpcStatus. No logic lives here.
#pragma once

#include "drivegw/v1/leases.grpc.pb.h"
#include "server/core/idempotency.h"
#include "server/core/lease_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

// Every LeaseService RPC once: (method, request, response).
#define DGW_LEASE_RPCS(X)                                    \
  X(AcquireLease, AcquireLeaseRequest, Lease)                \
  X(RenewLease, RenewLeaseRequest, Lease)                    \
  X(ReleaseLease, ReleaseLeaseRequest, ReleaseLeaseResponse) \
  X(ListLeases, ListLeasesRequest, ListLeasesResponse)

class LeaseServiceGrpc final : public v1::LeaseService::CallbackService {
 public:
  // Every call is authorised by `auth` (decision 015); `idempotency` may be null (no idempotent
  // retries, decision 020).
  LeaseServiceGrpc(LeaseServiceCore& core, WorkerPool& pool, const CallAuth& auth,
                   IdempotencyCache* idempotency = nullptr)
      : core_(core), pool_(pool), auth_(auth), idempotency_(idempotency) {}

#define DGW_LEASE_RPC(Method, Req, Resp)                                                 \
  grpc::ServerUnaryReactor* Method(grpc::CallbackServerContext* ctx, const v1::Req* req, \
                                   v1::Resp* resp) override;
  DGW_LEASE_RPCS(DGW_LEASE_RPC)
#undef DGW_LEASE_RPC

 private:
  LeaseServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
  IdempotencyCache* idempotency_;
};

}  // namespace drivegw::server
