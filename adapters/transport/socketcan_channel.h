// SocketCAN back end: a raw CAN_RAW socket on a Linux CAN interface, with kernel filters,
// error frames, bus-off detection and recovery with exponential back-off (docs/decisions/804).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/can_frame.h"
#include "adapters/transport/candump_trace.h"

namespace drivegw::transport {

// The bus state after an error frame (linux/can/error.h classes in frame.id, details in
// data[1]): CAN_ERR_BUSOFF -> kBusOff, CAN_ERR_RESTARTED -> kActive, CAN_ERR_CRTL passive /
// warning / active -> kPassive / kWarning / kActive; any other error frame keeps `current`.
// Pure, so it is tested without a CAN kernel.
CanBusState NextCanBusState(CanBusState current, const CanFrame& error_frame);

// Exponential back-off between recovery attempts: initial, 2x, 4x, ... up to max; Reset()
// after a success. Never zero, so a dead bus never becomes a busy loop.
class CanBackoff {
 public:
  CanBackoff(std::chrono::milliseconds initial, std::chrono::milliseconds max)
      : initial_(std::max(initial, std::chrono::milliseconds(1))),
        max_(std::max(max, initial_)),
        next_(initial_) {}
  // The delay before the next attempt; doubles the one after.
  std::chrono::milliseconds Next() {
    const auto d = next_;
    next_ = std::min(next_ * 2, max_);
    return d;
  }
  void Reset() { next_ = initial_; }

 private:
  std::chrono::milliseconds initial_, max_, next_;
};

class SocketCanChannel final : public CanChannel {
 public:
  struct Options {
    std::string interface = "can0";
    std::shared_ptr<CandumpTrace> trace;          // null: no trace
    std::chrono::milliseconds min_backoff{100};   // first recovery attempt after bus-off/down
    std::chrono::milliseconds max_backoff{5000};  // back-off ceiling
  };

  // socket(PF_CAN, SOCK_RAW, CAN_RAW), error filter, bind to the interface. Errors name the
  // interface and the errno: "can.socketcan.interface 'can0': this kernel has no SocketCAN
  // (EAFNOSUPPORT)", "... 'can9': no such interface (ENODEV)" (Unavailable); InvalidArgument
  // for a name longer than IFNAMSIZ-1. An interface that is down opens in state kDown.
  static absl::StatusOr<std::unique_ptr<SocketCanChannel>> Open(Options options);

  ~SocketCanChannel() override;
  SocketCanChannel(const SocketCanChannel&) = delete;
  SocketCanChannel& operator=(const SocketCanChannel&) = delete;

  // Unavailable at once (no socket call) while bus-off or down: recovery runs in Receive.
  absl::Status Send(const CanFrame& frame) override;
  // Also drives recovery: while bus-off or down, the wait is cut at the next back-off
  // deadline, where the socket is reopened (new ifindex after a re-plug) and the interface
  // flags decide the state (IFF_UP and IFF_RUNNING: the controller carries again).
  absl::StatusOr<std::optional<CanFrame>> Receive(std::chrono::nanoseconds timeout) override;
  void Wake() override;
  absl::Status SetFilters(std::span<const CanFilter> filters) override;
  CanBusState state() const override { return state_.load(std::memory_order_acquire); }
  CanCounters counters() const override;
  std::string name() const override { return options_.interface; }

 private:
  explicit SocketCanChannel(Options options)
      : options_(std::move(options)), backoff_(options_.min_backoff, options_.max_backoff) {}

  // A configured, bound socket (filters applied) or the error naming the interface.
  absl::StatusOr<int> OpenSocket() const;
  absl::Status ApplyFilters(int fd, const std::vector<CanFilter>& filters) const;
  // Interface flags via SIOCGIFFLAGS: nullopt when the interface does not exist.
  std::optional<unsigned> InterfaceFlags() const;
  void EnterFault(CanBusState state, std::string_view why);
  void TryRecover();
  void OnErrorFrame(const CanFrame& frame);

  const Options options_;
  std::shared_mutex fd_mu_;  // exclusive only to swap fd_ during recovery
  int fd_ = -1;
  int wake_fd_ = -1;
  std::atomic<CanBusState> state_{CanBusState::kActive};

  std::mutex recovery_mu_;  // guards backoff_ and next_recovery_
  CanBackoff backoff_;
  std::chrono::steady_clock::time_point next_recovery_{};

  mutable std::mutex filters_mu_;
  std::vector<CanFilter> filters_;  // empty: accept all; re-applied after a reopen

  std::atomic<uint64_t> tx_{0}, rx_{0}, tx_errors_{0}, rx_errors_{0}, error_frames_{0},
      bus_off_events_{0}, dropped_malformed_{0};
};

}  // namespace drivegw::transport
