// Bit timing of classic CAN frames on the wire, and the pacer that makes the user-space bus
// take as long per frame as a real bus at its bit rate (docs/decisions/805-udp-bus-bit-timing.md).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::transport {

// The bit rates the user-space bus can be paced at (bit/s): DeviceNet's three (125k, 250k,
// 500k) and CANopen's 1 Mbit/s, the rates the Trinamic jumpers select (decision 1099, §3.2).
inline constexpr uint32_t kCanBitrates[] = {125000, 250000, 500000, 1000000};
bool IsSupportedCanBitrate(uint32_t bitrate);

// Bits `frame` occupies on the bus, exactly: SOF, arbitration, control, data and CRC-15 with the
// stuff bits this frame's content needs (ISO 11898-1 §10.5, CAN 2.0 A/B §3.1 and §5), then CRC
// delimiter, ACK slot, ACK delimiter, 7 bits EOF and the 3 bits of intermission before the next
// frame may start. 47..135 bits for a base frame, 67..160 for an extended one.
uint32_t CanFrameBits(const CanFrame& frame);

// The same frame length without stuff bits (the fewest possible) and with the most stuff bits
// any content can need (Davis et al. 2007, eq. 1: g + 8s + 13 + floor((g + 8s - 1) / 4), g = 34
// base, 54 extended).
uint32_t CanNominalFrameBits(uint8_t dlc, bool extended, bool rtr = false);
uint32_t CanWorstCaseFrameBits(uint8_t dlc, bool extended, bool rtr = false);

// Time `bits` take at `bitrate` bit/s (rounded to the nanosecond).
std::chrono::nanoseconds CanBitTime(uint32_t bits, uint32_t bitrate);

// One node's transmitter at a fixed bit rate: a frame handed over while the node is still
// sending the previous one starts when that one ends; a frame is on the wire for
// CanFrameBits(frame) bit times and reaches the other nodes at its end. The schedule is a
// monotonic next-free time, so waking late never shifts later frames (no drift); waits use an
// absolute CLOCK_MONOTONIC timerfd, which has no timer slack. Not thread-safe: the owner
// serialises calls (its transmit queue order).
class CanTxPacer {
 public:
  using SteadyTime = std::chrono::steady_clock;

  // InvalidArgument for a bit rate outside kCanBitrates; Internal when no timerfd.
  static absl::StatusOr<std::unique_ptr<CanTxPacer>> Create(uint32_t bitrate);
  ~CanTxPacer();
  CanTxPacer(const CanTxPacer&) = delete;
  CanTxPacer& operator=(const CanTxPacer&) = delete;

  // Blocks until the end of `frame` on the wire when it was handed over at `queued` (the
  // caller's clock reading before it waited for its turn); returns that end time.
  SteadyTime::time_point WaitEndOfFrame(const CanFrame& frame, SteadyTime::time_point queued);

  uint32_t bitrate() const { return bitrate_; }

 private:
  CanTxPacer(uint32_t bitrate, int timer_fd) : bitrate_(bitrate), timer_fd_(timer_fd) {}
  void SleepUntil(SteadyTime::time_point t);

  uint32_t bitrate_;
  int timer_fd_;
  SteadyTime::time_point free_at_{};  // when this node's last frame ends
};

}  // namespace drivegw::transport
