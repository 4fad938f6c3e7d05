// TokenRepo: random ids and secrets from RAND_bytes, SHA-256 through EVP, constant-time compare
// with CRYPTO_memcmp (decision 015).
#include "storage/token_repo.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <array>
#include <cstdint>
#include <memory>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "storage/audit_log.h"  // FormatTimestamp, ParseTimestamp

namespace drivegw::storage {
namespace {

using Time = std::chrono::system_clock::time_point;

constexpr size_t kIdBytes = 8;       // 16 hex digits: a row key, not a secret
constexpr size_t kSecretBytes = 32;  // 256 bits of the token's secret
constexpr size_t kSaltBytes = 16;
constexpr size_t kSecretChars = 43;  // base64url of 32 bytes without padding
constexpr size_t kMaxNameLength = 128;
constexpr std::string_view kRoles[] = {"viewer", "operator", "engineer", "admin"};
constexpr char kColumns[] = "id, name, role, created_at, revoked_at, last_used";

Time NowMs() {
  return std::chrono::floor<std::chrono::milliseconds>(std::chrono::system_clock::now());
}

absl::StatusOr<std::string> RandomBytes(size_t n) {
  std::string out(n, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(out.data()), static_cast<int>(n)) != 1) {
    return absl::InternalError("token: the random source (RAND_bytes) failed");
  }
  return out;
}

std::string Hex(std::string_view bytes) {
  return absl::BytesToHexString(absl::string_view(bytes.data(), bytes.size()));
}

// RFC 4648 §5 base64url without padding: the secret fits an HTTP header and a shell argument.
std::string Base64Url(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (unsigned char c : bytes) {
    acc = (acc << 8) | c;
    bits += 8;
    while (bits >= 6) {
      bits -= 6;
      out.push_back(kAlphabet[(acc >> bits) & 0x3f]);
    }
  }
  if (bits > 0) out.push_back(kAlphabet[(acc << (6 - bits)) & 0x3f]);
  return out;
}

bool IsLowerHex(std::string_view s) {
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

bool IsBase64Url(std::string_view s) {
  for (char c : s) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_';
    if (!ok) return false;
  }
  return true;
}

// SHA-256(salt || secret): salt as raw bytes, secret as the base64url text the client sends.
absl::StatusOr<std::array<unsigned char, 32>> Digest(std::string_view salt,
                                                     std::string_view secret) {
  struct Free {
    void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
  };
  std::unique_ptr<EVP_MD_CTX, Free> ctx(EVP_MD_CTX_new());
  std::array<unsigned char, 32> out{};
  unsigned int len = 0;
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1 ||
      EVP_DigestUpdate(ctx.get(), salt.data(), salt.size()) != 1 ||
      EVP_DigestUpdate(ctx.get(), secret.data(), secret.size()) != 1 ||
      EVP_DigestFinal_ex(ctx.get(), out.data(), &len) != 1 || len != out.size()) {
    return absl::InternalError("token: SHA-256 (EVP) failed");
  }
  return out;
}

absl::Status ValidateName(std::string_view name) {
  if (name.empty() || name.size() > kMaxNameLength) {
    return absl::InvalidArgumentError(
        absl::StrCat("name: length ", name.size(), " is outside 1..", kMaxNameLength));
  }
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat("name: '", std::string(name),
                                                     "' has a character outside [A-Za-z0-9._-] "
                                                     "at index ",
                                                     i));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateRole(std::string_view role) {
  for (std::string_view r : kRoles) {
    if (r == role) return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "role: '", std::string(role), "' is not one of viewer, operator, engineer, admin"));
}

std::optional<Time> OptionalTime(const Statement& stmt, int column) {
  if (stmt.ColumnIsNull(column)) return std::nullopt;
  return ParseTimestamp(stmt.ColumnText(column)).value_or(Time{});
}

// Columns in kColumns order.
TokenRecord ReadRecord(const Statement& stmt) {
  TokenRecord r;
  r.id = stmt.ColumnText(0);
  r.name = stmt.ColumnText(1);
  r.role = stmt.ColumnText(2);
  r.created_at = ParseTimestamp(stmt.ColumnText(3)).value_or(Time{});
  r.revoked_at = OptionalTime(stmt, 4);
  r.last_used = OptionalTime(stmt, 5);
  return r;
}

absl::Status Unauthenticated(std::string_view why) {
  return absl::UnauthenticatedError(absl::StrCat("bearer token: ", std::string(why)));
}

}  // namespace

absl::StatusOr<NewToken> TokenRepo::Create(std::string_view name, std::string_view role) {
  DGW_RETURN_IF_ERROR(ValidateName(name));
  DGW_RETURN_IF_ERROR(ValidateRole(role));
  DGW_ASSIGN_OR_RETURN(const std::string id_bytes, RandomBytes(kIdBytes));
  DGW_ASSIGN_OR_RETURN(const std::string secret_bytes, RandomBytes(kSecretBytes));
  DGW_ASSIGN_OR_RETURN(const std::string salt, RandomBytes(kSaltBytes));
  NewToken out;
  out.record.id = Hex(id_bytes);
  out.record.name = std::string(name);
  out.record.role = std::string(role);
  out.record.created_at = NowMs();
  const std::string secret = Base64Url(secret_bytes);
  out.token = absl::StrCat(std::string(kPrefix), out.record.id, "_", secret);
  DGW_ASSIGN_OR_RETURN(const auto digest, Digest(salt, secret));
  const std::string hash(reinterpret_cast<const char*>(digest.data()), digest.size());

  DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
    DGW_ASSIGN_OR_RETURN(
        Statement live,
        db_->Prepare("SELECT 1 FROM api_tokens WHERE name = ?1 AND revoked_at IS NULL"));
    DGW_RETURN_IF_ERROR(live.Bind(1, name));
    DGW_ASSIGN_OR_RETURN(const bool taken, live.Step());
    if (taken) {
      return absl::AlreadyExistsError(
          absl::StrCat("name: a live token '", std::string(name), "' exists (revoke it first)"));
    }
    DGW_ASSIGN_OR_RETURN(Statement insert,
                         db_->Prepare("INSERT INTO api_tokens (id, name, role, salt, "
                                      "secret_hash, created_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6)"));
    DGW_RETURN_IF_ERROR(insert.Bind(1, std::string_view(out.record.id)));
    DGW_RETURN_IF_ERROR(insert.Bind(2, name));
    DGW_RETURN_IF_ERROR(insert.Bind(3, role));
    DGW_RETURN_IF_ERROR(insert.Bind(4, std::string_view(Hex(salt))));
    DGW_RETURN_IF_ERROR(insert.Bind(5, std::string_view(Hex(hash))));
    DGW_RETURN_IF_ERROR(insert.Bind(6, std::string_view(FormatTimestamp(out.record.created_at))));
    return insert.Run();
  }));
  return out;
}

absl::StatusOr<std::vector<TokenRecord>> TokenRepo::List(bool include_revoked) {
  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt,
                       db_->Prepare(absl::StrCat("SELECT ", kColumns, " FROM api_tokens",
                                                 include_revoked ? "" : " WHERE revoked_at IS NULL",
                                                 " ORDER BY created_at, rowid")));
  std::vector<TokenRecord> out;
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadRecord(stmt));
  }
  return out;
}

absl::StatusOr<TokenRecord> TokenRepo::Revoke(std::string_view name) {
  TokenRecord out;
  DGW_RETURN_IF_ERROR(db_->Transaction([&]() -> absl::Status {
    DGW_ASSIGN_OR_RETURN(Statement find,
                         db_->Prepare(absl::StrCat("SELECT ", kColumns,
                                                   " FROM api_tokens WHERE name = ?1 AND "
                                                   "revoked_at IS NULL")));
    DGW_RETURN_IF_ERROR(find.Bind(1, name));
    DGW_ASSIGN_OR_RETURN(const bool row, find.Step());
    if (!row) {
      return absl::NotFoundError(absl::StrCat("name: no live token '", std::string(name), "'"));
    }
    out = ReadRecord(find);
    out.revoked_at = NowMs();
    DGW_ASSIGN_OR_RETURN(Statement update,
                         db_->Prepare("UPDATE api_tokens SET revoked_at = ?1 WHERE id = ?2"));
    DGW_RETURN_IF_ERROR(update.Bind(1, std::string_view(FormatTimestamp(*out.revoked_at))));
    DGW_RETURN_IF_ERROR(update.Bind(2, std::string_view(out.id)));
    return update.Run();
  }));
  return out;
}

absl::StatusOr<TokenRecord> TokenRepo::Verify(std::string_view token) {
  // "dgw_" + 16 hex + "_" + 43 base64url: anything else is refused before the database.
  constexpr size_t kIdChars = 2 * kIdBytes;
  if (token.size() != kPrefix.size() + kIdChars + 1 + kSecretChars ||
      token.substr(0, kPrefix.size()) != kPrefix || token[kPrefix.size() + kIdChars] != '_') {
    return Unauthenticated("malformed (want dgw_<id>_<secret>, as `drivegw token create` prints)");
  }
  const std::string_view id = token.substr(kPrefix.size(), kIdChars);
  const std::string_view secret = token.substr(kPrefix.size() + kIdChars + 1);
  if (!IsLowerHex(id) || !IsBase64Url(secret)) {
    return Unauthenticated("malformed (want dgw_<id>_<secret>, as `drivegw token create` prints)");
  }

  TokenRecord record;
  std::string salt_hex;
  std::string hash_hex;
  {
    auto lock = db_->Lock();
    DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(absl::StrCat(
                                             "SELECT ", kColumns,
                                             ", salt, secret_hash FROM api_tokens WHERE id = ?1")));
    DGW_RETURN_IF_ERROR(stmt.Bind(1, id));
    DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
    if (!row) return Unauthenticated("unknown or wrong token");
    record = ReadRecord(stmt);
    salt_hex = stmt.ColumnText(6);
    hash_hex = stmt.ColumnText(7);
  }
  const std::string salt = absl::HexStringToBytes(salt_hex);
  const std::string stored = absl::HexStringToBytes(hash_hex);
  DGW_ASSIGN_OR_RETURN(const auto digest, Digest(salt, secret));
  // CRYPTO_memcmp takes the same time wherever the first difference is.
  if (stored.size() != digest.size() ||
      CRYPTO_memcmp(stored.data(), digest.data(), digest.size()) != 0) {
    return Unauthenticated("unknown or wrong token");
  }
  if (record.revoked_at) {
    return Unauthenticated(absl::StrCat("token '", record.name, "' was revoked at ",
                                        FormatTimestamp(*record.revoked_at)));
  }

  // last_used: one write per token per kLastUsedResolution, not one per call.
  const Time now = NowMs();
  bool write = false;
  {
    std::lock_guard lock(mu_);
    auto [it, inserted] = last_used_written_.try_emplace(record.id, now);
    if (inserted || now - it->second >= kLastUsedResolution) {
      it->second = now;
      write = true;
    }
  }
  if (write) {
    auto lock = db_->Lock();
    auto stmt = db_->Prepare("UPDATE api_tokens SET last_used = ?1 WHERE id = ?2");
    // A failed bookkeeping write does not refuse a valid token.
    if (stmt.ok() && stmt->Bind(1, std::string_view(FormatTimestamp(now))).ok() &&
        stmt->Bind(2, std::string_view(record.id)).ok() && stmt->Run().ok()) {
      record.last_used = now;
    }
  }
  return record;
}

}  // namespace drivegw::storage
