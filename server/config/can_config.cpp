// The `can:` mapping of the CAN families: one bus, socketcan or the user-space UDP bus.
#include "server/config/can_config.h"

#include <arpa/inet.h>

#include <algorithm>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "adapters/transport/can_bit_timing.h"

namespace drivegw::config::internal {
namespace {

constexpr int64_t kMaxPort = 65535;
constexpr size_t kMaxInterfaceLength = 15;  // IFNAMSIZ - 1
constexpr int64_t kMaxBitrate = 1000000;    // classic CAN's highest bit rate (ISO 11898-2)

// Linux dev_valid_name: 1..15 characters, not "." or "..", no '/', ':' or white space.
bool IsValidInterfaceName(std::string_view name) {
  if (name.empty() || name.size() > kMaxInterfaceLength || name == "." || name == "..") {
    return false;
  }
  return std::none_of(name.begin(), name.end(), [](char c) {
    return c == '/' || c == ':' || c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\0';
  });
}

// Dotted-quad IPv4 in 224.0.0.0/4 (python-can's udp_multicast default is 239.74.163.2).
bool IsIpv4Multicast(const std::string& text) {
  in_addr addr{};
  return ::inet_pton(AF_INET, text.c_str(), &addr) == 1 && (ntohl(addr.s_addr) >> 28) == 0xE;
}

}  // namespace

// can: {socketcan: {interface: can0}} | {udp: {group: G, port: P, bitrate: B}}, optional trace
// (docs/config.md "can"; docs/decisions/801-can-channel.md).
void ParseCan(const Section& parent, CanBusConfig& out) {
  const YAML::Node node = *parent.Get("can");
  const Section s(node, parent.Child("can"), {"socketcan", "udp", "trace"}, parent.errors());
  if (!node.IsMap()) {
    if (node.IsNull()) {
      s.errors().Add(s.Label(), "needs exactly one of socketcan, udp", node);
    }
    return;
  }
  const bool socketcan = s.Has("socketcan");
  const bool udp = s.Has("udp");
  if (socketcan == udp) {
    s.errors().Add(s.Label(),
                   socketcan ? "has both socketcan and udp; a drive is on one bus"
                             : "needs exactly one of socketcan, udp",
                   node);
  }
  if (socketcan) {
    out.kind = CanBusConfig::Kind::kSocketCan;
    const YAML::Node sub = *s.Get("socketcan");
    const Section sc(sub, s.Child("socketcan"), {"interface"}, s.errors());
    if (sub.IsNull() || sub.IsMap()) {
      if (!sub.IsMap()) {
        sc.errors().Add(sc.Child("interface"), "required", YAML::Node());
      } else if (sc.String("interface", out.interface, /*required=*/true) &&
                 !IsValidInterfaceName(out.interface)) {
        sc.errors().Add(sc.Child("interface"),
                        absl::StrCat("'", out.interface,
                                     "' is not a network interface name (1..15 characters, no "
                                     "'/', ':' or spaces)"),
                        *sc.Get("interface"));
      }
    }
  } else if (udp) {
    out.kind = CanBusConfig::Kind::kUdpMulticast;
    const YAML::Node sub = *s.Get("udp");
    const Section u(sub, s.Child("udp"), {"group", "port", "bitrate"}, s.errors());
    if (sub.IsMap()) {  // "udp:" alone takes python-can's defaults
      if (u.String("group", out.group) && !IsIpv4Multicast(out.group)) {
        u.errors().Add(
            u.Child("group"),
            absl::StrCat("'", out.group, "' is not an IPv4 multicast address (224.0.0.0/4)"),
            *u.Get("group"));
      }
      int64_t port = 0;
      if (u.Int("port", 1, kMaxPort, port)) out.port = static_cast<uint16_t>(port);
      // Optional bit timing of the virtual bus (decision 805): a real bit rate or nothing.
      int64_t bitrate = 0;
      if (u.Int("bitrate", 1, kMaxBitrate, bitrate)) {
        if (transport::IsSupportedCanBitrate(static_cast<uint32_t>(bitrate))) {
          out.bitrate = static_cast<uint32_t>(bitrate);
        } else {
          u.errors().Add(u.Child("bitrate"),
                         absl::StrCat(bitrate,
                                      " is not one of 125000, 250000, 500000, 1000000 "
                                      "(bit/s; omit the key for an unpaced bus)"),
                         *u.Get("bitrate"));
        }
      }
    }
  }
  if (s.String("trace", out.trace_file) && out.trace_file.empty()) {
    s.errors().Add(s.Child("trace"), "must not be empty (omit the key to trace nothing)",
                   *s.Get("trace"));
  }
}

std::string BusKey(const CanBusConfig& can) {
  if (can.kind == CanBusConfig::Kind::kSocketCan) return absl::StrCat("socketcan:", can.interface);
  return absl::StrCat("udp:", can.group, ":", can.port);
}

}  // namespace drivegw::config::internal
