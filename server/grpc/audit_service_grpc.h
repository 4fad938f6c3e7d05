// Thin gRPC callback service over AuditServiceCore (issue 7 "Audit trail", decision 017): unary
// calls on the worker pool (SQLite, hashing), the two server streams on a producer thread each.
// No logic lives here.
#pragma once

#include "drivegw/v1/audit.grpc.pb.h"
#include "server/core/audit_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::server {

class AuditServiceGrpc final : public v1::AuditService::CallbackService {
 public:
  // Every call is authorised by `auth` (decision 015).
  AuditServiceGrpc(AuditServiceCore& core, WorkerPool& pool, const CallAuth& auth)
      : core_(core), pool_(pool), auth_(auth) {}

  grpc::ServerUnaryReactor* ListAuditEvents(grpc::CallbackServerContext* ctx,
                                            const v1::ListAuditEventsRequest* req,
                                            v1::ListAuditEventsResponse* resp) override;
  grpc::ServerUnaryReactor* VerifyAuditLog(grpc::CallbackServerContext* ctx,
                                           const v1::VerifyAuditLogRequest* req,
                                           v1::VerifyAuditLogResponse* resp) override;
  grpc::ServerWriteReactor<v1::AuditEvent>* WatchAuditEvents(
      grpc::CallbackServerContext* ctx, const v1::WatchAuditEventsRequest* req) override;
  grpc::ServerWriteReactor<v1::AuditEvent>* ExportAuditEvents(
      grpc::CallbackServerContext* ctx, const v1::ExportAuditEventsRequest* req) override;

 private:
  AuditServiceCore& core_;
  WorkerPool& pool_;
  const CallAuth& auth_;
};

}  // namespace drivegw::server
