// TrinamicCanServer: one simulated SIXpack/QUADpack on a CAN channel (UDP multicast bus or
// SocketCAN): command frames ID = A << 3, replies to ID = RA << 3, 8-byte frames (§3,
// L289-291), the 16-command queue (L303) and optionally the PACK's RS-232 port on a pty: serial
// control until the first CAN instruction, then the transparent tunnel (L291, L307-317). The
// controller is advanced to an injected clock on every loop (never by sleeping).
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/pty.h"
#include "sim/trinamic/controller.h"
#include "sim/trinamic/options.h"
#include "sim/trinamic/word_assembler.h"

namespace drivegw::sim::trinamic {

struct CanServerOptions {
  // `framing` is ignored: CAN replies are always the 8-byte body under ID RA << 3.
  ControllerOptions controller;
  CanBusConfig can;  // the bus to open unless a channel is injected
  Faults faults;     // silent controller, power loss at a chosen time
  // Time the PACK needs per received command (~2 ms, L303): commands wait in a queue of at most
  // kCanQueueSize and execute one per `command_time` of the injected clock; a command arriving
  // at a full queue is dropped (G-27, decision 1041). Zero: executed on arrival.
  Duration command_time = Duration::zero();
  // The PACK's RS-232 port as a pty (CT-51, CT-53, CT-54; decision 1042): serial command words
  // (replies in `serial_framing`) until the first valid CAN instruction; from then on bytes
  // from frames ID (A << 3) + 1 are written to it and bytes read from it are forwarded as
  // configured by `$44`, flushed on the `$41` timeout (L291, L307-317).
  bool serial_endpoint = false;
  std::string serial_pty_path;  // symlink to the slave; empty = none
  ReplyFraming serial_framing = ReplyFraming::kR8;
  Duration default_packet_timeout = std::chrono::milliseconds(100);  // until `$41` (G-04)
};

inline constexpr size_t kCanQueueSize = 16;  // L303

struct CanServerCounters {
  uint64_t frames_in = 0;         // frames returned by the channel
  uint64_t commands = 0;          // frames decoded and handed to the controller
  uint64_t malformed = 0;         // frames the codec refused (DLC, RTR, extended, opcode): dropped
  uint64_t foreign = 0;           // frames for another identifier that passed the filter
  uint64_t replies = 0;           // reply frames sent
  uint64_t send_errors = 0;       // replies the channel refused
  uint64_t receive_errors = 0;    // channel errors while receiving
  uint64_t resets = 0;            // injected power losses
  uint64_t queue_overflows = 0;   // commands dropped at a full 16-entry queue (G-27)
  uint64_t serial_bytes_in = 0;   // bytes read from the serial endpoint
  uint64_t serial_words = 0;      // serial command words executed (before the CAN takeover)
  uint64_t tunnel_frames = 0;     // RS-232 -> CAN tunnel frames sent (L317)
  uint64_t tunnel_bytes_out = 0;  // CAN -> RS-232 bytes written to the serial endpoint (L315)
  uint64_t tunnel_dropped = 0;    // tunnel bytes dropped (forwarding disabled, not in CAN mode)
};

// Thread model: one thread owns the Receive loop; public methods are thread-safe and serialised
// with it by one mutex. The thread re-reads the clock at least every 5 ms of real time, so a
// ManualClock::Advance (delayed `$28` replies, reset-at-time) takes effect without sleeping.
class TrinamicCanServer {
 public:
  // Validates the options, opens options.can unless `channel` is injected, installs the
  // acceptance filter for ID A << 3 and starts the thread. `clock` must outlive the server.
  static absl::StatusOr<std::unique_ptr<TrinamicCanServer>> Start(
      const CanServerOptions& options, const Clock& clock,
      std::unique_ptr<transport::CanChannel> channel = nullptr);
  ~TrinamicCanServer();  // Stop()
  TrinamicCanServer(const TrinamicCanServer&) = delete;
  TrinamicCanServer& operator=(const TrinamicCanServer&) = delete;

  void Stop();  // prompt (wakes the Receive) and idempotent
  std::string bus_name() const { return channel_->name(); }
  uint16_t command_id() const { return command_id_; }
  CanServerCounters counters() const;
  // The serial endpoint's slave path; empty without `serial_endpoint`.
  std::string serial_path() const { return pty_ ? pty_->slave_path() : std::string(); }
  // True once a valid CAN instruction has taken over from serial control (L291).
  bool can_mode() const;

  // ---- fault injection and introspection (take effect at clock.Now()) ----
  void SetSilent(bool silent);
  void LoseSteps(int motor, int64_t steps);
  void SetStuckSwitch(int motor, std::optional<bool> level);
  // Runs `fn` on the controller under the lock after advancing it to clock.Now().
  void WithController(const std::function<void(Controller&)>& fn);

 private:
  TrinamicCanServer(const CanServerOptions& options, const Clock& clock,
                    std::unique_ptr<transport::CanChannel> channel, Controller controller);
  void Run();
  void AdvanceLocked();
  void AdvanceControllerLocked(TimePoint to);
  void ProcessQueueLocked(TimePoint now);
  void ExecuteLocked(const drivegw::trinamic::Command& command);
  void AfterResetLocked();
  void HandleFrameLocked(const transport::CanFrame& frame);
  void SendReplyLocked(const std::vector<uint8_t>& r9);
  void SerialLocked(const std::vector<uint8_t>& bytes);
  void TunnelFlushLocked(TimePoint now, bool force);
  Duration PacketTimeoutLocked() const;

  CanServerOptions options_;
  const Clock& clock_;
  std::unique_ptr<transport::CanChannel> channel_;
  uint16_t command_id_ = 0;
  uint16_t tunnel_id_ = 0;  // (A << 3) + 1 with a serial endpoint (L315)
  std::optional<transport::PseudoTerminal> pty_;
  mutable std::mutex mu_;
  Controller controller_;
  uint64_t resets_seen_ = 0;
  bool can_mode_ = false;
  std::deque<std::pair<TimePoint, drivegw::trinamic::Command>> queue_;
  TimePoint busy_until_{};
  WordAssembler words_;
  std::vector<uint8_t> tunnel_rx_;
  TimePoint tunnel_since_{};
  TimePoint start_;
  TimePoint advanced_to_;
  bool reset_done_ = false;
  CanServerCounters counters_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::trinamic
