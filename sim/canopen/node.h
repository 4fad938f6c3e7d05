// SlaveNode: a generic simulated CANopen slave without I/O: NMT slave state machine with boot-up
// message, SDO server over the object dictionary (expedited + segmented, per-frame timeout),
// heartbeat producer (1017h) and consumer (1016h), SYNC consumer, synchronous and event-driven
// TPDOs (inhibit time, event timer), RPDOs (synchronous ones applied at the next SYNC, deadline
// monitoring), EMCY producer with 1001h/1003h, 1029h error behaviour, and fault injection.
// Time comes in with every call (an injected clock's Now()); frames to send collect in an
// outbox the owner drains with TakeFrames().
// Source: CiA 301 v4.2.0 §7.2.2 (PDO), §7.2.4 (SDO), §7.2.5 (SYNC), §7.2.7 (EMCY), §7.2.8 (NMT,
// error control), §7.5.2 (communication objects). Decisions 1121-1139.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/nmt.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"
#include "adapters/core/clock.h"
#include "adapters/transport/can_frame.h"
#include "sim/canopen/communication_objects.h"
#include "sim/canopen/device_model.h"
#include "sim/canopen/object_dictionary.h"

namespace drivegw::sim::canopen {

using drivegw::canopen::NmtState;

struct SlaveNodeOptions {
  uint8_t node_id = 1;  // 1..127
  DeviceIdentity identity;
  uint16_t heartbeat_ms = 0;  // 1017h power-on value; 0 = no heartbeat
  // 1016h:01 power-on value: monitor the master's heartbeat (node 0 = off, decision 1130).
  uint8_t master_node = 0;
  uint16_t master_heartbeat_ms = 0;
  ErrorBehaviour error_behaviour = ErrorBehaviour::kPreOperational;  // 1029h:01 power-on
  // The SDO server drops a segmented transfer whose next request does not come within this
  // time after its last response, with abort 0504 0000h (decision 1103's default).
  Duration sdo_timeout = drivegw::canopen::kSdoDefaultTimeout;
  size_t sdo_max_download = drivegw::canopen::kSdoDefaultMaxSize;
  // Largest step handed to DeviceModel::Tick; a longer advance is split. Zero: one step.
  Duration max_tick = Duration::zero();
};

struct NodeCounters {
  uint64_t frames_in = 0;          // frames handed to OnFrame (also while silent)
  uint64_t frames_ignored = 0;     // not for this node, or not acted on in the NMT state
  uint64_t nmt_commands = 0;       // NMT commands for this node (or all nodes) acted on
  uint64_t sdo_requests = 0;       // SDO request frames processed
  uint64_t sdo_aborts = 0;         // abort frames sent by the SDO server
  uint64_t syncs = 0;              // SYNC objects consumed in OPERATIONAL
  uint64_t rpdos_received = 0;     // RPDO frames accepted (length ok)
  uint64_t rpdos_applied = 0;      // RPDO payloads written to the dictionary
  uint64_t rpdo_write_errors = 0;  // mapped objects whose write the dictionary refused
  uint64_t tpdos_sent = 0;
  uint64_t heartbeats_sent = 0;
  uint64_t emcys_sent = 0;
  uint64_t boot_ups = 0;
  uint64_t suppressed = 0;  // frames not sent because of an injected fault
};

class SlaveNode {
 public:
  // Validates the options, builds the dictionary with the communication objects and lets the
  // model add its own (DeviceModel::Configure). The node is powered off until Boot(). `model`
  // may be null and must outlive the node.
  static absl::StatusOr<std::unique_ptr<SlaveNode>> Create(const SlaveNodeOptions& options,
                                                           DeviceModel* model = nullptr);
  ~SlaveNode();
  SlaveNode(const SlaveNode&) = delete;
  SlaveNode& operator=(const SlaveNode&) = delete;

  ObjectDictionary& dictionary() { return od_; }
  const ObjectDictionary& dictionary() const { return od_; }
  const SlaveNodeOptions& options() const { return options_; }
  uint8_t node_id() const { return options_.node_id; }
  NmtState state() const { return state_; }
  bool booted() const { return booted_; }
  TimePoint now() const { return now_; }  // the instant the node was last advanced to
  const NodeCounters& counters() const { return counters_; }

  // Power-on: initialising → boot-up message → PRE-OPERATIONAL (Figure 48). Once.
  void Boot(TimePoint now);
  // A frame from the bus at `now` (the model and timers are advanced to `now` first).
  void OnFrame(const transport::CanFrame& frame, TimePoint now);
  // Advances the model and every timer (heartbeats, SDO timeout, event timers, inhibit times,
  // heartbeat consumers, RPDO deadlines) to `now`; earlier times are ignored.
  void Advance(TimePoint now);
  // Frames produced since the last call, in order.
  std::vector<transport::CanFrame> TakeFrames();

  // ---- device side ----
  // EMCY producer (§7.2.7): 1001h |= register_bits | generic, `code` on top of the 1003h
  // history, and the EMCY frame (1014h identifier; not in STOPPED or with 1014h invalid).
  void RaiseEmcy(uint16_t code, uint8_t register_bits, std::array<uint8_t, 5> msef = {});
  // All errors gone: 1001h = 0 and the "error reset" EMCY 0000h. The history stays.
  void ClearErrors();
  // A communication error (heartbeat consumer timeout, bus-off recovered): EMCY `code` with
  // the communication bit, then the 1029h:01 behaviour.
  void CommunicationError(uint16_t code, uint8_t producer = 0);
  // An application event for TPDO `number` (1..4): event-driven ones are sent (after the
  // inhibit time), acyclic synchronous (type 0) ones at the next SYNC.
  void RequestTpdo(uint16_t number);
  // Sets the power-on configuration of a PDO (SetDefaultPdo with this node's id) and applies it
  // now. For DeviceModel::Configure.
  absl::Status ConfigureDefaultPdo(drivegw::canopen::PdoKind kind, uint16_t number,
                                   const drivegw::canopen::PdoCommParams& comm,
                                   std::span<const drivegw::canopen::PdoMappingEntry> mapping);

  // ---- fault injection (decision 1133) ----
  // Off the bus: frames are neither acted on nor sent (no heartbeat, no SDO answers); timers
  // keep running, so heartbeat consumers may time out.
  void SetSilent(bool silent) { silent_ = silent; }
  bool silent() const { return silent_; }
  // Only the heartbeat frames are suppressed (boot-up messages still go out); everything else
  // works.
  void SetHeartbeatLoss(bool lost) { heartbeat_lost_ = lost; }
  // SDO reads and writes of index:sub are refused with `code` (PDOs are not affected).
  void InjectSdoAbort(uint16_t index, uint8_t sub, drivegw::canopen::SdoAbortCode code);
  void ClearSdoAborts() { injected_aborts_.clear(); }
  // Power cycle mid-operation: application and communication objects back to their defaults,
  // OnResetApplication, boot-up message, PRE-OPERATIONAL.
  void Reboot(TimePoint now);

 private:
  class SdoObjects;
  struct TpdoState {
    std::optional<TimePoint> last_sent;
    std::optional<std::vector<uint8_t>> last_payload;  // the last transmitted data
    std::optional<TimePoint> next_event;               // event timer expiry
    std::optional<std::vector<uint8_t>> rtr_sample;    // type 252: sampled at SYNC
    uint32_t syncs = 0;                                // SYNCs since the last transmission
    bool requested = false;                            // RequestTpdo pending
  };
  struct RpdoState {
    std::optional<std::vector<uint8_t>> pending;  // synchronous: applied at the next SYNC
    std::optional<TimePoint> deadline;            // event timer (deadline monitoring)
    bool deadline_missed = false;
  };
  struct ConsumerState {
    std::optional<TimePoint> last;  // monitoring starts with the first heartbeat
    bool timed_out = false;
  };

  SlaveNode(const SlaveNodeOptions& options, DeviceModel* model);
  bool Emit(const transport::CanFrame& frame);
  bool EmitErrorControl(NmtState state);
  void ScheduleHeartbeat();
  void SendEmcy(uint16_t code, uint8_t error_register, const std::array<uint8_t, 5>& msef);
  void SetState(NmtState to);
  void ResetNode(bool application);
  void TickModel(TimePoint now);
  void RunTimers();
  void ResetPdoRuntime();
  void OnDictionaryWrite(uint16_t index, uint8_t sub);

  void HandleNmt(const transport::CanFrame& frame);
  void HandleSync(const transport::CanFrame& frame);
  void HandleSdo(const transport::CanFrame& frame);
  void HandleHeartbeat(const transport::CanFrame& frame);
  bool HandlePdo(const transport::CanFrame& frame);

  absl::StatusOr<std::vector<uint8_t>> PackTpdo(const PdoConfig& config);
  void SendTpdo(const PdoConfig& config, std::vector<uint8_t> payload);
  void RunEventTpdos();
  void ApplyRpdo(const PdoConfig& config, std::span<const uint8_t> payload);

  SlaveNodeOptions options_;
  DeviceModel* model_;
  ObjectDictionary od_;
  std::unique_ptr<SdoObjects> sdo_objects_;
  std::optional<drivegw::canopen::SdoServer> sdo_;
  std::optional<TimePoint> sdo_deadline_;
  bool unsized_expedited_ = false;  // the request being served is e = 1, s = 0

  bool booted_ = false;
  NmtState state_ = NmtState::kBootUp;
  TimePoint now_{};
  TimePoint ticked_to_{};
  std::optional<TimePoint> next_heartbeat_;
  std::map<uint8_t, ConsumerState> consumers_;
  std::array<TpdoState, kPdoCount> tpdo_{};
  std::array<RpdoState, kPdoCount> rpdo_{};

  bool silent_ = false;
  bool heartbeat_lost_ = false;
  std::map<std::pair<uint16_t, uint8_t>, drivegw::canopen::SdoAbortCode> injected_aborts_;

  std::vector<transport::CanFrame> outbox_;
  NodeCounters counters_;
};

}  // namespace drivegw::sim::canopen
