// SlaveServer: one simulated CANopen slave on a real CAN channel (UDP multicast bus or
// SocketCAN): owns the channel, one I/O thread and the SlaveNode with its DeviceModel. The node
// and the model advance to the injected clock on every frame and at least every 5 ms of real
// time, so a test's ManualClock::Advance takes effect without sleeping (decision 1134).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/transport/can_channel.h"
#include "sim/canopen/device_model.h"
#include "sim/canopen/node.h"

namespace drivegw::sim::canopen {

struct SlaveServerOptions {
  SlaveNodeOptions node;
  CanBusConfig can;  // the bus to open unless a channel is injected
};

struct SlaveServerCounters {
  uint64_t frames_in = 0;       // frames returned by the channel
  uint64_t frames_out = 0;      // frames the channel accepted
  uint64_t send_errors = 0;     // frames the channel refused
  uint64_t receive_errors = 0;  // channel errors while receiving
  NodeCounters node;
};

// Thread model: the I/O thread owns the Receive loop; public methods are thread-safe and
// serialised with it by one mutex. DeviceModel callbacks and dictionary hooks run on the I/O
// thread (or inside WithNode) with that mutex held: they may use the SlaveNode they are given,
// never the server's public methods (decision 1126).
class SlaveServer {
 public:
  // Validates the options, creates the node (DeviceModel::Configure), opens options.can unless
  // `channel` is injected, boots the node (boot-up message) at clock.Now() and starts the
  // thread. `clock` and `model` (may be null) must outlive the server.
  static absl::StatusOr<std::unique_ptr<SlaveServer>> Start(
      const SlaveServerOptions& options, const Clock& clock, DeviceModel* model = nullptr,
      std::unique_ptr<transport::CanChannel> channel = nullptr);
  ~SlaveServer();  // Stop()
  SlaveServer(const SlaveServer&) = delete;
  SlaveServer& operator=(const SlaveServer&) = delete;

  void Stop();  // prompt (wakes the Receive) and idempotent
  std::string bus_name() const { return channel_->name(); }
  uint8_t node_id() const { return node_id_; }
  NmtState state() const;
  SlaveServerCounters counters() const;

  // Runs `fn` on the node under the lock, after advancing it to clock.Now(); afterwards the
  // node's timers and event-driven TPDOs run and its frames are sent.
  void WithNode(const std::function<void(SlaveNode&)>& fn);

  // ---- device events ----
  void RaiseEmcy(uint16_t code, uint8_t register_bits, std::array<uint8_t, 5> msef = {});
  void ClearErrors();

  // ---- fault injection (decision 1133); all act at clock.Now() ----
  void SetSilent(bool silent);       // no frames in or out: no heartbeat, no SDO replies
  void SetHeartbeatLoss(bool lost);  // only the heartbeat stops
  void InjectSdoAbort(uint16_t index, uint8_t sub, drivegw::canopen::SdoAbortCode code);
  void ClearSdoAborts();
  void Reboot();  // boot-up message mid-operation, application values back to defaults

 private:
  SlaveServer(const Clock& clock, std::unique_ptr<transport::CanChannel> channel,
              std::unique_ptr<SlaveNode> node);
  void Run();
  void FlushLocked();

  const Clock& clock_;
  std::unique_ptr<transport::CanChannel> channel_;
  uint8_t node_id_ = 0;
  mutable std::mutex mu_;
  std::unique_ptr<SlaveNode> node_;
  transport::CanBusState bus_state_ = transport::CanBusState::kActive;
  SlaveServerCounters counters_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::canopen
