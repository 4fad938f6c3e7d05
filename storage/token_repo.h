// API bearer tokens in SQLite (issue 7 "Authentication and authorisation", migration 004,
// decision 015): a token is "dgw_<id>_<secret>", stored only as a random salt and
// SHA-256(salt || secret). The secret is returned once, by Create; Verify reads the row on every
// call, so a revocation (by the API or by the CLI in another process) holds from the next call.
#pragma once

#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/db.h"

namespace drivegw::storage {

// One token as stored, without its secret.
struct TokenRecord {
  std::string id;    // 16 lower-case hex digits, unique; the "<id>" part of the token
  std::string name;  // 1..128 characters [A-Za-z0-9._-]; unique among live tokens
  std::string role;  // "viewer", "operator", "engineer" or "admin" (migration 004 checks it)
  std::chrono::system_clock::time_point created_at{};
  std::optional<std::chrono::system_clock::time_point> revoked_at;
  // Updated at most once per TokenRepo::kLastUsedResolution per token (no write per call).
  std::optional<std::chrono::system_clock::time_point> last_used;
};

// What Create hands out: the record and the one copy of the secret token.
struct NewToken {
  TokenRecord record;
  std::string token;  // "dgw_<id>_<43 base64url characters of 32 random bytes>"
};

class TokenRepo {
 public:
  static constexpr std::string_view kPrefix = "dgw_";
  static constexpr std::chrono::seconds kLastUsedResolution{60};

  // Keeps `db`, which must outlive this object and be migrated (004_auth_tokens).
  explicit TokenRepo(Db& db) : db_(&db) {}

  // A new live token. InvalidArgument naming `name` or `role` for a bad value; AlreadyExists
  // when a live token already has the name (revoke it first; a revoked name may be reused).
  // Internal when the random source fails (RAND_bytes).
  absl::StatusOr<NewToken> Create(std::string_view name, std::string_view role);

  // Every token, oldest first; revoked ones only with include_revoked.
  absl::StatusOr<std::vector<TokenRecord>> List(bool include_revoked = true);

  // Revokes the live token called `name`: NotFound when there is none.
  absl::StatusOr<TokenRecord> Revoke(std::string_view name);

  // The live token `token` ("dgw_<id>_<secret>") is, or Unauthenticated: malformed, unknown id,
  // wrong secret (compared in constant time) or revoked. Messages never echo the secret.
  absl::StatusOr<TokenRecord> Verify(std::string_view token);

 private:
  Db* db_;
  std::mutex mu_;  // last_used_written_
  // When each token's last_used was last written by this process.
  std::map<std::string, std::chrono::system_clock::time_point> last_used_written_;
};

}  // namespace drivegw::storage
