// Options of the simulated SIXpack/QUADpack server: the controller model, the pty endpoint,
// the packet timeout before `$41` is sent and the fault injection (trinamic-sixpack.md §7).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

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
  // Further PACKs on the same simulated RS-485 line (CT-06): every unit frames the host's bytes
  // itself and acts only on words with its own address (L273, L275; decision 1039).
  std::vector<ControllerOptions> more_units;
  std::string pty_path;  // symlink to the pty slave (`--pty PATH`); empty = none
  // Packet abort timeout until `$41` sets one; the default is not stated (G-04, decision 1037).
  Duration default_packet_timeout = std::chrono::milliseconds(100);
  // Hold every reply until the unit's `$40` switchover time has passed on the injected clock
  // after the query was received (L283, L833; decision 1040). Off: replies are written at once.
  bool turnaround = false;
  // Treat bytes as line noise while the peer's termios speed on the shared pty differs from the
  // unit's `$40` baud rate (L273, L832, §2.7; decision 1045).
  bool check_peer_baud = false;
  Faults faults;
  // Host words (words()) and wire events (wire()) kept for tests and tools, oldest dropped first.
  // Each is a small heap vector: at the poll rate of a live gateway (≈ 200 words/s) the default
  // fills ≈ 15 MB in ≈ 8 min; the gateway's embedded demo keeps none (decision 1442).
  size_t trace_limit = 100000;
};

// InvalidArgument naming the field (axes, address, amax divisor, packet timeout, more_units).
absl::Status ValidateOptions(const ServerOptions& options);

// True when `peer_baud` is within 3 % of the rate of `$40` divisor `divisor` (1 250 000 / divisor,
// §2.1): a UART still samples such bytes correctly.
bool BaudMatches(int peer_baud, uint16_t divisor);

}  // namespace drivegw::sim::trinamic
