// gRPC server credentials from the tls section, and the client certificate CN of a call.
#include "server/grpc/peer_identity.h"

#include <grpcpp/security/auth_context.h>

#include "absl/strings/match.h"

namespace drivegw::server {
namespace {

// gRPC's TLS auth context property with the peer certificate's subject CN
// (GRPC_X509_CN_PROPERTY_NAME in grpc/grpc_security_constants.h).
constexpr char kX509CommonName[] = "x509_common_name";

}  // namespace

bool IsInProcessCall(const grpc::CallbackServerContext& ctx) {
  const std::string peer = ctx.peer();
  return !(absl::StartsWith(peer, "ipv4:") || absl::StartsWith(peer, "ipv6:") ||
           absl::StartsWith(peer, "unix:"));
}

std::shared_ptr<grpc::ServerCredentials> GrpcServerCredentials(
    const std::optional<config::TlsConfig>& tls) {
  if (!tls) return grpc::InsecureServerCredentials();
  grpc_ssl_client_certificate_request_type request = GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE;
  if (!tls->client_ca_pem.empty()) {
    request = tls->require_client_cert ? GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY
                                       : GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  grpc::SslServerCredentialsOptions options(request);
  options.pem_root_certs = tls->client_ca_pem;
  options.pem_key_cert_pairs.push_back({tls->key_pem, tls->cert_pem});
  return grpc::SslServerCredentials(options);
}

std::optional<std::string> ClientCommonName(const grpc::CallbackServerContext& ctx) {
  if (IsInProcessCall(ctx)) {
    const auto& md = ctx.client_metadata();
    auto it = md.find(kClientCnMetadata);
    if (it == md.end() || it->second.empty()) return std::nullopt;
    return std::string(it->second.data(), it->second.size());
  }
  // The property exists only when a client certificate was presented and, with the
  // ..._AND_VERIFY request types we configure, verified against tls.client_ca.
  const std::shared_ptr<const grpc::AuthContext> auth = ctx.auth_context();
  if (auth == nullptr || !auth->IsPeerAuthenticated()) return std::nullopt;
  const std::vector<grpc::string_ref> cn = auth->FindPropertyValues(kX509CommonName);
  if (cn.empty() || cn.front().empty()) return std::nullopt;
  return std::string(cn.front().data(), cn.front().size());
}

const config::TlsClientPrincipal* ClientPrincipal(const grpc::CallbackServerContext& ctx,
                                                  const std::optional<config::TlsConfig>& tls) {
  if (!tls) return nullptr;
  const std::optional<std::string> cn = ClientCommonName(ctx);
  return cn ? config::FindClientPrincipal(*tls, *cn) : nullptr;
}

}  // namespace drivegw::server
