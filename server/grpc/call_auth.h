// The one enforcement point of issue 7 "Every RPC has one required role, enforced in one place
// that gRPC and REST both pass through" (REST reaches the services as in-process gRPC calls):
// every handler gets its CallContext from CallAuth::Authorize with its full method name, through
// the Inline/Offload helpers below or, for streams, directly. Refusals are UNAUTHENTICATED or
// PERMISSION_DENIED and are audited as "auth.denied" (decision 015).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "server/auth/authenticator.h"
#include "server/core/call_context.h"
#include "server/grpc/status_mapping.h"
#include "server/grpc/worker_pool.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

// "/drivegw.v1.DriveService/MoveAbsolute" from the generated service_full_name() and a method.
std::string FullMethod(std::string_view service_full_name, std::string_view method);

// What Authorize needs of a call, read on the gRPC thread so the check can run on a pool thread.
struct CallCredentials {
  std::string method;                         // FullMethod(...)
  CallContext base;                           // ContextFrom(ctx)
  std::string authorization;                  // metadata `authorization`, "" if none
  std::optional<std::string> certificate_cn;  // verified client certificate's subject CN
};

class CallAuth {
 public:
  // Refusals beyond this many per second are counted, not written one by one (a client
  // hammering with a bad token must not push real entries out of the size-limited audit log);
  // the next written refusal carries the count.
  static constexpr int kMaxDeniedAuditsPerSecond = 20;

  // `authenticator` and `audit` (may be null) must outlive this object and its calls; `clock`
  // times the refusal rate window.
  CallAuth(const auth::Authenticator& authenticator, storage::AuditLog* audit,
           const Clock& clock = SteadyClock::Instance())
      : authenticator_(authenticator), audit_(audit), clock_(clock) {}

  // Auth disabled (anonymous admin), no audit: for tests that build one service on its own.
  // The role table still applies: a method without a role is refused.
  static const CallAuth& Open();

  static CallCredentials Credentials(const grpc::CallbackServerContext& ctx,
                                     std::string_view method);
  // The authenticated, authorised context (principal and role filled in), or the refusal.
  absl::StatusOr<CallContext> Check(const CallCredentials& credentials) const;
  absl::StatusOr<CallContext> Authorize(const grpc::CallbackServerContext& ctx,
                                        std::string_view method) const {
    return Check(Credentials(ctx, method));
  }

  const auth::Authenticator& authenticator() const { return authenticator_; }

 private:
  void AuditDenied(const CallCredentials& credentials, const CallContext& who,
                   const absl::Status& refusal) const;

  const auth::Authenticator& authenticator_;
  storage::AuditLog* audit_;
  const Clock& clock_;
  mutable std::mutex mu_;  // the denial rate window
  mutable TimePoint window_start_{};
  mutable int window_count_ = 0;
  mutable int64_t suppressed_ = 0;
};

// Unary call run inline on the gRPC thread (cheap reads): authorise, run fn(ctx), finish.
template <typename Resp, typename Fn>
grpc::ServerUnaryReactor* Inline(const CallAuth& auth, std::string_view method,
                                 grpc::CallbackServerContext* ctx, Resp* resp, Fn fn) {
  auto* reactor = ctx->DefaultReactor();
  absl::StatusOr<CallContext> cc = auth.Authorize(*ctx, method);
  absl::Status status = cc.status();
  if (cc.ok()) {
    auto result = fn(*cc);
    if (result.ok()) *resp = *std::move(result);
    status = result.status();
  }
  reactor->Finish(ToGrpcStatus(status));
  return reactor;
}

// Unary call run on the worker pool (it may block on a drive or SQLite): the credentials are
// read here, checked and run there, and the call finishes from there.
template <typename Resp, typename Fn>
grpc::ServerUnaryReactor* Offload(const CallAuth& auth, std::string_view method, WorkerPool& pool,
                                  grpc::CallbackServerContext* ctx, Resp* resp, Fn fn) {
  auto* reactor = ctx->DefaultReactor();
  pool.Post([&auth, reactor, resp, fn = std::move(fn),
             credentials = CallAuth::Credentials(*ctx, method)]() mutable {
    absl::StatusOr<CallContext> cc = auth.Check(credentials);
    absl::Status status = cc.status();
    if (cc.ok()) {
      auto result = fn(*cc);
      if (result.ok()) *resp = *std::move(result);
      status = result.status();
    }
    reactor->Finish(ToGrpcStatus(status));
  });
  return reactor;
}

// A streaming call refused before it started: finishes at once, deletes itself in OnDone.
template <typename T>
class RefusedWriter final : public grpc::ServerWriteReactor<T> {
 public:
  explicit RefusedWriter(const absl::Status& s) { this->Finish(ToGrpcStatus(s)); }
  void OnDone() override { delete this; }  // callback API: the reactor owns itself
};
template <typename T>
class RefusedReader final : public grpc::ServerReadReactor<T> {
 public:
  explicit RefusedReader(const absl::Status& s) { this->Finish(ToGrpcStatus(s)); }
  void OnDone() override { delete this; }
};

}  // namespace drivegw::server
