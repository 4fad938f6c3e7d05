// An IPv4 UDP endpoint (address + port) with parsing, printing, equality and hashing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/statusor.h"

namespace drivegw::transport {

struct Endpoint {
  static constexpr uint32_t kAny = 0x00000000;       // 0.0.0.0
  static constexpr uint32_t kLoopback = 0x7F000001;  // 127.0.0.1

  uint32_t ipv4 = kAny;  // host byte order: 127.0.0.1 = 0x7F000001
  uint16_t port = 0;     // host byte order; 0 = ephemeral when binding

  // "127.0.0.1:49360".
  std::string ToString() const;

  // Numeric dotted-quad IPv4 ("192.168.1.17", "0.0.0.0") or "localhost" (= 127.0.0.1); no DNS.
  // InvalidArgument naming the host otherwise.
  static absl::StatusOr<Endpoint> Parse(std::string_view host, uint16_t port);

  // Parse, else a host name resolved to its first IPv4 address (getaddrinfo: /etc/hosts, DNS,
  // a compose service name). Blocks while resolving: call it when a drive is activated, not on
  // a hot path. Unavailable naming the host when the name does not resolve.
  static absl::StatusOr<Endpoint> Resolve(std::string_view host, uint16_t port);

  friend bool operator==(const Endpoint&, const Endpoint&) = default;

  template <typename H>
  friend H AbslHashValue(H h, const Endpoint& e) {
    return H::combine(std::move(h), e.ipv4, e.port);
  }
};

// For std::unordered_map<Endpoint, ...>.
struct EndpointHash {
  size_t operator()(const Endpoint& e) const noexcept {
    return std::hash<uint64_t>()((uint64_t{e.ipv4} << 16) | e.port);
  }
};

}  // namespace drivegw::transport

template <>
struct std::hash<drivegw::transport::Endpoint> : drivegw::transport::EndpointHash {};
