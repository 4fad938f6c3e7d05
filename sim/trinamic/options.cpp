// Validation of the simulated SIXpack server's options (trinamic-sixpack.md §2.5, §7).
#include "sim/trinamic/options.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::trinamic {

absl::Status ValidateOptions(const ServerOptions& options) {
  if (auto c = Controller::Create(options.controller); !c.ok()) return c.status();
  // `$41` allows 2..65535 × 2 ms (L838); the default must lie in that range too.
  if (options.default_packet_timeout < std::chrono::milliseconds(4) ||
      options.default_packet_timeout > std::chrono::milliseconds(131070)) {
    return absl::InvalidArgumentError(
        "options.default_packet_timeout: must be 4 ms .. 131.07 s (L838)");
  }
  if (options.faults.reset_after && *options.faults.reset_after < Duration::zero()) {
    return absl::InvalidArgumentError("options.faults.reset_after: must not be negative");
  }
  std::vector<uint8_t> addresses = {options.controller.address};
  for (const ControllerOptions& unit : options.more_units) {
    if (auto c = Controller::Create(unit); !c.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.more_units: ", std::string(c.status().message())));
    }
    if (std::find(addresses.begin(), addresses.end(), unit.address) != addresses.end()) {
      return absl::InvalidArgumentError(absl::StrCat("options.more_units: address ", unit.address,
                                                     " is used twice on one line (L273)"));
    }
    addresses.push_back(unit.address);
  }
  return absl::OkStatus();
}

bool BaudMatches(int peer_baud, uint16_t divisor) {
  if (peer_baud <= 0 || divisor == 0) return false;
  const double rate = 1'250'000.0 / divisor;  // §2.1, L832
  return std::abs(peer_baud - rate) <= 0.03 * rate;
}

}  // namespace drivegw::sim::trinamic
