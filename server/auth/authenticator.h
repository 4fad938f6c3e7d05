// Who is calling: a bearer token (storage::TokenRepo) or a mapped client certificate becomes a
// principal {name, role}; Authorize adds the role check of method_roles (issue 7, decision 015).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "server/auth/role.h"

namespace drivegw::storage {
class TokenRepo;
}

namespace drivegw::auth {

struct Principal {
  std::string name;  // the token's name, the certificate's mapped principal, or "anonymous"
  Role role = Role::kViewer;
  std::string via;  // "token", "certificate" or "anonymous" (auth disabled)
};

// tls.client_principals[i] (decision 023): a verified client certificate with subject CN
// `common_name` acts as `principal` with `role`.
struct CertificatePrincipal {
  std::string common_name;
  std::string principal;
  Role role = Role::kViewer;
};

struct AuthOptions {
  // false: every call is the principal "anonymous" with role admin (the embedded demo on
  // loopback; config.auth.enabled, decision 015).
  bool enabled = false;
  std::vector<CertificatePrincipal> certificates;
};

class Authenticator {
 public:
  static constexpr std::string_view kAnonymous = "anonymous";

  // `tokens` must outlive this object; it may be null only when options.enabled is false.
  Authenticator(AuthOptions options, storage::TokenRepo* tokens)
      : options_(std::move(options)), tokens_(tokens) {}

  bool enabled() const { return options_.enabled; }

  // The principal of an `authorization` header value "Bearer <token>" (scheme case-insensitive,
  // RFC 6750 §2.1). Unauthenticated for another scheme, a malformed, unknown, wrong or revoked
  // token (TokenRepo::Verify reads the token's row on every call: revocation is immediate).
  absl::StatusOr<Principal> FromBearer(std::string_view authorization) const;

  // The principal a verified client certificate's subject CN maps to (exact match), or nullopt.
  // W2-E's TLS layer extracts the CN (server/grpc/peer_identity.h).
  std::optional<Principal> FromCertificate(std::string_view common_name) const;

  // The caller: anonymous admin when auth is disabled; else the bearer token when an
  // authorization header was sent (a bad token is refused even if a certificate would map);
  // else the mapped client certificate; else Unauthenticated saying what to send.
  absl::StatusOr<Principal> Authenticate(std::string_view authorization,
                                         std::optional<std::string_view> certificate_cn) const;

  // Checks `principal` against the role `method` needs: PermissionDenied naming the method, the
  // role it needs and the principal's role; PermissionDenied for a method missing from the
  // table (even with auth disabled: an RPC without a role is a bug, never open).
  static absl::Status Authorize(std::string_view method, const Principal& principal);

 private:
  AuthOptions options_;
  storage::TokenRepo* tokens_;
};

}  // namespace drivegw::auth
