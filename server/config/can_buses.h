// One protocol per CAN bus: DeviceNet, CANopen and the Trinamic CAN protocol all use 11-bit
// identifiers in overlapping ranges, so drives of different protocols never share a bus
// (decision 407). Internal to server/config.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "adapters/core/drive_config.h"
#include "server/config/section.h"

namespace drivegw::config::internal {

class CanBusProtocols {
 public:
  explicit CanBusProtocols(Errors& errors) : errors_(errors) {}

  // drives[index] of `family` uses `bus`; `path` names its can key ("drives[1].can",
  // "drives[1].trinamic.can") and `at` is that node (line numbers). The first drive on a bus
  // sets its protocol; a drive of another protocol is an error naming both. Families that are
  // not CAN protocols (linmot) are ignored. Drives of one bus must agree on its bit rate
  // (decision 805).
  void Add(size_t index, const std::string& family, const std::string& path,
           const CanBusConfig& bus, const YAML::Node& at);

 private:
  struct First {
    size_t index = 0;
    std::string family;
    uint32_t bitrate = 0;  // CanBusConfig::bitrate of the first drive (0 = unpaced)
  };
  Errors& errors_;
  std::map<std::string, First> buses_;  // BusKey -> first drive on it
};

}  // namespace drivegw::config::internal
