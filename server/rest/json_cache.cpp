// JsonCache: deterministic wire bytes as the key of the printed JSON (decision 1361).
#include "server/rest/json_cache.h"

#include <functional>
#include <string_view>

#include "google/protobuf/io/coded_stream.h"
#include "google/protobuf/io/zero_copy_stream_impl_lite.h"
#include "google/protobuf/message.h"
#include "server/rest/json_print.h"

namespace drivegw::rest {

absl::StatusOr<std::string> JsonCache::Print(const google::protobuf::Message& msg) {
  // Deterministic: map entries sorted, so equal messages give equal bytes. Equal bytes parse to
  // equal messages (doubles are compared by bit pattern in protobuf 3.21's generated
  // serializers, -0.0 included), and PrintJson's text depends on the message alone: equal bytes,
  // equal JSON. Unknown fields only make the key stricter. The buffer is reused per thread.
  thread_local std::string key;
  key.clear();
  {
    google::protobuf::io::StringOutputStream stream(&key);
    google::protobuf::io::CodedOutputStream out(&stream);
    out.SetSerializationDeterministic(true);
    if (!msg.SerializeToCodedStream(&out)) return PrintJson(msg);
  }
  // The type is part of the key: two types can share wire bytes.
  const google::protobuf::Descriptor* type = msg.GetDescriptor();
  const size_t slot = std::hash<std::string_view>{}(key) % kSlots;
  std::shared_ptr<const Entry> entry;
  {
    std::lock_guard lock(mu_);
    entry = slots_[slot];
  }
  if (entry != nullptr && entry->type == type && entry->key == key) {
    hits_.fetch_add(1, std::memory_order_relaxed);
    return entry->json;
  }
  misses_.fetch_add(1, std::memory_order_relaxed);
  absl::StatusOr<std::string> json = PrintJson(msg);
  if (!json.ok()) return json;
  auto printed = std::make_shared<const Entry>(Entry{type, key, *json});
  std::lock_guard lock(mu_);
  slots_[slot] = std::move(printed);
  return json;
}

uint64_t JsonCache::hits() const { return hits_.load(std::memory_order_relaxed); }

uint64_t JsonCache::misses() const { return misses_.load(std::memory_order_relaxed); }

}  // namespace drivegw::rest
