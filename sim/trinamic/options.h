// Options of the simulated SIXpack/QUADpack server: the controller model, the pty endpoint,
// the packet timeout before `$41` is sent and the fault injection (trinamic-sixpack.md §7).
#pragma once

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "adapters/core/clock.h"
#include "sim/trinamic/controller.h"

namespace drivegw::sim::trinamic {

struct Faults {
  bool silent = false;                  // reads and executes words, never answers
  std::optional<Duration> reset_after;  // power loss this long after Start (L224, L228)
};

struct ServerOptions {
  ControllerOptions controller;
  std::string pty_path;  // symlink to the pty slave (`--pty PATH`); empty = none
  // Packet abort timeout until `$41` sets one; the default is not stated (G-04, decision 1037).
  Duration default_packet_timeout = std::chrono::milliseconds(100);
  Faults faults;
};

// InvalidArgument naming the field (axes, address, amax divisor, packet timeout).
absl::Status ValidateOptions(const ServerOptions& options);

}  // namespace drivegw::sim::trinamic
