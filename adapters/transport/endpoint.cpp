// Endpoint parsing and printing: Parse is numeric IPv4 only (never blocks or hits DNS); Resolve
// adds host names for the addresses of drives (docs/config.md: linudp.host).
#include "adapters/transport/endpoint.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace drivegw::transport {

std::string Endpoint::ToString() const {
  return absl::StrCat((ipv4 >> 24) & 0xFF, ".", (ipv4 >> 16) & 0xFF, ".", (ipv4 >> 8) & 0xFF, ".",
                      ipv4 & 0xFF, ":", port);
}

absl::StatusOr<Endpoint> Endpoint::Parse(std::string_view host, uint16_t port) {
  if (host == "localhost") return Endpoint{kLoopback, port};
  // inet_pton accepts exactly the dotted quad (no octal, no short forms), unlike inet_aton.
  // A std::string: this abseil's StrCat does not take std::string_view.
  const std::string text(host);
  in_addr addr{};
  if (host.empty() || inet_pton(AF_INET, text.c_str(), &addr) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("endpoint host '", text, "': not a numeric IPv4 address or 'localhost'"));
  }
  return Endpoint{ntohl(addr.s_addr), port};
}

absl::StatusOr<Endpoint> Endpoint::Resolve(std::string_view host, uint16_t port) {
  absl::StatusOr<Endpoint> numeric = Parse(host, port);
  if (numeric.ok() || host.empty()) return numeric;
  const std::string name(host);
  addrinfo hints{};
  hints.ai_family = AF_INET;  // LinUDP is IPv4 (linmot-linudp.md §1)
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int rc = getaddrinfo(name.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr) {
    return absl::UnavailableError(absl::StrCat(
        "endpoint host '", name,
        "': cannot resolve to an IPv4 address: ", rc != 0 ? gai_strerror(rc) : "no address"));
  }
  // The first IPv4 address, as getaddrinfo orders them (RFC 6724 / gai.conf).
  const auto* in = reinterpret_cast<const sockaddr_in*>(found->ai_addr);
  const Endpoint e{ntohl(in->sin_addr.s_addr), port};
  freeaddrinfo(found);
  return e;
}

}  // namespace drivegw::transport
