// drives[i].trinamic: one axis of a Trinamic SIXpack/QUADpack (docs/config.md "trinamic",
// trinamic-sixpack.md, decision 405). Internal to server/config.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "adapters/core/drive_config.h"
#include "server/config/section.h"

namespace drivegw::config::internal {

// Reads `trinamic` of `drive` (which must have it) into `out`. `axis` are the drive's already
// parsed travel limits (the position range must fit the PACK's int32 microsteps, §5.2 L60).
// Returns false when the section had errors.
bool ParseTrinamic(const Section& drive, const AxisConfig& axis, TrinamicConfig& out);

// Rules between the Trinamic drives of one file. Axes with the same transport and address are
// motors of one controller behind one serialised session (decision 1052), so they must not
// repeat a motor and must agree on what the session and the controller hold once.
class TrinamicControllers {
 public:
  explicit TrinamicControllers(Errors& errors) : errors_(errors) {}

  // `path` = "drives[i].trinamic", `at` = that node (for line numbers).
  void Add(size_t index, const std::string& path, const TrinamicConfig& config,
           const YAML::Node& at);
  // Rules that need every drive: the response address is no controller's address (CT-50).
  void Finish();

 private:
  struct Entry {
    size_t index = 0;
    std::string path;
    TrinamicConfig config;
    YAML::Node node;
  };
  const Entry* Controller(const std::string& transport, uint8_t address) const;

  Errors& errors_;
  std::vector<Entry> entries_;
  std::map<std::tuple<std::string, uint8_t, uint8_t>, size_t> axes_;  // -> entries_ index
  std::map<std::string, size_t> lines_;  // serial device -> first entry on it
};

// "serial:/dev/ttyUSB0" or the CAN bus key ("udp:239.74.163.2:43113"): which axes share a line.
std::string TrinamicTransportKey(const TrinamicConfig& config);

}  // namespace drivegw::config::internal
