// TLS on the gRPC port: the server credentials built from the `tls:` section, and the verified
// client certificate's subject CN of a call, whether it came over the network (TLS auth
// context) or from the REST front end in process (metadata x-drivegw-client-cn-bin).
// Decision 023.
#pragma once

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_context.h>

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "server/config/tls_config.h"

namespace drivegw::server {

// Binary metadata (a CN is UTF-8) the REST server's in-process calls carry: the CN of the
// HTTPS client's verified certificate. Trusted only on in-process calls, like x-drivegw-source.
inline constexpr char kClientCnMetadata[] = "x-drivegw-client-cn-bin";

// True for a call that came over the in-process channel (the REST front end), false for a
// network peer ("ipv4:", "ipv6:", "unix:"), the same rule as ContextFrom.
bool IsInProcessCall(const grpc::CallbackServerContext& ctx);

// Insecure credentials without `tls`; otherwise SSL credentials with the certificate chain and
// key and, with client_ca, client certificate verification: required
// (GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY) or optional
// (GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY: a certificate that is sent must verify).
std::shared_ptr<grpc::ServerCredentials> GrpcServerCredentials(
    const std::optional<config::TlsConfig>& tls);

// The subject CN of the caller's verified client certificate: from the TLS auth context
// (x509_common_name) on a network call, from kClientCnMetadata on an in-process call; nullopt
// when the caller presented none. Authentication maps it with config::FindClientPrincipal.
std::optional<std::string> ClientCommonName(const grpc::CallbackServerContext& ctx);

// The `tls.client_principals` entry for the call's client certificate, or nullptr (no
// certificate, no tls section, or an unmapped CN).
const config::TlsClientPrincipal* ClientPrincipal(const grpc::CallbackServerContext& ctx,
                                                  const std::optional<config::TlsConfig>& tls);

}  // namespace drivegw::server
