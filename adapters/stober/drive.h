// StoberDrive: one STOBER axis (CiA 402 + the motion core's I401/I402 command interface) on the
// bus's shared CanopenMaster (adapters/canopen/master_pool.h), behind the unified Drive API.
// Status comes from TPDO1 (6041h, I89, I90, packed flags 4000h) and TPDO2 (6064h, 606Ch) of the
// default PDO layout (object_map.h, decision 1175); set values and the Execute edge go out as
// RPDOs. Sources: stober-motion.md §1-§4, §2.15; CiA 301/402; decisions 1191-1219.
#pragma once

#include <condition_variable>
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
#include "adapters/canopen/master.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_base.h"
#include "adapters/core/health.h"
#include "adapters/stober/cia402_master.h"
#include "adapters/stober/object_map.h"

namespace drivegw::stober {

struct StoberDriveCounters {
  uint64_t configurations = 0;  // successful node configurations (activation, boot-up, resume)
  uint64_t configure_failures = 0;
  uint64_t status_tpdos = 0;
  uint64_t actual_tpdos = 0;
  // TPDO1/TPDO2 shorter than their mapping (CiA 301 §7.2.2.3: the consumer drops them): counted
  // so a mis-mapped node shows up in /metrics instead of freezing the status silently; never
  // taken as a status (decisions 1405, 1421).
  uint64_t malformed_tpdos = 0;
  uint64_t rpdos = 0;
  uint64_t bootups = 0;  // boot-up messages after the first configuration (reboots)
  uint64_t heartbeat_losses = 0;
  uint64_t emcy = 0;
  uint64_t execute_retries = 0;  // Execute edges repeated because the node did not take one (1207)
  // Positioning Done (I92) seen while TPDO2 did not show the axis at rest at the target: a
  // duplicated or reordered status frame from before the edge; DONE waits (decision 1484).
  uint64_t done_withheld = 0;
};

// The RPDO images the drive keeps (every RPDO carries all its fields, so the unchanged ones are
// re-sent from here; refreshed from the node at every configuration, decision 1196).
struct RpdoImage {
  uint16_t control_word = 0;      // 6040h
  uint8_t command = 0;            // I401
  double position = 0;            // I403
  bool execute = false;           // I402 (= control word bit 4, decision 1175)
  double velocity = 0;            // I404
  double acceleration = 0;        // I405
  double deceleration = 0;        // I406
  double jerk = 0;                // I407
  double override_percent = 100;  // I230
  int direction = 0;              // I411
  bool brake_at_end = false;      // I410
  uint32_t motion_id = 0;         // I400
};

// RPDO4 while a cyclic stream runs: I421 cyclic position · I426 cyclic speed (decision 1205).
PdoLayout CyclicLayout();

class StoberDrive final : public DriveBase, private canopen::NodeObserver {
 public:
  StoberDrive(DriveConfig config, const Clock& clock);
  ~StoberDrive() override;

  std::string endpoint() const override;  // "canopen://udp:239.74.163.2:43113/node/5"

  absl::StatusOr<CommandInfo> Enable() override;
  absl::StatusOr<CommandInfo> Disable() override;
  absl::StatusOr<CommandInfo> Home() override;
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override;
  absl::StatusOr<CommandInfo> AcknowledgeFault() override;
  absl::StatusOr<std::unique_ptr<CyclicStream>> StartCyclic(CyclicMode mode) override;
  // drive_curve.cpp: the curve as MC_CyclicPosition set points at the SYNC period (decision 1208).
  absl::StatusOr<CommandInfo> RunCurve(const Curve& curve, const CurveRunOptions& options) override;

  // ParameterRef.id = CANopen index << 8 | sub; bound objects in their user value (rounded to
  // an integer), others as the raw integer of the SDO size. rom: InvalidArgument (decision 1201).
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override;
  absl::Status WriteParameter(const ParameterRef& ref, int64_t value) override;
  // StoberMcRequest (commands 0..11 → a command handle), CanOpenSdoRequest (raw SDO).
  absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) override;

  StoberDriveCounters counters() const;
  // missed = heartbeat losses; the SDO round trip lives in the CANopen master: left empty.
  LinkHealth link_health() const override {
    const StoberDriveCounters c = counters();
    return {c.rpdos, c.status_tpdos + c.actual_tpdos, c.heartbeat_losses, std::nullopt};
  }
  // The bus master's counters (SYNC timing, SDO, PDO); nullopt while not ACTIVE.
  std::optional<canopen::MasterCounters> master_counters() const;
  // Frames of this node on the bus while ACTIVE (CanopenMaster::SetNodeTrace).
  absl::Status SetWireTrace(bool on) override;

 protected:
  absl::Status DoActivate() override;
  void DoDeactivate() override;

 private:
  class Stream;
  friend class Stream;
  class CurveRunner;  // drive_curve.cpp

  // The one open motion-core command handle (§2.3: one status set per axis).
  struct Tracker {
    uint64_t id = 0;
    std::string kind;
    CommandProgress progress;
    TimePoint edge_sent{};
    bool counted = false;               // a TPDO1 produced after the edge arrived
    bool buffered_seen = false;         // pending: the node showed it buffered (I83 = 2)
    std::optional<TimePoint> deadline;  // homing
    // Positioning with a target the gateway knows (MoveAbsolute; MoveRelative from standstill):
    // its Done counts only with a TPDO2 after the edge at rest within I22 of it (decision 1484).
    std::optional<double> target;
    // TPDO2's position when the command started at standstill (I89 = 2, I199 = 1); unset when
    // the axis was moving, whose further motion would prove nothing about this edge.
    std::optional<double> start_position;
    // A TPDO2 after the edge shows the axis more than I22 away from start_position: the node is
    // executing this command, whatever TPDO1s were lost (decision 1485).
    bool moved = false;
    bool done_withheld = false;
    int done_frames = 0;     // TPDO1s in a row showing Done since it was withheld
    TimePoint done_since{};  // the first of them
  };

  // NodeObserver (receive thread).
  void OnHeartbeat(uint8_t node, canopen::NmtState state, TimePoint at) noexcept override;
  void OnBootUp(const canopen::NodeEventInfo& event) noexcept override;
  void OnEmcy(const canopen::EmcyEvent& event) noexcept override;
  void OnTpdo(const canopen::TpdoEvent& event) noexcept override;
  void OnLinkEvent(const canopen::NodeEventInfo& event) noexcept override;

  // Worker: (re)configures the node and supervises deadlines.
  void RunWorker();
  absl::Status Configure();
  absl::Status ConfigureMasterWatchdog(canopen::CanopenMaster& m,
                                       const std::function<TimePoint()>& deadline);
  void GoOfflineLocked(const std::string& reason, bool node_reset);

  // RPDO images → frames (non-blocking).
  absl::Status SendRpdoLocked(uint16_t number);
  TimePoint Deadline() const;
  Duration CycleTime() const;
  // canopen.rpdo_transmission_type: synchronous RPDOs (0..240) and the comm record to configure.
  bool SyncRpdos() const;
  canopen::PdoCommParams RpdoComm(const PdoLayout& layout) const;

  // Status.
  bool OnlineLocked() const;
  DriveStatus BuildStatusLocked() const;
  void PublishLocked();
  void EvaluateTrackerLocked(TimePoint now);
  // Decision 1484: the latest TPDO1 (with Done) and TPDO2 arrived after `t`'s edge and TPDO2
  // shows the axis at rest (|606Ch| ≤ C40) within the node's position window I22 of t.target;
  // true without a target.
  bool ArrivedLocked(const Tracker& t) const;
  // The buffered handle (decision 1210): true when it consumed the status (waiting, chain
  // error); false before its edge counts, or after it took over (tracker_ is then evaluated).
  bool EvaluatePendingLocked(TimePoint now);
  // I409/I429 by SDO before the edge when they differ from the node (decision 1209).
  absl::Status WriteBlockInputs(uint8_t command_mode, double end_velocity);
  void EndTrackerLocked(CommandState state, const std::string& message);
  absl::Status RequireOnlineLocked(const std::string& what) const;
  absl::Status RequireEnabledLocked(const std::string& what) const;
  std::string Prefix(const std::string& what) const;
  template <typename Pred>
  bool WaitLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline, Pred pred);

  // Control word step: sends it and waits until the power state satisfies `pred`.
  template <typename Pred>
  absl::Status ControlStepLocked(std::unique_lock<std::mutex>& lock, uint16_t control_word,
                                 TimePoint deadline, const std::string& what, Pred pred);

  // Enable/Disable/AcknowledgeFault: one operation at a time, online check, `precondition` (may
  // be empty; refusing records no command), then a command record whose outcome is `step`'s.
  absl::StatusOr<CommandInfo> RunControlCommand(
      const char* name, const std::function<absl::Status()>& precondition,
      const std::function<absl::Status(std::unique_lock<std::mutex>&)>& step);

  // Motion-core command: set values, edge, acceptance, Execute low (decision 1179/1197).
  struct McStart {
    std::string kind;
    uint8_t command = 0;
    double position = 0;
    double velocity = 0;
    double acceleration = 0;
    double deceleration = 0;
    double jerk = 0;
    std::optional<int> direction;
    std::optional<uint32_t> motion_id;
    bool homing = false;
    uint8_t command_mode = 0;  // I409: 0 aborting, 1 buffered (decision 1162)
    double end_velocity = 0;   // I429 (1-3)
  };
  absl::StatusOr<CommandInfo> StartMc(const McStart& start);
  absl::StatusOr<McStart> PlanMove(const MotionCommand& cmd) const;
  absl::StatusOr<NativeReply> Sdo(const CanOpenSdoRequest& req);
  absl::Status WriteBound(const char* param, double value);
  // drive_cyclic.cpp: RPDO4 ↔ the cyclic set values (decision 1205).
  absl::Status MapCyclicRpdo(bool cyclic);
  // StartCyclic with the handle's kind and a check run under the drive lock just before the edge.
  absl::StatusOr<std::unique_ptr<CyclicStream>> OpenCyclic(
      CyclicMode mode, const std::string& kind, const std::function<absl::Status()>& precondition);
  void StopCurveRunner();  // drive_curve.cpp: Deactivate ends the runner thread
  absl::StatusOr<CommandInfo> CloseStream(Stream* stream);
  void DetachStream();  // Deactivate: the open stream stops sending, SYNC stops if ours

  const Clock& clock_;
  const uint8_t node_;

  std::mutex op_mu_;  // one operation at a time
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::shared_ptr<canopen::CanopenMaster> master_;
  std::optional<canopen::ObserverId> observer_;
  std::thread worker_;
  bool stop_ = false;
  bool need_config_ = false;
  TimePoint next_try_{};  // next configuration attempt after a failure
  // Decision 1431: heartbeat loss, bus-off, a node that left OPERATIONAL or rebooted -> DOWN at
  // once; failed configurations count and set the re-configuration back-off. Set by DoActivate.
  std::optional<HealthModel> health_;
  void PublishHealthLocked();
  uint64_t config_gen_ = 0;  // bumped by every event that invalidates a configuration
  bool configuring_ = false;
  bool configured_ = false;
  bool link_ok_ = true;
  std::string offline_reason_ = "not configured yet";
  std::optional<MotionStatus> status_;
  ActualValues actual_;
  TimePoint actual_at_{};  // arrival of the TPDO2 in actual_
  TimePoint status_at_{};  // arrival of the TPDO1 in status_
  // I22 position window and C40 velocity window, read at configuration (decision 1484).
  double position_window_ = 0;
  double velocity_window_ = 0;
  uint64_t status_seq_ = 0;
  uint64_t heartbeats_ = 0;  // heartbeats seen
  canopen::NmtState heartbeat_state_ = canopen::NmtState::kBootUp;
  RpdoImage image_;
  Duration cycle_ = std::chrono::milliseconds(1);  // A150
  bool endless_ = false;                           // I00 = 1
  TimePoint execute_low_at_{};
  uint16_t emcy_code_ = 0;
  std::string emcy_text_;
  std::optional<Tracker> tracker_;
  // A command started with I409 = 1 behind tracker_: BUSY until the node's take-over (I83 leaves
  // 2), then it becomes tracker_ (decision 1210).
  std::optional<Tracker> pending_;
  // I409 / I429 as the node holds them (read back at configuration, written by SDO before an
  // edge that needs other values; not in the RPDO layout, decision 1209).
  uint8_t command_mode_ = 0;
  double end_velocity_ = 0;
  bool disabling_ = false;
  // Set position of the last absolute positioning (demand position once it is Done, decision 1203).
  std::optional<double> demand_target_;
  bool demand_reached_ = false;
  Stream* stream_ = nullptr;   // the open cyclic stream, if any (RPDO4 carries I421/I426)
  bool sync_started_ = false;  // this drive started the bus's SYNC producer
  PdoLayout cyclic_layout_ = CyclicLayout();
  StoberDriveCounters counters_;
  std::mutex curve_mu_;                 // guards curve_ (never held with mu_ or op_mu_)
  std::shared_ptr<CurveRunner> curve_;  // the latest RunCurve's streaming thread
};

}  // namespace drivegw::stober
