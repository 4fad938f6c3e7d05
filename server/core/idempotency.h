// Idempotent mutating calls (issue 7, decision 020): a call carrying an idempotency key returns
// the first call's result for a retry with the same key, principal and method, runs at most once
// while concurrent retries wait for it, and refuses the same key with a different request body.
// Bounded memory: LRU over a maximum entry count and byte size, plus a time to live on the
// injected clock. RunIdempotent is the one hook the gRPC front end calls around every unary call.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/clock.h"
#include "google/protobuf/io/coded_stream.h"
#include "google/protobuf/io/zero_copy_stream_impl_lite.h"
#include "google/protobuf/message.h"
#include "server/core/call_context.h"
#include "server/core/errors.h"

namespace drivegw::server {

// Longest idempotency key accepted, in bytes (decision 1452): the cache charges each entry a fixed
// kEntryOverhead of 256 bytes for its bookkeeping, key included, so max_bytes bounds memory only
// if keys stay that small; gRPC would otherwise let a client store up to its 8 KiB metadata limit
// per entry, 10000 entries deep. 256 fits a UUID (36) or a ULID (26) many times over.
inline constexpr size_t kMaxIdempotencyKeyBytes = 256;

// Bounds of the cache (decision 020).
struct IdempotencyOptions {
  Duration ttl = std::chrono::hours(24);
  size_t max_entries = 10000;
  size_t max_bytes = 64u << 20;  // response bytes plus a fixed overhead per entry
};

class IdempotencyCache {
 public:
  using Options = IdempotencyOptions;
  // One call's recorded outcome: the response message's bytes when `status` is OK.
  struct Result {
    absl::Status status;
    std::string response;
  };

  explicit IdempotencyCache(Options options = Options(),
                            const Clock& clock = SteadyClock::Instance());

  // Runs `call` for the first (principal, method, key) and returns its result; a later call with
  // the same triple and the same `request` bytes gets that result without running `call`, one
  // with different bytes InvalidArgument naming the key. A call arriving while the first runs
  // waits for it. Results that say nothing happened (ForgetsResult) are returned but not kept,
  // so a retry runs again.
  Result Run(const CallContext& c, std::string_view method, const std::string& request,
             const std::function<Result()>& call);

  size_t size() const;  // kept (finished) entries, for tests

  // Codes after which a retry runs again: the call was refused before it could act.
  static bool ForgetsResult(absl::StatusCode code);

 private:
  struct Entry {
    uint64_t fingerprint = 0;
    size_t request_size = 0;
    bool done = false;
    Result result;
    TimePoint expires;
    std::list<std::string>::iterator lru;  // valid when in_lru
    bool in_lru = false;
  };

  void EvictLocked(TimePoint now);

  const Options options_;
  const Clock& clock_;
  mutable std::mutex mu_;
  std::condition_variable done_cv_;
  std::map<std::string, std::shared_ptr<Entry>> entries_;  // guarded by mu_
  std::list<std::string> lru_;                             // finished keys, newest first
  size_t bytes_ = 0;                                       // responses of finished entries
};

// Read-only methods ("Get…", "List…", "Read…", "Watch…", "Diff…", "Export…", "Validate…",
// "Verify…") are never recorded: a retry of a read must see the present.
bool IsReadOnlyMethod(std::string_view method);

// The hook: runs `fn()` (returning absl::StatusOr<Resp>) through `cache` when the call carries
// an idempotency key and `method` ("drivegw.v1.DriveService/MoveAbsolute") mutates; otherwise
// just runs it. `cache` may be null.
template <typename Req, typename Fn>
auto RunIdempotent(IdempotencyCache* cache, std::string_view method, const Req& request,
                   const CallContext& c, Fn fn) -> decltype(fn()) {
  using Out = decltype(fn());
  if (c.idempotency_key.empty() || IsReadOnlyMethod(method)) return fn();
  if (c.idempotency_key.size() > kMaxIdempotencyKeyBytes) {
    return FieldError("Idempotency-Key",
                      absl::StrCat(c.idempotency_key.size(), " bytes exceeds the limit of ",
                                   kMaxIdempotencyKeyBytes, " bytes"));
  }
  if (cache == nullptr) return fn();
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream raw(&bytes);
    google::protobuf::io::CodedOutputStream out(&raw);
    out.SetSerializationDeterministic(true);  // map fields in key order: one body, one fingerprint
    request.SerializeToCodedStream(&out);
  }
  IdempotencyCache::Result r = cache->Run(c, method, bytes, [&] {
    Out out = fn();
    IdempotencyCache::Result res;
    res.status = out.status();
    if (out.ok()) res.response = out->SerializeAsString();
    return res;
  });
  if (!r.status.ok()) return r.status;
  typename Out::value_type resp;
  if (!resp.ParseFromString(r.response)) {
    return absl::InternalError(absl::StrCat("idempotency key '", c.idempotency_key,
                                            "': the recorded response does not parse"));
  }
  return resp;
}

}  // namespace drivegw::server
