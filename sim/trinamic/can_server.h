// TrinamicCanServer: one simulated SIXpack/QUADpack on a CAN channel (UDP multicast bus or
// SocketCAN): command frames ID = A << 3, replies to ID = RA << 3, 8-byte frames (§3,
// L289-291). The controller is advanced to an injected clock on every loop (never by sleeping).
#pragma once

#include <atomic>
#include <cstdint>
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
#include "sim/trinamic/controller.h"
#include "sim/trinamic/options.h"

namespace drivegw::sim::trinamic {

struct CanServerOptions {
  // `framing` is ignored: CAN replies are always the 8-byte body under ID RA << 3.
  ControllerOptions controller;
  CanBusConfig can;  // the bus to open unless a channel is injected
  Faults faults;     // silent controller, power loss at a chosen time
};

struct CanServerCounters {
  uint64_t frames_in = 0;       // frames returned by the channel
  uint64_t commands = 0;        // frames decoded and handed to the controller
  uint64_t malformed = 0;       // frames the codec refused (DLC, RTR, extended, opcode): dropped
  uint64_t foreign = 0;         // frames for another identifier that passed the filter
  uint64_t replies = 0;         // reply frames sent
  uint64_t send_errors = 0;     // replies the channel refused
  uint64_t receive_errors = 0;  // channel errors while receiving
  uint64_t resets = 0;          // injected power losses
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
  void HandleFrameLocked(const transport::CanFrame& frame);
  void SendReplyLocked(const std::vector<uint8_t>& r9);

  CanServerOptions options_;
  const Clock& clock_;
  std::unique_ptr<transport::CanChannel> channel_;
  uint16_t command_id_ = 0;
  mutable std::mutex mu_;
  Controller controller_;
  TimePoint start_;
  TimePoint advanced_to_;
  bool reset_done_ = false;
  CanServerCounters counters_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::trinamic
