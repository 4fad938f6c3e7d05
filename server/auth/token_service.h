// TokenService core (proto drivegw/v1/auth.proto): create, list and revoke API tokens over
// storage::TokenRepo; every call audited, never with the secret (issue 7, decision 015). The
// role check (admin) is done before, by the one enforcement point (server/grpc/call_auth.h).
#pragma once

#include "absl/status/statusor.h"
#include "drivegw/v1/auth.pb.h"
#include "server/core/call_context.h"
#include "storage/token_repo.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::auth {

class TokenServiceCore {
 public:
  // `tokens` (and `audit`, which may be null in tests) must outlive this object.
  TokenServiceCore(storage::TokenRepo& tokens, storage::AuditLog* audit)
      : tokens_(tokens), audit_(audit) {}

  absl::StatusOr<v1::CreateTokenResponse> CreateToken(const v1::CreateTokenRequest& req,
                                                      const server::CallContext& c);
  absl::StatusOr<v1::ListTokensResponse> ListTokens(const v1::ListTokensRequest& req,
                                                    const server::CallContext& c);
  absl::StatusOr<v1::Token> RevokeToken(const v1::RevokeTokenRequest& req,
                                        const server::CallContext& c);

 private:
  storage::TokenRepo& tokens_;
  storage::AuditLog* audit_;
};

// storage -> API: "tokens/<name>", timestamps, no secret.
v1::Token ToProto(const storage::TokenRecord& record);

}  // namespace drivegw::auth
