// Canonical audit entry form and SHA-256 through OpenSSL's EVP interface.
#include "storage/audit_log_hash.h"

#include <openssl/evp.h>

#include <array>
#include <string>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"

namespace drivegw::storage {
namespace {

void Field(std::string& out, std::string_view name, std::string_view value) {
  // Appended piece by piece: no temporaries (callers build one form per audited command).
  out.append(name);
  out.push_back(' ');
  out.append(std::to_string(value.size()));
  out.push_back(':');
  out.append(value);
  out.push_back('\n');
}

}  // namespace

struct Sha256::Ctx {
  struct Free {
    void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
  };
  std::unique_ptr<EVP_MD_CTX, Free> md{EVP_MD_CTX_new()};
};

namespace {

// Fetched once: with OpenSSL 3, EVP_sha256() makes every EVP_DigestInit_ex look the provider's
// implementation up again (an implicit fetch under a lock), once per audited command. Kept for
// the life of the process.
const EVP_MD* Sha256Md() {
  static const EVP_MD* const md = [] {
    const EVP_MD* fetched = EVP_MD_fetch(nullptr, "SHA256", nullptr);
    return fetched != nullptr ? fetched : EVP_sha256();
  }();
  return md;
}

}  // namespace

Sha256::Sha256() : ctx_(std::make_unique<Ctx>()) {
  // Allocation failure of a 200-byte context: nothing sensible remains but to stop.
  if (!ctx_->md || EVP_DigestInit_ex(ctx_->md.get(), Sha256Md(), nullptr) != 1) std::abort();
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

namespace {

std::string SeqPart(int64_t seq) {
  std::string out = "drivegw.audit.v1\n";
  Field(out, "seq", absl::StrCat(seq));
  return out;
}

std::string PrevPart(std::string_view prev_hash) {
  std::string out;
  Field(out, "prev_hash", prev_hash);
  return out;
}

}  // namespace

PreparedAuditEntry PrepareAuditEntry(const AuditEntry& e) {
  PreparedAuditEntry p;
  p.ts = FormatTimestamp(e.time);
  p.body.reserve(256 + e.principal.size() + e.source_address.size() + e.request_json.size() +
                 e.result_message.size() + e.before_json.size() + e.after_json.size());
  Field(p.body, "ts", p.ts);
  Field(p.body, "principal", e.principal);
  Field(p.body, "role", e.role);
  Field(p.body, "source_address", e.source_address);
  Field(p.body, "drive", e.drive);
  Field(p.body, "action", e.action);
  Field(p.body, "request_json", e.request_json);
  Field(p.body, "result_code", absl::StrCat(e.result_code));
  Field(p.body, "result_message", e.result_message);
  Field(p.body, "before_json", e.before_json);
  Field(p.body, "after_json", e.after_json);
  return p;
}

std::string CanonicalAuditForm(int64_t seq, const AuditEntry& e, std::string_view prev_hash) {
  return absl::StrCat(SeqPart(seq), PrepareAuditEntry(e).body, PrevPart(prev_hash));
}

std::string PreparedAuditHash(int64_t seq, const PreparedAuditEntry& prepared,
                              std::string_view prev_hash) {
  Sha256 sha;
  sha.Update(SeqPart(seq));
  sha.Update(prepared.body);
  sha.Update(PrevPart(prev_hash));
  return sha.HexDigest();
}

std::string AuditEntryHash(int64_t seq, const AuditEntry& entry, std::string_view prev_hash) {
  return PreparedAuditHash(seq, PrepareAuditEntry(entry), prev_hash);
}

}  // namespace drivegw::storage
