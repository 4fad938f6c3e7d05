// Bearer parsing (RFC 6750 §2.1), certificate mapping, and the one role check.
#include "server/auth/authenticator.h"

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/auth/method_roles.h"
#include "storage/token_repo.h"

namespace drivegw::auth {
namespace {

absl::string_view Av(std::string_view s) { return absl::string_view(s.data(), s.size()); }

}  // namespace

absl::StatusOr<Principal> Authenticator::FromBearer(std::string_view authorization) const {
  const absl::string_view value = absl::StripAsciiWhitespace(Av(authorization));
  // RFC 7235 §2.1: the scheme is case-insensitive; RFC 6750 §2.1: "Bearer" 1*SP token68.
  constexpr absl::string_view kScheme = "bearer ";
  if (value.size() <= kScheme.size() ||
      !absl::EqualsIgnoreCase(value.substr(0, kScheme.size()), kScheme)) {
    return absl::UnauthenticatedError(
        "authorization: not a bearer token (send 'authorization: Bearer <token>')");
  }
  const absl::string_view token = absl::StripLeadingAsciiWhitespace(value.substr(kScheme.size()));
  if (tokens_ == nullptr) {
    return absl::UnauthenticatedError("authorization: no token store is configured");
  }
  auto record = tokens_->Verify(std::string_view(token.data(), token.size()));
  if (!record.ok()) return record.status();
  const std::optional<Role> role = ParseRole(record->role);
  if (!role) {
    // Migration 004's CHECK keeps other values out; a row that has one is not trusted.
    return absl::UnauthenticatedError(
        absl::StrCat("bearer token: '", record->name, "' has an unknown role"));
  }
  return Principal{record->name, *role, "token"};
}

std::optional<Principal> Authenticator::FromCertificate(std::string_view common_name) const {
  for (const CertificatePrincipal& c : options_.certificates) {
    if (c.common_name == common_name) return Principal{c.principal, c.role, "certificate"};
  }
  return std::nullopt;
}

absl::StatusOr<Principal> Authenticator::Authenticate(
    std::string_view authorization, std::optional<std::string_view> certificate_cn) const {
  if (!options_.enabled) return Principal{std::string(kAnonymous), Role::kAdmin, "anonymous"};
  if (!authorization.empty()) return FromBearer(authorization);
  if (certificate_cn) {
    if (auto p = FromCertificate(*certificate_cn)) return *std::move(p);
    return absl::UnauthenticatedError(
        absl::StrCat("client certificate: CN '", std::string(*certificate_cn),
                     "' is not in tls.client_principals, and no bearer token was sent"));
  }
  return absl::UnauthenticatedError(
      "no credentials: send 'authorization: Bearer <token>' (drivegw token create) or a mapped "
      "client certificate");
}

absl::Status Authenticator::Authorize(std::string_view method, const Principal& principal) {
  const std::optional<Role> need = RequiredRole(method);
  if (!need) {
    return absl::PermissionDeniedError(
        absl::StrCat(std::string(method), ": no role is assigned to this method (denied)"));
  }
  if (!Satisfies(principal.role, *need)) {
    return absl::PermissionDeniedError(absl::StrCat(
        std::string(method), " needs role ", std::string(RoleName(*need)), "; principal '",
        principal.name, "' has role ", std::string(RoleName(principal.role))));
  }
  return absl::OkStatus();
}

}  // namespace drivegw::auth
