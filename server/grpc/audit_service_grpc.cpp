// AuditServiceGrpc: one line per RPC into the core.
#include "server/grpc/audit_service_grpc.h"

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include "server/grpc/call_auth.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

// The full method name the role table knows this service's `method` by.
std::string RpcName(const char* method) {
  return FullMethod(v1::AuditService::service_full_name(), method);
}

// Server stream of audit events: a producer thread runs the core's loop and hands each event
// to gRPC one write at a time (the producer waits while a write is in flight), as the drive
// watch stream does (drive_service_grpc.cpp).
class EventStream final : public grpc::ServerWriteReactor<v1::AuditEvent> {
 public:
  using Sink = std::function<bool(const v1::AuditEvent&)>;
  using Body = std::function<absl::Status(const Sink&, const std::function<bool()>&)>;

  explicit EventStream(Body body) {
    producer_ = std::thread([this, body = std::move(body)] {
      absl::Status s = body([this](const v1::AuditEvent& e) { return Write(e); },
                            [this] { return cancelled_.load(); });
      // The last write must be done before Finish.
      {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return !writing_ || cancelled_.load(); });
      }
      Finish(ToGrpcStatus(s));
    });
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mu_);
    writing_ = false;
    if (!ok) cancelled_.store(true);
    cv_.notify_all();
  }
  void OnCancel() override {
    cancelled_.store(true);
    std::lock_guard lock(mu_);
    cv_.notify_all();
  }
  void OnDone() override {
    cancelled_.store(true);
    // gRPC may run OnDone inline on the producer thread (from Finish); it cannot join itself.
    if (producer_.joinable()) {
      if (producer_.get_id() == std::this_thread::get_id()) {
        producer_.detach();
      } else {
        producer_.join();
      }
    }
    delete this;  // callback API: the reactor owns itself until OnDone
  }

 private:
  bool Write(const v1::AuditEvent& e) {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !writing_ || cancelled_.load(); });
    if (cancelled_.load()) return false;
    current_ = e;
    writing_ = true;
    lock.unlock();
    StartWrite(&current_);
    return true;
  }

  std::mutex mu_;
  std::condition_variable cv_;
  bool writing_ = false;
  std::atomic<bool> cancelled_{false};
  v1::AuditEvent current_;
  std::thread producer_;
};

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
  return new EventStream(  // deletes itself in OnDone
      [this, r = *req, cc = std::move(cc)](const EventStream::Sink& sink,
                                           const std::function<bool()>& cancelled) {
        return core_.WatchAuditEvents(r, cc, sink, cancelled);
      });
}

grpc::ServerWriteReactor<v1::AuditEvent>* AuditServiceGrpc::ExportAuditEvents(
    grpc::CallbackServerContext* ctx, const v1::ExportAuditEventsRequest* req) {
  absl::StatusOr<CallContext> authorised = auth_.Authorize(*ctx, RpcName("ExportAuditEvents"));
  if (!authorised.ok()) return new RefusedWriter<v1::AuditEvent>(authorised.status());
  CallContext cc = *std::move(authorised);
  return new EventStream(  // deletes itself in OnDone
      [this, r = *req, cc = std::move(cc)](const EventStream::Sink& sink,
                                           const std::function<bool()>& cancelled) {
        return core_.ExportAuditEvents(r, cc, sink, cancelled);
      });
}

}  // namespace drivegw::server
