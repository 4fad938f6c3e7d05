// HTTPS for the REST server: the OpenSSL context (TLS 1.2+, certificate chain and key, optional
// client verification) and the verified client certificate's subject CN of one connection.
// Kept apart from server.cpp so the Beast TU only wraps its sockets (decision 023).
#pragma once

#include <openssl/types.h>  // SSL

#include <string>

#include "absl/status/status.h"

namespace boost::asio::ssl {
class context;
}

namespace drivegw::rest {

struct RestTls {
  std::string cert_chain_pem;  // server certificate, then any intermediates
  std::string key_pem;         // unencrypted private key matching the certificate
  std::string client_ca_pem;   // "" = no client certificates are asked for
  // With client_ca_pem: true refuses a handshake without a client certificate; false accepts
  // one without, but a certificate that is sent must verify.
  bool require_client_cert = false;
};

// Configures a `tls_server` context. InvalidArgument naming rest.tls.<field> for PEM the
// context refuses.
absl::Status ConfigureTlsContext(const RestTls& tls, boost::asio::ssl::context& ctx);

// The subject CN of the client certificate of a completed handshake, "" when the client sent
// none or it did not verify (SSL_get_verify_result), or the subject has no CN.
std::string VerifiedClientCommonName(SSL* ssl);

}  // namespace drivegw::rest
