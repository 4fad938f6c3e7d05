// The audit hash chain's canonical serialisation and SHA-256 (OpenSSL libcrypto), decision 017.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace drivegw::storage {

struct AuditEntry;

// prev_hash of the first chained row (the genesis anchor): 64 zeros.
inline constexpr std::string_view kGenesisPrevHash =
    "0000000000000000000000000000000000000000000000000000000000000000";

// "drivegw.audit.v1\n" then, per field in the fixed order seq, ts, principal, role,
// source_address, drive, action, request_json, result_code, result_message, before_json,
// after_json, prev_hash: "<name> <byte length>:<bytes>\n". Length-prefixed, so no field content
// (quotes, newlines, NUL) can shift a boundary; integers in decimal ASCII, ts as stored
// (FormatTimestamp). Decision 017 spells it out for verifiers outside drivegw.
std::string CanonicalAuditForm(int64_t seq, const AuditEntry& entry, std::string_view prev_hash);

// Lowercase hex SHA-256 of CanonicalAuditForm(seq, entry, prev_hash).
std::string AuditEntryHash(int64_t seq, const AuditEntry& entry, std::string_view prev_hash);

// An entry's stored timestamp text and the middle of its canonical form (fields ts ..
// after_json), which do not depend on the chain: each caller builds them on its own thread
// before it queues for the group-commit writer, which then only adds seq and prev_hash.
struct PreparedAuditEntry {
  std::string ts;    // FormatTimestamp(entry.time), bound as the row's ts
  std::string body;  // "ts <n>:<ts>\n" .. "after_json <n>:<after_json>\n"
};
PreparedAuditEntry PrepareAuditEntry(const AuditEntry& entry);
// Equals AuditEntryHash(seq, entry, prev_hash) for `prepared` = PrepareAuditEntry(entry).
std::string PreparedAuditHash(int64_t seq, const PreparedAuditEntry& prepared,
                              std::string_view prev_hash);

// Incremental SHA-256 (EVP), for digests over many rows.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void Update(std::string_view bytes);
  // Lowercase hex; the object is spent afterwards.
  std::string HexDigest();

 private:
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
};

}  // namespace drivegw::storage
