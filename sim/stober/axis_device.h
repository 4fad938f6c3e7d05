// AxisDevice: the simulated STOBER axis as a CANopen device (issue 5): binds the pure
// MotionCore into a SlaveNode's object dictionary per the shared object map
// (adapters/stober/object_map.h): every catalogue parameter and CiA 402 object with read/write
// hooks into the core, the packed status object 4000h, the default PDO layout, the motion core
// advanced in A150 cycles from Tick(dt), EMCY on faults, reset on NMT reset node.
// Gap choices: decisions 1176-1181.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/stober/object_map.h"
#include "sim/canopen/device_model.h"
#include "sim/canopen/node.h"
#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober {

// EMCY codes of the simulated axis (decision 1178).
inline constexpr uint16_t kEmcyFollowingError = 0x8611;  // CiA 402: following error
inline constexpr uint16_t kEmcyLimitSwitch = 0x8612;     // CiA 402: reference limit
// Motion-core errors (I91 = 1): FF00h + I90 cause, manufacturer-specific range of CiA 301.
inline constexpr uint16_t kEmcyMotionCoreBase = 0xFF00;
inline constexpr uint8_t kErrorRegisterProfile = 0x20;       // 1001h bit 5: device profile
inline constexpr uint8_t kErrorRegisterManufacturer = 0x80;  // 1001h bit 7

struct AxisDeviceOptions {
  MotionCoreOptions core;
  std::optional<double> cycle_ms;  // A150 at power-on (default: the catalogue's 1 ms)
  bool endless = false;            // I00 = 1 with I01 = revolution at power-on
  double revolution = 360;
  // I423 at power-on (default: the catalogue's 5 ms): how long the motion core extrapolates
  // missing cyclic set values before event 78 cause 3 (L1344) — the commissioned value of a
  // drive whose master is not hard real-time (decision 413).
  std::optional<double> extrapolation_ms;
};

// Every callback runs on the SlaveServer's I/O thread under its lock (decision 1126); so do the
// fault-injection methods, which take the node for the EMCY they raise (AxisServer calls them
// through SlaveServer::WithNode).
class AxisDevice : public canopen::DeviceModel {
 public:
  explicit AxisDevice(AxisDeviceOptions options = {});
  // The options' power-on writes (A150, I423, I00, I01) against the catalogue: InvalidArgument
  // naming the parameter and the limit.
  static absl::Status Validate(const AxisDeviceOptions& options);

  absl::Status Configure(canopen::SlaveNode& node) override;
  void Tick(canopen::SlaveNode& node, Duration dt) override;
  // Input latch (decision 1182): Execute written 0 by an RPDO since the previous cycle counts as
  // seen low at the next one, so low + high read in one burst still give one rising edge.
  void OnRpdoWritten(canopen::SlaveNode& node, uint16_t number) override;
  void OnResetApplication(canopen::SlaveNode& node) override;
  // 6007h abort connection option on a heartbeat time-out or bus-off (decision 1483).
  void OnCommunicationError(canopen::SlaveNode& node, uint16_t emcy_code,
                            uint8_t producer) override;
  // Called (on the server's thread) with the motion-log entry of each 6007h reaction, so
  // `drivegw-sim stober` can print it.
  void SetAbortListener(std::function<void(const Event&)> listener) {
    on_abort_ = std::move(listener);
  }

  MotionCore& core() { return *core_; }
  const MotionCore& core() const { return *core_; }
  // TPDO1's packed status word (4000h) as the model sees it now.
  uint32_t StatusFlags() const;

  // ---- fault injection ----
  // A following error: CiA 402 fault (Fault reaction active → Fault) and EMCY 8611h.
  void InjectFollowingError(canopen::SlaveNode& node);
  // Forces the hardware limit switch signal (nullopt: follow the simulated position); the EMCY
  // follows from the next cycle's I441/I442.
  void ForceLimitSwitch(bool positive, std::optional<bool> active);
  // Execute edges the axis does not take (decision 1182): every edge while `ignore` is set, or
  // only the next one. The suppressed edge leaves Execute low in the core.
  void SetIgnoreExecute(bool ignore) { ignore_execute_ = ignore; }
  void DropNextExecuteEdge() { drop_next_edge_ = true; }
  uint64_t dropped_edges() const { return dropped_edges_; }

 private:
  absl::Status AddObject(canopen::SlaveNode& node, const drivegw::stober::ObjectBinding& b);
  static absl::StatusOr<std::unique_ptr<MotionCore>> MakeCore(const AxisDeviceOptions& options);
  void Restart();
  void AfterCycle(canopen::SlaveNode& node);
  void SampleExecute();  // input latch and edge suppression, right before a core cycle

  AxisDeviceOptions options_;
  std::unique_ptr<MotionCore> core_;
  Duration carry_{};  // time not yet spent in whole A150 cycles
  // Fault edges seen after the previous cycle (EMCY on a rising edge, decision 1178).
  bool error_ = false;
  bool positive_limit_ = false;
  bool negative_limit_ = false;
  bool emcy_active_ = false;
  uint32_t last_flags_ = 0;
  uint16_t last_status_word_ = 0;
  int last_plc_ = 0;
  // Execute input (decision 1182).
  bool sampled_execute_ = false;   // I402 at the previous core cycle
  bool execute_seen_low_ = false;  // an RPDO wrote I402 = 0 since the previous core cycle
  bool ignore_execute_ = false;
  bool drop_next_edge_ = false;
  uint64_t dropped_edges_ = 0;
  std::function<void(const Event&)> on_abort_;
};

}  // namespace drivegw::sim::stober
