// CanChannel: one classic CAN bus as the DeviceNet/Trinamic/CANopen sessions see it, chosen
// per drive from CanBusConfig (SocketCAN or the python-can compatible UDP multicast bus).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive_config.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::transport {

// An acceptance filter like CAN_RAW's struct can_filter: a frame passes when it has this
// frame format (base/extended) and (frame.id & mask) == (id & mask). mask 0 passes every id
// of that format. Error frames are never filtered (docs/decisions/801-can-channel.md).
struct CanFilter {
  uint32_t id = 0;
  uint32_t mask = 0;
  bool extended = false;

  bool Matches(const CanFrame& frame) const {
    return frame.extended == extended && (frame.id & mask) == (id & mask);
  }
};

// CAN_RAW_FILTER_MAX (linux/can/raw.h).
inline constexpr size_t kMaxCanFilters = 512;

// OK when there are at most kMaxCanFilters and each id/mask fits its format; InvalidArgument
// "can filters[2].mask: 0xFFFF exceeds 0x7FF (11-bit base format)" otherwise.
absl::Status ValidateCanFilters(std::span<const CanFilter> filters);

// Fault confinement state (ISO 11898-1 §12): error counters below 96 active, from 96 warning,
// from 128 passive, above 255 bus-off. kDown: the interface is down, gone or not open.
enum class CanBusState { kActive, kWarning, kPassive, kBusOff, kDown };
// "active", "warning", "passive", "bus-off", "down" (a C string: Debian's absl::StrCat takes no
// std::string_view).
const char* CanBusStateName(CanBusState state);

struct CanCounters {
  uint64_t tx = 0;                 // frames handed to the bus
  uint64_t rx = 0;                 // frames returned by Receive
  uint64_t tx_errors = 0;          // Send failures (bus-off, down, full buffer)
  uint64_t rx_errors = 0;          // socket errors while receiving
  uint64_t error_frames = 0;       // error frames seen (consumed, not returned)
  uint64_t bus_off_events = 0;     // transitions into bus-off
  uint64_t dropped_malformed = 0;  // undecodable frames/datagrams from the bus, dropped
};

// Send, Receive, Wake, SetFilters, state, counters and name may be called from different
// threads at the same time (typically one I/O thread receives while others send). Destroying
// may not overlap any other call.
class CanChannel {
 public:
  virtual ~CanChannel() = default;

  // Queues one frame. InvalidArgument for a frame ValidateCanFrame refuses; Unavailable
  // (counted in tx_errors) when the bus is off or down or the transmit queue is full.
  virtual absl::Status Send(const CanFrame& frame) = 0;

  // Waits up to `timeout` (<= 0: just checks) for one frame that passes the filters. nullopt
  // on time-out or after Wake(). Error frames update state() and counters, are traced, and
  // are not returned. Errors only for a broken channel (Internal/Unavailable).
  virtual absl::StatusOr<std::optional<CanFrame>> Receive(std::chrono::nanoseconds timeout) = 0;

  // Makes one blocked (or the next) Receive return nullopt at once.
  virtual void Wake() = 0;

  // Replaces the acceptance filters; an empty span accepts every frame again (the state after
  // opening). InvalidArgument for more than kMaxCanFilters or an id/mask beyond the format.
  virtual absl::Status SetFilters(std::span<const CanFilter> filters) = 0;

  virtual CanBusState state() const = 0;
  virtual CanCounters counters() const = 0;

  // "can0", "udp:239.74.163.2:43113": for logs and the candump trace's interface column.
  virtual std::string name() const = 0;
};

// Opens the back end `config` selects; with a non-empty trace_file the channel is wrapped so
// every frame in and out is appended to that file in candump -l format (candump_trace.h).
absl::StatusOr<std::unique_ptr<CanChannel>> OpenCanChannel(const CanBusConfig& config);

// Simulator command lines: "socketcan:IFACE" or "udp:GROUP:PORT" ("udp" and "udp:GROUP" take
// the default group/port). InvalidArgument "--can 'x': ..." naming what is wrong.
absl::StatusOr<CanBusConfig> ParseCanSpec(std::string_view spec);

// "socketcan:can0" / "udp:239.74.163.2:43113": the inverse of ParseCanSpec.
std::string CanSpecString(const CanBusConfig& config);

}  // namespace drivegw::transport
