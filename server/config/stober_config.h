// drives[i].node_id and drives[i].canopen: a STOBER axis as a CANopen node (docs/config.md
// "stober", stober-motion.md §7, decision 408). Internal to server/config.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <utility>

#include "adapters/core/drive_config.h"
#include "server/config/section.h"

namespace drivegw::config::internal {

// Reads `node_id` and `canopen` of `s` into `drive` (family, can and axis already parsed).
// Family stober: node_id 1..127 required, canopen optional, linudp/mac_id refused, and the
// travel and dynamics limits must fit the fixed-point wire types (decision 1172). Any other
// family: node_id and canopen are refused (a key that would be ignored is an error).
void ParseCanOpenDrive(const Section& s, DriveConfig& drive);

// Rules between the CANopen drives of one file: one drive per (bus, node ID), and one SYNC
// period per bus, since the drives of a bus share one master with one SYNC producer
// (decision 1116).
class CanOpenNodes {
 public:
  explicit CanOpenNodes(Errors& errors) : errors_(errors) {}

  // `s` is drives[index]; `drive` its parsed configuration (ignored unless it has can + node_id).
  void Add(size_t index, const Section& s, const DriveConfig& drive);

 private:
  void CheckMasterNode(size_t index, const Section& s, const DriveConfig& drive,
                       const std::string& bus);

  Errors& errors_;
  std::map<std::pair<std::string, uint8_t>, size_t> nodes_;    // (bus, node ID) -> drive index
  std::map<std::string, std::pair<size_t, int64_t>> sync_;     // bus -> (first drive, period ms)
  std::map<std::string, std::pair<size_t, uint8_t>> masters_;  // bus -> (first drive, master ID)
};

}  // namespace drivegw::config::internal
