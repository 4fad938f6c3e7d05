// CanChannel helpers: state names, filter validation, the back-end factory and --can specs.
#include "adapters/transport/can_channel.h"

#include <arpa/inet.h>

#include <charconv>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "adapters/transport/can_bit_timing.h"
#include "adapters/transport/candump_trace.h"
#include "adapters/transport/socketcan_channel.h"
#include "adapters/transport/udp_multicast_channel.h"

namespace drivegw::transport {
namespace {

std::string Hex(uint32_t value) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "0x%X", value);
  return buf;
}

absl::Status SpecError(std::string_view spec, std::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat("--can '", std::string(spec.substr(0, 80)), "': ", std::string(what)));
}

}  // namespace

const char* CanBusStateName(CanBusState state) {
  switch (state) {
    case CanBusState::kActive:
      return "active";
    case CanBusState::kWarning:
      return "warning";
    case CanBusState::kPassive:
      return "passive";
    case CanBusState::kBusOff:
      return "bus-off";
    case CanBusState::kDown:
      return "down";
  }
  return "unknown";
}

absl::Status ValidateCanFilters(std::span<const CanFilter> filters) {
  if (filters.size() > kMaxCanFilters) {
    return absl::InvalidArgumentError(absl::StrCat("can filters: ", filters.size(),
                                                   " filters exceed ", kMaxCanFilters,
                                                   " (CAN_RAW_FILTER_MAX)"));
  }
  for (size_t i = 0; i < filters.size(); ++i) {
    const CanFilter& f = filters[i];
    const uint32_t limit = f.extended ? kCanExtendedIdMax : kCanStandardIdMax;
    const char* format = f.extended ? " (29-bit extended format)" : " (11-bit base format)";
    if (f.id > limit) {
      return absl::InvalidArgumentError(
          absl::StrCat("can filters[", i, "].id: ", Hex(f.id), " exceeds ", Hex(limit), format));
    }
    if (f.mask > limit) {
      return absl::InvalidArgumentError(absl::StrCat("can filters[", i, "].mask: ", Hex(f.mask),
                                                     " exceeds ", Hex(limit), format));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<CanChannel>> OpenCanChannel(const CanBusConfig& config) {
  std::shared_ptr<CandumpTrace> trace;
  if (!config.trace_file.empty()) {
    auto opened = CandumpTrace::Open(config.trace_file);
    if (!opened.ok()) return opened.status();
    trace = *std::move(opened);
  }
  switch (config.kind) {
    case CanBusConfig::Kind::kSocketCan: {
      SocketCanChannel::Options options;
      options.interface = config.interface;
      options.trace = std::move(trace);
      auto ch = SocketCanChannel::Open(std::move(options));
      if (!ch.ok()) return ch.status();
      return std::unique_ptr<CanChannel>(*std::move(ch));
    }
    case CanBusConfig::Kind::kUdpMulticast: {
      UdpMulticastChannel::Options options;
      options.group = config.group;
      options.port = config.port;
      options.trace = std::move(trace);
      options.bitrate = config.bitrate;
      auto ch = UdpMulticastChannel::Open(std::move(options));
      if (!ch.ok()) return ch.status();
      return std::unique_ptr<CanChannel>(*std::move(ch));
    }
  }
  return absl::InternalError("OpenCanChannel: unknown CanBusConfig::Kind");
}

absl::StatusOr<CanBusConfig> ParseCanSpec(std::string_view spec) {
  CanBusConfig config;
  // "udp...@BITRATE" paces this node's frames (decision 805): udp:G:P@500000, udp@125000. A
  // SocketCAN interface has its bit rate set by `ip link`, so there '@' stays in the name.
  std::string_view body = spec;
  if (spec.substr(0, 3) == "udp") {
    if (const size_t at = spec.rfind('@'); at != std::string_view::npos) {
      const std::string_view rate = spec.substr(at + 1);
      unsigned value = 0;
      const auto [end, ec] = std::from_chars(rate.data(), rate.data() + rate.size(), value);
      if (rate.empty() || ec != std::errc() || end != rate.data() + rate.size() ||
          !IsSupportedCanBitrate(value)) {
        return SpecError(spec, absl::StrCat("bitrate '", std::string(rate.substr(0, 20)),
                                            "' is not one of 125000, 250000, 500000, 1000000"));
      }
      config.bitrate = value;
      body = spec.substr(0, at);
    }
  }
  const size_t colon = body.find(':');
  const std::string_view kind = body.substr(0, colon);
  const std::string_view rest =
      colon == std::string_view::npos ? std::string_view() : body.substr(colon + 1);
  if (kind == "socketcan") {
    config.kind = CanBusConfig::Kind::kSocketCan;
    if (rest.empty()) return SpecError(spec, "socketcan needs an interface: socketcan:IFACE");
    if (rest.size() > 15) return SpecError(spec, "interface name exceeds 15 characters (IFNAMSIZ)");
    if (rest.find_first_of(" \t:/") != std::string_view::npos) {
      return SpecError(spec, "interface name contains ' ', ':' or '/'");
    }
    config.interface = std::string(rest);
    return config;
  }
  if (kind == "udp") {
    config.kind = CanBusConfig::Kind::kUdpMulticast;
    if (colon == std::string_view::npos) return config;  // "udp": python-can's defaults
    const size_t colon2 = rest.find(':');
    const std::string_view group = rest.substr(0, colon2);
    if (!group.empty()) {
      in_addr addr{};
      const std::string g(group);
      if (::inet_pton(AF_INET, g.c_str(), &addr) != 1 || (ntohl(addr.s_addr) >> 28) != 0xE) {
        return SpecError(
            spec, absl::StrCat("group '", g, "' is not an IPv4 multicast address (224.0.0.0/4)"));
      }
      config.group = g;
    }
    if (colon2 != std::string_view::npos) {
      const std::string_view port = rest.substr(colon2 + 1);
      unsigned value = 0;
      const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
      if (port.empty() || ec != std::errc() || end != port.data() + port.size() || value == 0 ||
          value > 65535) {
        return SpecError(
            spec, absl::StrCat("port '", std::string(port.substr(0, 20)), "' is not 1..65535"));
      }
      config.port = static_cast<uint16_t>(value);
    }
    return config;
  }
  return SpecError(spec, "expected socketcan:IFACE or udp:GROUP:PORT[@BITRATE]");
}

std::string CanSpecString(const CanBusConfig& config) {
  if (config.kind == CanBusConfig::Kind::kSocketCan)
    return absl::StrCat("socketcan:", config.interface);
  if (config.bitrate != 0) {
    return absl::StrCat("udp:", config.group, ":", config.port, "@", config.bitrate);
  }
  return absl::StrCat("udp:", config.group, ":", config.port);
}

}  // namespace drivegw::transport
