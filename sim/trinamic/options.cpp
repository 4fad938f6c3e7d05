// Validation of the simulated SIXpack server's options (trinamic-sixpack.md §2.5, §7).
#include "sim/trinamic/options.h"

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
  return absl::OkStatus();
}

}  // namespace drivegw::sim::trinamic
