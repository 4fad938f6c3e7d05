// IdempotencyCache: keyed outcomes with waiting duplicates, LRU + TTL bounds (decision 020).
#include "server/core/idempotency.h"

#include <array>

#include "absl/hash/hash.h"
#include "absl/strings/match.h"

namespace drivegw::server {
namespace {

// The key of one (principal, method, key) triple; NUL cannot occur in any of the three parts'
// sources (gRPC metadata values and method names are printable).
std::string EntryKey(const CallContext& c, std::string_view method) {
  return absl::StrCat(c.principal, std::string(1, '\0'), std::string(method), std::string(1, '\0'),
                      c.idempotency_key);
}

// Fixed-size bookkeeping per entry besides the response bytes.
constexpr size_t kEntryOverhead = 256;

}  // namespace

bool IsReadOnlyMethod(std::string_view method) {
  const size_t slash = method.rfind('/');
  const std::string_view name = slash == std::string_view::npos ? method : method.substr(slash + 1);
  static constexpr std::array<std::string_view, 8> kReadPrefixes = {
      "Get", "List", "Read", "Watch", "Diff", "Export", "Validate", "Verify"};
  for (std::string_view p : kReadPrefixes) {
    if (name.substr(0, p.size()) == p) return true;
  }
  return false;
}

bool IdempotencyCache::ForgetsResult(absl::StatusCode code) {
  switch (code) {
    // Refused before anything happened: a retry with the same key must be able to run
    // (the lease released, the drive back, the token fixed).
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kUnauthenticated:
    case absl::StatusCode::kUnavailable:
    case absl::StatusCode::kResourceExhausted:
    case absl::StatusCode::kUnimplemented:
    case absl::StatusCode::kCancelled:
    case absl::StatusCode::kAlreadyExists:
      return true;
    default:
      return false;  // OK, and outcomes after which the drive may have acted (deadline, internal)
  }
}

IdempotencyCache::IdempotencyCache(Options options, const Clock& clock)
    : options_(options), clock_(clock) {}

size_t IdempotencyCache::size() const {
  std::lock_guard lock(mu_);
  return lru_.size();
}

void IdempotencyCache::EvictLocked(TimePoint now) {
  // Oldest first; a pending entry is never in lru_, so an in-flight call is never evicted.
  while (!lru_.empty()) {
    auto it = entries_.find(lru_.back());
    const bool expired = it != entries_.end() && now >= it->second->expires;
    const bool over =
        lru_.size() > options_.max_entries || (bytes_ > options_.max_bytes && lru_.size() > 1);
    if (!expired && !over) break;
    if (it != entries_.end()) {
      bytes_ -= it->second->result.response.size() + kEntryOverhead;
      entries_.erase(it);
    }
    lru_.pop_back();
  }
  // Entries that expired but were used recently sit before the tail: drop them on lookup instead.
}

IdempotencyCache::Result IdempotencyCache::Run(const CallContext& c, std::string_view method,
                                               const std::string& request,
                                               const std::function<Result()>& call) {
  const std::string key = EntryKey(c, method);
  const uint64_t fingerprint = absl::HashOf(request);
  std::shared_ptr<Entry> entry;
  {
    std::unique_lock lock(mu_);
    const TimePoint now = clock_.Now();
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second->done && now >= it->second->expires) {
      bytes_ -= it->second->result.response.size() + kEntryOverhead;
      lru_.erase(it->second->lru);
      entries_.erase(it);
      it = entries_.end();
    }
    if (it != entries_.end()) {
      std::shared_ptr<Entry> first = it->second;
      if (first->fingerprint != fingerprint || first->request_size != request.size()) {
        return {absl::InvalidArgumentError(absl::StrCat(
                    "idempotency key '", c.idempotency_key, "' was used for ", std::string(method),
                    " with a different request body; use a new key for a new request")),
                ""};
      }
      done_cv_.wait(lock, [&] { return first->done; });
      auto kept = entries_.find(key);
      if (kept != entries_.end() && kept->second == first && first->in_lru) {
        lru_.splice(lru_.begin(), lru_, first->lru);  // recently used
      }
      return first->result;
    }
    entry = std::make_shared<Entry>();
    entry->fingerprint = fingerprint;
    entry->request_size = request.size();
    entries_[key] = entry;
  }
  Result result = call();
  {
    std::lock_guard lock(mu_);
    entry->result = result;
    entry->done = true;
    if (ForgetsResult(result.status.code())) {
      entries_.erase(key);  // waiting duplicates still get `result` through their shared_ptr
    } else {
      entry->expires = clock_.Now() + options_.ttl;
      lru_.push_front(key);
      entry->lru = lru_.begin();
      entry->in_lru = true;
      bytes_ += result.response.size() + kEntryOverhead;
      EvictLocked(clock_.Now());
    }
  }
  done_cv_.notify_all();
  return result;
}

}  // namespace drivegw::server
