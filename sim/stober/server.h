// AxisServer: one simulated STOBER axis on a CAN bus (UDP multicast or SocketCAN) — a
// SlaveServer (sim/canopen) with an AxisDevice, for `drivegw-sim stober` and the gateway's demo
// and tests (issue 5). Fault injection is forwarded to the device or the CANopen node
// (decision 1181).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/sdo.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/transport/can_channel.h"
#include "sim/canopen/server.h"
#include "sim/stober/axis_device.h"

namespace drivegw::sim::stober {

struct AxisServerOptions {
  uint8_t node_id = 1;        // 1..127
  CanBusConfig can;           // the bus to open unless a channel is injected
  AxisDeviceOptions axis;     // motion core, A150, endless axis
  uint16_t heartbeat_ms = 0;  // 1017h power-on value (0: off until the master writes it)
  // Each 6007h reaction to a lost connection, with its motion-log entry (decision 1483); runs
  // on the server's I/O thread.
  std::function<void(const Event&)> on_abort;
};

// CiA 402 device type (1000h): profile 402 (0192h), additional information 0002h servo drive.
inline constexpr uint32_t kDeviceTypeServo = 0x00020192;

class AxisServer {
 public:
  // Validates the options (node id, axis options) and starts the slave (boot-up message at
  // clock.Now()). `clock` must outlive the server.
  static absl::StatusOr<std::unique_ptr<AxisServer>> Start(
      const AxisServerOptions& options, const Clock& clock,
      std::unique_ptr<transport::CanChannel> channel = nullptr);
  ~AxisServer();
  AxisServer(const AxisServer&) = delete;
  AxisServer& operator=(const AxisServer&) = delete;

  void Stop();  // idempotent
  std::string bus_name() const { return slave_->bus_name(); }
  uint8_t node_id() const { return slave_->node_id(); }
  canopen::NmtState state() const { return slave_->state(); }
  canopen::SlaveServerCounters counters() const { return slave_->counters(); }

  // Runs `fn` on the motion core under the server's lock, after advancing it to clock.Now()
  // (observation in tests, commissioning helpers such as SetActualPosition).
  void WithAxis(const std::function<void(MotionCore&)>& fn);
  // An integer object of the node's dictionary as the node holds it now (tests: what a master
  // configured, e.g. 1016h:01 and 6007h, decision 1483).
  absl::StatusOr<int64_t> ReadObject(uint16_t index, uint8_t sub);

  // ---- fault injection (all at clock.Now()) ----
  void ForceLimitSwitch(bool positive, std::optional<bool> active);
  void InjectFollowingError();
  void InjectSdoAbort(uint16_t index, uint8_t sub, drivegw::canopen::SdoAbortCode code);
  void ClearSdoAborts();
  void SetHeartbeatLoss(bool lost);
  void SetSilent(bool silent);
  void Reboot();
  // Execute edges not taken by the axis (decision 1182): all while set, or only the next one.
  void SetIgnoreExecute(bool ignore);
  void DropNextExecuteEdge();
  uint64_t dropped_execute_edges();

 private:
  explicit AxisServer(std::unique_ptr<AxisDevice> device) : device_(std::move(device)) {}

  std::unique_ptr<AxisDevice> device_;  // outlives slave_ (declared first, destroyed last)
  std::unique_ptr<canopen::SlaveServer> slave_;
};

}  // namespace drivegw::sim::stober
