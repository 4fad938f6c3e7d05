// AuditServiceGrpc: one line per RPC into the core.
#include "server/grpc/audit_service_grpc.h"

#include <functional>

#include "server/grpc/call_auth.h"
#include "server/grpc/producer_stream.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

// The full method name the role table knows this service's `method` by.
std::string RpcName(const char* method) {
  return FullMethod(v1::AuditService::service_full_name(), method);
}

using AuditStream = ProducerStream<v1::AuditEvent>;

}  // namespace

grpc::ServerUnaryReactor* AuditServiceGrpc::ListAuditEvents(grpc::CallbackServerContext* ctx,
                                                            const v1::ListAuditEventsRequest* req,
                                                            v1::ListAuditEventsResponse* resp) {
  return Offload(auth_, RpcName("ListAuditEvents"), pool_, ctx, resp,
                 [this, req](const CallContext& c) { return core_.ListAuditEvents(*req, c); });
}

grpc::ServerUnaryReactor* AuditServiceGrpc::VerifyAuditLog(grpc::CallbackServerContext* ctx,
                                                           const v1::VerifyAuditLogRequest* req,
                                                           v1::VerifyAuditLogResponse* resp) {
  return Offload(auth_, RpcName("VerifyAuditLog"), pool_, ctx, resp,
                 [this, req](const CallContext& c) { return core_.VerifyAuditLog(*req, c); });
}

grpc::ServerWriteReactor<v1::AuditEvent>* AuditServiceGrpc::WatchAuditEvents(
    grpc::CallbackServerContext* ctx, const v1::WatchAuditEventsRequest* req) {
  absl::StatusOr<CallContext> authorised = auth_.Authorize(*ctx, RpcName("WatchAuditEvents"));
  if (!authorised.ok()) return new RefusedWriter<v1::AuditEvent>(authorised.status());
  CallContext cc = *std::move(authorised);
  return new AuditStream(  // deletes itself in OnDone
      [this, r = *req, cc = std::move(cc)](const AuditStream::Sink& sink,
                                           const std::function<bool()>& cancelled) {
        return core_.WatchAuditEvents(r, cc, sink, cancelled);
      });
}

grpc::ServerWriteReactor<v1::AuditEvent>* AuditServiceGrpc::ExportAuditEvents(
    grpc::CallbackServerContext* ctx, const v1::ExportAuditEventsRequest* req) {
  absl::StatusOr<CallContext> authorised = auth_.Authorize(*ctx, RpcName("ExportAuditEvents"));
  if (!authorised.ok()) return new RefusedWriter<v1::AuditEvent>(authorised.status());
  CallContext cc = *std::move(authorised);
  return new AuditStream(  // deletes itself in OnDone
      [this, r = *req, cc = std::move(cc)](const AuditStream::Sink& sink,
                                           const std::function<bool()>& cancelled) {
        return core_.ExportAuditEvents(r, cc, sink, cancelled);
      });
}

}  // namespace drivegw::server
