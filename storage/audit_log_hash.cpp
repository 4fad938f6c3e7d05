// Canonical audit entry form and SHA-256 through OpenSSL's EVP interface.
#include "storage/audit_log_hash.h"

#include <openssl/evp.h>

#include <array>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"

namespace drivegw::storage {
namespace {

void Field(std::string& out, std::string_view name, std::string_view value) {
  absl::StrAppend(&out, std::string(name), " ", value.size(), ":", std::string(value), "\n");
}

}  // namespace

struct Sha256::Ctx {
  struct Free {
    void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
  };
  std::unique_ptr<EVP_MD_CTX, Free> md{EVP_MD_CTX_new()};
};

Sha256::Sha256() : ctx_(std::make_unique<Ctx>()) {
  // Allocation failure of a 200-byte context: nothing sensible remains but to stop.
  if (!ctx_->md || EVP_DigestInit_ex(ctx_->md.get(), EVP_sha256(), nullptr) != 1) std::abort();
}
Sha256::~Sha256() = default;

void Sha256::Update(std::string_view bytes) {
  EVP_DigestUpdate(ctx_->md.get(), bytes.data(), bytes.size());
}

std::string Sha256::HexDigest() {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx_->md.get(), digest.data(), &len);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * len);
  for (unsigned int i = 0; i < len; ++i) {
    out.push_back(kHex[digest[i] >> 4]);
    out.push_back(kHex[digest[i] & 0xf]);
  }
  return out;
}

std::string CanonicalAuditForm(int64_t seq, const AuditEntry& e, std::string_view prev_hash) {
  std::string out = "drivegw.audit.v1\n";
  Field(out, "seq", absl::StrCat(seq));
  Field(out, "ts", FormatTimestamp(e.time));
  Field(out, "principal", e.principal);
  Field(out, "role", e.role);
  Field(out, "source_address", e.source_address);
  Field(out, "drive", e.drive);
  Field(out, "action", e.action);
  Field(out, "request_json", e.request_json);
  Field(out, "result_code", absl::StrCat(e.result_code));
  Field(out, "result_message", e.result_message);
  Field(out, "before_json", e.before_json);
  Field(out, "after_json", e.after_json);
  Field(out, "prev_hash", prev_hash);
  return out;
}

std::string AuditEntryHash(int64_t seq, const AuditEntry& entry, std::string_view prev_hash) {
  Sha256 sha;
  sha.Update(CanonicalAuditForm(seq, entry, prev_hash));
  return sha.HexDigest();
}

}  // namespace drivegw::storage
