// Command line of `drivegw-sim linmot-devicenet`: flags -> DnSimOptions, with errors that name
// the flag (the caller prints them and exits 2).
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "sim/linmot_devicenet/options.h"

namespace drivegw::sim::linmot_devicenet {

struct CliFlags {
  DnSimOptions sim;
  int count = 1;              // drives on MAC IDs mac, mac+1, ...
  double status_every_s = 0;  // print each drive's state this often; 0 = never
  bool help = false;
};

// `args` are the words after the family ("--can", "udp:239.74.163.2:43113", "--mac", "5", ...;
// "--flag=value" works too). InvalidArgument "--mac: '64' is not an integer in [0, 63]",
// "--count: 4 drives from MAC 62 exceed 63", "unknown flag '--x'"; option validation errors are
// reported with the flag that sets the field ("--stroke-max: ...").
absl::StatusOr<CliFlags> ParseCliFlags(const std::vector<std::string>& args);

// The options of drive i (0-based) of `flags.count`: MAC + i, name NAME-(i+1) when count > 1.
DnSimOptions DriveOptions(const CliFlags& flags, int i);

extern const char kCliUsage[];

}  // namespace drivegw::sim::linmot_devicenet
