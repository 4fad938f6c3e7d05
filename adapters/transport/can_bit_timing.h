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

// An absolute CLOCK_MONOTONIC timer on a timerfd: hrtimers armed through timerfd get no timer
// slack, whereas nanosleep/poll time-outs of an ordinary thread are rounded up by its 50 us
// default slack (man 2 prctl, PR_SET_TIMERSLACK). libstdc++'s steady_clock is CLOCK_MONOTONIC.
class MonotonicTimer {
 public:
  using SteadyTime = std::chrono::steady_clock;

  // Internal when the kernel has no timerfd.
  static absl::StatusOr<MonotonicTimer> Create();
  MonotonicTimer(MonotonicTimer&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  MonotonicTimer& operator=(MonotonicTimer&& other) noexcept;
  ~MonotonicTimer();

  // Readable (POLLIN) from `t` on; a past `t` fires at once. Disarm() stops it and drains it.
  void Arm(SteadyTime::time_point t);
  void Disarm();
  // Blocks until `t` (returns at once when it has passed).
  void SleepUntil(SteadyTime::time_point t);
  int fd() const { return fd_; }

 private:
  explicit MonotonicTimer(int fd) : fd_(fd) {}
  int fd_ = -1;
};

// One node's transmitter at a fixed bit rate. A frame handed over while the node is still
// sending the previous one starts when that one ends; it is on the wire for CanFrameBits(frame)
// bit times and reaches the other nodes at its end. The schedule is a monotonic next-free time,
// so waking late never shifts later frames (no drift). Not thread-safe: the owner serialises
// calls (its transmit queue order).
class CanTxPacer {
 public:
  using SteadyTime = std::chrono::steady_clock;
  struct Slot {
    SteadyTime::time_point start;  // the frame's first bit (SOF)
    SteadyTime::time_point end;    // after its last bit and the intermission
  };

  // InvalidArgument for a bit rate outside kCanBitrates; Internal when no timerfd.
  static absl::StatusOr<std::unique_ptr<CanTxPacer>> Create(uint32_t bitrate);

  // Schedules `frame`, handed over at `queued` (the caller's clock reading before it waited for
  // its turn), after this node's previous frame and blocks until it starts: a controller holds
  // one frame in transmission, so the node can never run ahead of the wire by more than one.
  Slot Transmit(const CanFrame& frame, SteadyTime::time_point queued);

  // The longest time a frame can take at this bit rate (160 bits: extended, 8 bytes, worst-case
  // stuffing): how long a receiver may hold a frame announced for the future.
  SteadyTime::duration longest_frame() const { return longest_frame_; }
  uint32_t bitrate() const { return bitrate_; }

 private:
  CanTxPacer(uint32_t bitrate, MonotonicTimer timer);

  uint32_t bitrate_;
  MonotonicTimer timer_;
  SteadyTime::duration longest_frame_;
  SteadyTime::time_point free_at_{};  // when this node's last frame ends
};

}  // namespace drivegw::transport
