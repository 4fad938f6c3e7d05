// CallAuth: credentials from gRPC metadata and the TLS peer, the Authenticator's verdict, and
// one "auth.denied" audit entry per refusal (rate-limited, decision 015).
#include "server/grpc/call_auth.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "server/core/audit.h"
#include "server/grpc/peer_identity.h"

namespace drivegw::server {
namespace {

std::string Metadata(const grpc::CallbackServerContext& ctx, const char* key) {
  const auto& md = ctx.client_metadata();
  auto it = md.find(key);
  if (it == md.end()) return "";
  return std::string(it->second.data(), it->second.size());
}

// The principal an UNAUTHENTICATED refusal is recorded under: nobody was proven.
constexpr char kUnauthenticated[] = "(unauthenticated)";

// The unauthenticated base of a call's context (CallCredentials::base). Not exported: every
// handler gets its context from CallAuth, so none can skip the check by accident.
CallContext ContextFrom(const grpc::CallbackServerContext& ctx) {
  CallContext cc;
  const std::string peer = ctx.peer();
  const bool network = absl::StartsWith(peer, "ipv4:") || absl::StartsWith(peer, "ipv6:") ||
                       absl::StartsWith(peer, "unix:");
  cc.transport = "grpc";
  cc.source_address = peer;
  cc.idempotency_key = Metadata(ctx, "idempotency-key");
  cc.lease_id = Metadata(ctx, "x-drivegw-lease");  // decision 019
  if (!network) {
    if (std::string src = Metadata(ctx, "x-drivegw-source"); !src.empty()) cc.source_address = src;
    if (std::string tr = Metadata(ctx, "x-drivegw-transport"); !tr.empty()) cc.transport = tr;
  }
  return cc;
}

}  // namespace

std::string FullMethod(std::string_view service_full_name, std::string_view method) {
  return absl::StrCat("/", std::string(service_full_name), "/", std::string(method));
}

const CallAuth& CallAuth::Open() {
  static const auth::Authenticator open_authenticator(auth::AuthOptions{}, nullptr);
  static const CallAuth open(open_authenticator, nullptr);
  return open;
}

CallCredentials CallAuth::Credentials(const grpc::CallbackServerContext& ctx,
                                      std::string_view method) {
  CallCredentials c;
  c.method = std::string(method);
  c.base = ContextFrom(ctx);
  // The REST front end forwards the HTTP Authorization header as this metadata (router.cpp).
  c.authorization = Metadata(ctx, "authorization");
  c.certificate_cn = ClientCommonName(ctx);  // decision 023
  return c;
}

absl::StatusOr<CallContext> CallAuth::Check(const CallCredentials& credentials) const {
  CallContext cc = credentials.base;
  absl::StatusOr<auth::Principal> principal =
      authenticator_.Authenticate(credentials.authorization, credentials.certificate_cn);
  if (!principal.ok()) {
    cc.principal = kUnauthenticated;
    cc.role = "";
    const absl::Status refusal = absl::UnauthenticatedError(
        absl::StrCat(credentials.method, ": ", principal.status().message()));
    AuditDenied(credentials, cc, refusal);
    return refusal;
  }
  cc.principal = principal->name;
  cc.role = std::string(auth::RoleName(principal->role));
  if (absl::Status s = auth::Authenticator::Authorize(credentials.method, *principal); !s.ok()) {
    AuditDenied(credentials, cc, s);
    return s;
  }
  return cc;
}

void CallAuth::AuditDenied(const CallCredentials& credentials, const CallContext& who,
                           const absl::Status& refusal) const {
  int64_t suppressed = 0;
  {
    std::lock_guard lock(mu_);
    const TimePoint now = clock_.Now();
    if (now - window_start_ >= std::chrono::seconds(1)) {
      if (suppressed_ > 0 && window_count_ >= kMaxDeniedAuditsPerSecond) {
        log::Warn("auth_denied_suppressed", log::Fields().Add("count", suppressed_));
      }
      window_start_ = now;
      window_count_ = 0;
    }
    if (window_count_ >= kMaxDeniedAuditsPerSecond) {
      ++suppressed_;
      return;
    }
    ++window_count_;
    suppressed = suppressed_;
    suppressed_ = 0;
  }
  // Method names are [A-Za-z0-9./]: no JSON escaping needed.
  std::string request = absl::StrCat("{\"method\":\"", credentials.method, "\"");
  if (suppressed > 0) absl::StrAppend(&request, ",\"suppressed_before\":", suppressed);
  request += "}";
  log::Info("auth_denied", log::Fields()
                               .Add("method", credentials.method)
                               .Add("principal", who.principal)
                               .Add("source", who.source_address)
                               .Add("code", absl::StatusCodeToString(refusal.code())));
  WriteAudit(audit_, who, "", "auth.denied", request, refusal);
}

}  // namespace drivegw::server
