// The `tls:` section: certificate, key and client CA for HTTPS and gRPC over TLS, and the
// mapping from a verified client certificate's subject CN to a principal and role (issue 7,
// docs/config.md "tls", decision 023).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace drivegw::config {

// The roles of issue 7 ("Roles: viewer, operator, engineer, admin"), in rising privilege.
inline constexpr std::string_view kTlsRoles[] = {"viewer", "operator", "engineer", "admin"};

// PEM files larger than this are refused before reading (a chain of a few certificates is a
// few KiB).
inline constexpr size_t kMaxPemFileBytes = 1 << 20;

// tls.client_principals[i]: a client certificate whose subject CN is `common_name` acts as
// `principal` with `role`.
struct TlsClientPrincipal {
  std::string common_name;
  std::string principal;  // defaults to common_name
  std::string role;       // one of kTlsRoles
};

struct TlsConfig {
  // Paths as written in the file (relative ones against the working directory, like data_dir).
  std::string cert_path;
  std::string key_path;
  std::string client_ca_path;  // "" = clients are not asked for a certificate
  // The files' contents, read and checked while parsing: PEM, the key matches the first
  // certificate of cert_path, client_ca_path holds at least one certificate.
  std::string cert_pem;  // the server certificate, optionally followed by intermediates
  std::string key_pem;
  std::string client_ca_pem;
  // With client_ca: true refuses a handshake without a client certificate; false accepts
  // one without (a certificate that is sent must still verify against client_ca).
  bool require_client_cert = false;
  std::vector<TlsClientPrincipal> client_principals;
};

// The mapping entry for a verified client certificate's subject CN (exact, case-sensitive),
// or nullptr when the CN is not mapped.
const TlsClientPrincipal* FindClientPrincipal(const TlsConfig& tls, std::string_view common_name);

namespace internal {
class Section;

// Reads `tls` of the root mapping into `out` (left empty when the key is absent): shape
// errors name the key path with line and column; file errors name the key and the file
// (missing, unreadable, too large, not PEM, encrypted key, key does not match the certificate).
void ParseTls(const Section& root, std::optional<TlsConfig>& out);
}  // namespace internal

}  // namespace drivegw::config
