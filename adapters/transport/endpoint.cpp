// Endpoint parsing and printing: numeric IPv4 only, so resolving never blocks or hits DNS.
#include "adapters/transport/endpoint.h"

#include <arpa/inet.h>

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

}  // namespace drivegw::transport
