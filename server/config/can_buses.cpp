// One protocol per CAN bus (decision 407).
#include "server/config/can_buses.h"

#include <cstdint>
#include <string>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "adapters/stober/factory.h"
#include "adapters/trinamic/factory.h"
#include "server/config/can_config.h"

namespace drivegw::config::internal {
namespace {

// The protocol a family speaks on its bus; empty for families without one.
std::string_view ProtocolOf(std::string_view family) {
  if (family == "linmot-devicenet") return "DeviceNet";
  if (family == stober::kFamilyName) return "CANopen";
  if (family == trinamic::kFamilyName) return "the Trinamic CAN protocol";
  return {};
}

std::string RateText(uint32_t bitrate) {
  return bitrate == 0 ? std::string("no bitrate (unpaced)") : absl::StrCat(bitrate, " bit/s");
}

}  // namespace

void CanBusProtocols::Add(size_t index, const std::string& family, const std::string& path,
                          const CanBusConfig& bus, const YAML::Node& at) {
  const std::string_view protocol = ProtocolOf(family);
  if (protocol.empty()) return;
  const std::string key = BusKey(bus);
  auto [it, fresh] = buses_.emplace(key, First{index, family, bus.bitrate});
  if (fresh) return;
  const std::string_view theirs = ProtocolOf(it->second.family);
  if (theirs == protocol) {
    // Every node of a bus runs at one bit rate (decision 805): two rates on one user-space bus
    // would pace the same frames differently, which no real bus can do.
    if (bus.bitrate != it->second.bitrate) {
      errors_.Add(absl::StrCat(path, ".udp.bitrate"),
                  absl::StrCat(RateText(bus.bitrate), " differs from ",
                               RateText(it->second.bitrate), " of drives[", it->second.index,
                               "] on ", key, "; a bus has one bit rate (decision 805)"),
                  at);
    }
    return;
  }
  // DeviceNet groups 1-3 fill 000h-7BFh (linmot-devicenet.md §5.1), the CANopen predefined
  // connection set 000h-77Fh (CiA 301 §7.3.3), Trinamic IDs are address << 3 (trinamic-sixpack.md
  // §3.1, L289): frames of one would be taken for frames of the other.
  errors_.Add(path,
              absl::StrCat(key, " carries ", Av(theirs), " of drives[", it->second.index, "] (",
                           it->second.family, "); ", Av(protocol), " (", family,
                           ") cannot share a bus with it, their 11-bit CAN identifiers overlap "
                           "(decision 407)"),
              at);
}

}  // namespace drivegw::config::internal
