// A per-route cache of printed JSON for the direct read path (issue 10 P4, decision 1361): a
// response message whose deterministic wire bytes equal those of a message printed before is
// answered with that JSON instead of printing again. The key is the whole message, so no field
// can change without a print: there is no version to keep in step with the core.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"

namespace google::protobuf {
class Descriptor;
class Message;
}  // namespace google::protobuf

namespace drivegw::rest {

class JsonCache {
 public:
  // PrintJson(msg), from the cache when a message with the same deterministic serialization was
  // printed by this cache and is still in its slot. Thread-safe.
  absl::StatusOr<std::string> Print(const google::protobuf::Message& msg);

  // Lookups answered from the cache / printed, since construction (tests and benchmarks).
  uint64_t hits() const;
  uint64_t misses() const;

 private:
  // One entry per slot, chosen by the hash of the key: a few drives polled in turn each keep
  // their own slot; a collision only costs a print.
  static constexpr size_t kSlots = 64;
  struct Entry {
    const google::protobuf::Descriptor* type = nullptr;
    std::string key;  // deterministic wire bytes of the printed message
    std::string json;
  };
  // Entries are immutable once stored: the lock only guards swapping the pointers, and the
  // comparison and the copy of the text run outside it (two Beast threads share a route).
  std::mutex mu_;
  std::array<std::shared_ptr<const Entry>, kSlots> slots_;
  std::atomic<uint64_t> hits_{0};
  std::atomic<uint64_t> misses_{0};
};

}  // namespace drivegw::rest
