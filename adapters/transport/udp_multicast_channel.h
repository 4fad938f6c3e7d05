// A CAN bus over IPv4 UDP multicast that python-can's udp_multicast interface shares: one
// msgpack-packed can.Message dict per datagram (docs/decisions/802-udp-multicast-can-bus.md).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/can_bit_timing.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/can_frame.h"
#include "adapters/transport/candump_trace.h"

namespace drivegw::transport {

// python-can 4.1 can/interfaces/udp_multicast/utils.py pack_message: a map of the 11 keys
// timestamp (float64, seconds), arbitration_id, is_extended_id, is_remote_frame,
// is_error_frame, channel (nil), dlc, data (bin; empty for RTR), is_fd, bitrate_switch,
// error_state_indicator, in that order, shortest msgpack encodings (= msgpack-python's bytes).
std::vector<uint8_t> EncodePythonCanMessage(const CanFrame& frame, double timestamp_s);

// Accepts exactly what python-can's unpack_message(check=True) accepts for classic CAN: a
// map whose keys are can.Message arguments (missing ones take can.Message's defaults, note
// is_extended_id=True), dlc == len(data) unless RTR, ids within 11/29 bits, no trailing bytes.
// InvalidArgument naming the key otherwise; Unimplemented for CAN FD frames (is_fd true).
// `timestamp_s`, when given, receives the message's timestamp (0 when absent).
absl::StatusOr<CanFrame> DecodePythonCanMessage(std::span<const uint8_t> datagram,
                                                double* timestamp_s = nullptr);

class UdpMulticastChannel final : public CanChannel {
 public:
  struct Options {
    std::string group = "239.74.163.2";   // python-can UdpMulticastBus.DEFAULT_GROUP_IPv4
    uint16_t port = 43113;                // python-can's default port
    std::shared_ptr<CandumpTrace> trace;  // null: no trace
    // Bit rate this node paces its own frames at (kCanBitrates); 0 = unpaced
    // (docs/decisions/805-udp-bus-bit-timing.md).
    uint32_t bitrate = 0;
  };

  // Joins the group (TTL 1, loop on) and opens a sender socket. InvalidArgument for a group
  // outside 224.0.0.0/4 or port 0; Unavailable with what to do when the host has no multicast
  // route ("... add one: ip route add 224.0.0.0/4 dev lo").
  static absl::StatusOr<std::unique_ptr<UdpMulticastChannel>> Open(Options options);

  ~UdpMulticastChannel() override;
  UdpMulticastChannel(const UdpMulticastChannel&) = delete;
  UdpMulticastChannel& operator=(const UdpMulticastChannel&) = delete;

  // Waits up to 100 ms for room when the socket's send buffer is full (a burst), then
  // Unavailable; the wait never spins (poll for POLLOUT). With a bit rate, first waits until the
  // node's previous frame has ended (senders of one channel queue in call order); the datagram
  // then carries the end of this frame on the wire as its timestamp (decision 805).
  absl::Status Send(const CanFrame& frame) override;
  // With a bit rate, a frame is returned no earlier than the end its sender's timestamp
  // announces (at most one longest frame after it arrived), in end-of-frame order.
  absl::StatusOr<std::optional<CanFrame>> Receive(std::chrono::nanoseconds timeout) override;
  void Wake() override;
  absl::Status SetFilters(std::span<const CanFilter> filters) override;
  CanBusState state() const override { return state_.load(std::memory_order_acquire); }
  CanCounters counters() const override;
  std::string name() const override { return name_; }

  // The local UDP port frames leave from; datagrams from it are this channel's own (not
  // returned by Receive, as a CAN controller does not receive its own frames).
  uint16_t sender_port() const { return sender_port_; }
  uint32_t bitrate() const { return pacer_ ? pacer_->bitrate() : 0; }

 private:
  UdpMulticastChannel() = default;
  bool Accepts(const CanFrame& frame) const;
  absl::Status SendDatagram(const CanFrame& frame, double timestamp_s);
  struct HeldFrame {
    std::chrono::steady_clock::time_point at;  // the frame's end on the wire: hand over then
    CanFrame frame;
  };
  std::optional<CanFrame> PopDueLocked(std::chrono::steady_clock::time_point now);
  void HoldLocked(const CanFrame& frame, double timestamp_s);

  std::string name_;
  int rx_fd_ = -1;            // bound to GROUP:PORT, member of GROUP
  int tx_fd_ = -1;            // ephemeral port, connected to GROUP:PORT
  int wake_fd_ = -1;          // eventfd: readable while a wake-up is pending
  uint32_t sender_ipv4_ = 0;  // host order; getsockname of tx_fd_ after connect
  uint16_t sender_port_ = 0;
  std::shared_ptr<CandumpTrace> trace_;
  std::atomic<CanBusState> state_{CanBusState::kActive};

  std::mutex pace_mu_;                      // the transmit queue of a paced channel
  std::unique_ptr<CanTxPacer> pacer_;       // null: unpaced
  std::optional<MonotonicTimer> rx_timer_;  // paced: wakes Receive at a held frame's end
  std::mutex held_mu_;
  std::deque<HeldFrame> held_;  // paced: received frames not yet at their end, in end order

  mutable std::mutex filters_mu_;
  std::vector<CanFilter> filters_;  // empty: accept all

  std::atomic<uint64_t> tx_{0}, rx_{0}, tx_errors_{0}, rx_errors_{0}, error_frames_{0},
      dropped_malformed_{0};
};

}  // namespace drivegw::transport
