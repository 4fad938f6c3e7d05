// TokenServiceCore: field-named errors (google.rpc.BadRequest) and one audit entry per call.
#include "server/auth/token_service.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "server/auth/role.h"
#include "server/core/audit.h"
#include "server/core/errors.h"

namespace drivegw::auth {
namespace {

using google::protobuf::util::TimeUtil;

constexpr absl::string_view kPrefix = "tokens/";

google::protobuf::Timestamp ToTimestamp(std::chrono::system_clock::time_point t) {
  return TimeUtil::MillisecondsToTimestamp(
      std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count());
}

// "tokens/x" or "x" -> "x"; the repo checks the characters.
absl::StatusOr<std::string> TokenName(const std::string& name) {
  absl::string_view id = name;
  if (absl::StartsWith(id, kPrefix)) id.remove_prefix(kPrefix.size());
  if (id.empty()) return server::FieldError("name", "is required (\"tokens/{name}\" or a name)");
  return std::string(id);
}

// The repo's "name: ..." / "role: ..." InvalidArgument as a field error with BadRequest.
absl::Status Fielded(const absl::Status& s) {
  if (s.code() != absl::StatusCode::kInvalidArgument &&
      s.code() != absl::StatusCode::kAlreadyExists && s.code() != absl::StatusCode::kNotFound) {
    return s;
  }
  for (absl::string_view field : {"name", "role"}) {
    const std::string prefix = absl::StrCat(field, ": ");
    if (absl::StartsWith(s.message(), prefix)) {
      return server::FieldError(std::string(field), std::string(s.message().substr(prefix.size())),
                                s.code());
    }
  }
  return s;
}

}  // namespace

v1::Token ToProto(const storage::TokenRecord& r) {
  v1::Token t;
  t.set_name(absl::StrCat(kPrefix, r.name));
  t.set_id(r.id);
  t.set_role(r.role);
  *t.mutable_create_time() = ToTimestamp(r.created_at);
  if (r.revoked_at) *t.mutable_revoke_time() = ToTimestamp(*r.revoked_at);
  if (r.last_used) *t.mutable_last_used_time() = ToTimestamp(*r.last_used);
  t.set_revoked(r.revoked_at.has_value());
  return t;
}

absl::StatusOr<v1::CreateTokenResponse> TokenServiceCore::CreateToken(
    const v1::CreateTokenRequest& req, const server::CallContext& c) {
  // The request holds no secret, so it is audited as sent.
  const std::string request_json = server::ToAuditJson(req);
  auto result = [&]() -> absl::StatusOr<v1::CreateTokenResponse> {
    if (!ParseRole(req.role())) {
      return server::FieldError(
          "role",
          absl::StrCat("'", req.role(), "' is not one of viewer, operator, engineer, admin"));
    }
    auto name = TokenName(req.name());
    if (!name.ok()) return name.status();
    auto created = tokens_.Create(*name, req.role());
    if (!created.ok()) return Fielded(created.status());
    v1::CreateTokenResponse out;
    *out.mutable_token() = ToProto(created->record);
    out.set_secret(std::move(created->token));
    return out;
  }();
  server::WriteAudit(audit_, c, "", "CreateToken", request_json, result.status());
  return result;
}

absl::StatusOr<v1::ListTokensResponse> TokenServiceCore::ListTokens(
    const v1::ListTokensRequest& req, const server::CallContext& c) {
  auto result = [&]() -> absl::StatusOr<v1::ListTokensResponse> {
    auto records = tokens_.List(req.include_revoked());
    if (!records.ok()) return records.status();
    v1::ListTokensResponse out;
    for (const auto& r : *records) *out.add_tokens() = ToProto(r);
    return out;
  }();
  // Who looked at the token list is security information too.
  server::WriteAudit(audit_, c, "", "ListTokens", server::ToAuditJson(req), result.status());
  return result;
}

absl::StatusOr<v1::Token> TokenServiceCore::RevokeToken(const v1::RevokeTokenRequest& req,
                                                        const server::CallContext& c) {
  auto result = [&]() -> absl::StatusOr<v1::Token> {
    auto name = TokenName(req.name());
    if (!name.ok()) return name.status();
    auto revoked = tokens_.Revoke(*name);
    if (!revoked.ok()) return Fielded(revoked.status());
    return ToProto(*revoked);
  }();
  server::WriteAudit(audit_, c, "", "RevokeToken", server::ToAuditJson(req), result.status());
  return result;
}

}  // namespace drivegw::auth
