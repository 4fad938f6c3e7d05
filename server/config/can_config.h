// The `can:` mapping shared by every CAN family (drives[i].can for linmot-devicenet,
// drives[i].trinamic.can for trinamic): docs/config.md "can", decision 801. Internal to
// server/config.
#pragma once

#include <string>

#include "adapters/core/drive_config.h"
#include "server/config/section.h"

namespace drivegw::config::internal {

// Reads `can` of `parent` (which must have it): {socketcan: {interface}} |
// {udp: {group, port, bitrate}}, optional trace. Errors are named `<parent>.can.<key>`.
void ParseCan(const Section& parent, CanBusConfig& out);

// "socketcan:can0" / "udp:239.74.163.2:43113": which drives share a bus.
std::string BusKey(const CanBusConfig& can);

}  // namespace drivegw::config::internal
