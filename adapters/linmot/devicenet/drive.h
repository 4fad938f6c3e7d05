// LinMotDnDrive: the Drive of one motor of a LinMot DeviceNet controller — control word
// (RUN/STOP/INIT), Addressed commands with echo and toggle handshakes, background status reads,
// unified status. Sources: linmot-devicenet.md §7, §8, §11; decisions docs/decisions/980..989.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_base.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/commands.h"
#include "adapters/linmot/devicenet/session.h"

namespace drivegw::linmot::devicenet {

// §0.5: 1 position increment = 19.53125 µm = 1/51.2 mm (LinMot motors).
inline constexpr double kPositionIncrementsPerMm = 51.2;
// §0.5 filter units: 1 speed increment = 190.735 µm/s, 1 acceleration increment = 238.419 mm/s².
inline constexpr double kMmSPerSpeedIncrement = 0.190735;
inline constexpr double kMmS2PerAccelerationIncrement = 238.419;

// What the configuration (DriveConfig) cannot say yet: the defaults of decision 981.
struct DnDriveOptions {
  IoLayout layout = DefaultLayoutP();  // D-3 candidate P, motor A master, little-endian (D-1)
  Motor motor = Motor::kA;             // the controller's motor this drive commands
  SessionOptions session;              // gateway MAC ID 0, duplicate MAC ID check timing
  Duration poll_period = std::chrono::milliseconds(10);       // D-33
  Duration response_timeout = std::chrono::milliseconds(50);  // per poll
  uint16_t expected_packet_rate_ms = 100;                     // poll connection (TC-01 value)
  uint16_t explicit_epr_ms = 2500;                            // §11.2 step 5
  Duration explicit_timeout = std::chrono::milliseconds(200);
  Duration restart_wait = std::chrono::seconds(2);  // §11.8
  // Injected bus (tests): used instead of opening config.can through the SessionPool.
  std::shared_ptr<Session> session_override;
};

// Unified state of a LinMot DeviceNet controller's status low word for `motor`
// (docs/decisions/982-devicenet-state-mapping.md). Pure; `online` false gives OFFLINE.
// `motion_active`: the drive's own judgement (the protocol has no Motion Active bit): RUN, not
// In Position, and a gateway motion command open or the axis measurably moving.
DriveState MapDnState(bool online, StatusLowWord low, Motor motor, bool motion_active);

// Conversions of §0.5, checked (never clamped): OutOfRange naming the field and the wire range.
absl::StatusOr<int16_t> PositionToDn(const std::string& field, double mm);
double PositionFromDn(int32_t increments);
absl::StatusOr<uint16_t> SpeedToDn(const std::string& field, double mm_s);          // 0x51
absl::StatusOr<uint16_t> AccelerationToDn(const std::string& field, double mm_s2);  // 0x53

class LinMotDnDrive final : public DriveBase, private SessionPeer {
 public:
  // `config.can` and `config.mac_id` must be set (CreateLinMotDnDrive checks them); `clock` must
  // advance in real time and outlive the drive.
  LinMotDnDrive(DriveConfig config, const Clock& clock, DnDriveOptions options = {});
  ~LinMotDnDrive() override;

  std::string endpoint() const override;  // "devicenet://udp:239.74.163.2:43113/5"

  absl::StatusOr<CommandInfo> Enable() override;
  absl::StatusOr<CommandInfo> Disable() override;
  absl::StatusOr<CommandInfo> Home() override;
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override;
  absl::StatusOr<CommandInfo> AcknowledgeFault() override;

  // ParameterRef.id = a command ID of a Get/Set pair of §8.9 (either half); reads also take any
  // other documented Get command (status words, coded error, I/O). No stored values (rom): §8.8.
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override;
  absl::Status WriteParameter(const ParameterRef& ref, int64_t value) override;
  // LinMotDnRequest: one Addressed command, word 1 as given (bit 7 of a T-command is the
  // handshake's, §8.2), word 2 = value (-32768..65535). Reply: word2 = echo, word3 = response
  // value, word4 = status low word, status = coded error the command raised (0: none).
  absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) override;
  // A timed sequence of set-point moves (0x51 + 0x11 per leg): DeviceNet cannot transfer curve
  // shapes (linmot-devicenet.md §8.8); drive_curve.cpp, docs/decisions/987-devicenet-curve-run.md.
  absl::StatusOr<CommandInfo> RunCurve(const Curve& curve, const CurveRunOptions& options) override;
  // Frames to and from this MAC ID, logged by the session (PeerOptions::wire_trace).
  absl::Status SetWireTrace(bool on) override {
    wire_trace_->store(on);
    return absl::OkStatus();
  }

  // Diagnostics for the dashboard; nullopt while not ACTIVE.
  std::optional<PeerCounters> exchange_counters() const;
  // As drive_metrics.cpp reads them; missed = poll and explicit timeouts.
  LinkHealth link_health() const override {
    const auto c = exchange_counters();
    if (!c) return {};
    return {c->polls_sent + c->explicit_requests, c->poll_responses,
            c->poll_timeouts + c->explicit_timeouts, c->last_round_trip_ms};
  }
  std::optional<SessionCounters> session_counters() const;
  const DnDriveOptions& options() const { return options_; }

 protected:
  absl::Status DoActivate() override;
  void DoDeactivate() override;

 private:
  // The newest poll response and what the background reads found (§7.4, §8.5).
  struct Sample {
    bool valid = false;
    StatusLowWord low;
    StatusHighWord high;
    TimePoint received{};
    uint64_t gen = 0;  // poll generation the response answered
  };
  struct Cache {  // values read by Get commands (background or on request)
    std::optional<int16_t> actual_position;
    uint64_t actual_gen = 0;
    std::optional<int16_t> setpoint;
    uint64_t setpoint_gen = 0;
    std::optional<uint16_t> coded_error;
    std::optional<uint16_t> system_error;
    std::optional<uint16_t> motor_error;
    std::optional<uint16_t> system_warn;
    std::optional<uint16_t> motor_warn;
    std::optional<uint16_t> filter_speed;         // last value written with 0x51 (D-29)
    std::optional<uint16_t> filter_acceleration;  // 0x53
  };
  // One Addressed command in flight (§11.4).
  struct Transaction {
    uint64_t serial = 0;
    CommandSlot slot;
    const CommandSpec* spec = nullptr;
    bool toggle = false;         // T-command: done when Command Toggle == T too
    bool once = false;           // never answered (0x0F): carried by exactly one poll
    std::optional<Motor> motor;  // whose Command Toggle a T-command flips
    uint64_t first_gen = 0;      // first poll that carries it
    bool error_before = false;   // ERROR Pending at submission
    bool error_rose = false;     // ERROR Pending seen rising while in flight
    bool done = false;
    CommandSlot response;
    StatusLowWord low_at_response;
    uint64_t response_gen = 0;
  };
  struct MotionTracker {
    uint64_t id = 0;
    std::string kind;
    int16_t target = 0;
    uint64_t accepted_gen = 0;  // DONE needs a response to a later poll
    std::optional<TimePoint> completion_deadline;
  };
  enum class HomingPhase { kStarting, kRunning, kRestoring };
  struct HomingTracker {
    uint64_t id = 0;
    HomingPhase phase = HomingPhase::kStarting;
    uint64_t cw_gen = 0;  // control word generation carrying this phase's request
    TimePoint deadline{};
    int settle = 0;  // answered polls without INIT State but with INIT Done (kStarting)
  };
  enum class Wait { kReached, kDeadline, kOffline, kInactive };
  class CurveRunner;  // the legs of a RunCurve after the first one (drive_curve.cpp)

  // SessionPeer (I/O thread, under the session lock).
  std::vector<uint8_t> BuildPollCommand() noexcept override;
  void OnPollResponse(std::span<const uint8_t> produced, TimePoint received) noexcept override;
  bool HasUrgentRequest() noexcept override;
  void OnLinkChange(LinkState state, const std::string& reason) noexcept override;
  void OnHealthChange(const HealthInfo& health) noexcept override { SetHealth(health); }

  // All *Locked members need mu_.
  CommandSlot BackgroundSlotLocked();
  void AbsorbResponseLocked(CommandSlot addressed);
  void EvaluateTrackersLocked(TimePoint now);
  void EvaluateMotionLocked(TimePoint now);
  void EvaluateHomingLocked(TimePoint now);
  void PublishLocked(bool force);
  DriveStatus BuildStatusLocked() const;
  Fault FaultLocked() const;
  std::vector<std::string> WarningsLocked() const;
  bool OnlineLocked() const { return link_ == LinkState::kOnline && sample_.valid; }
  bool MotionActiveLocked() const;
  bool CurveOpenLocked() const;  // a RunCurve handle is open (decision 987: MOVING meanwhile)
  void StopCurveRunner();        // Deactivate: the runner's legs use this connection
  bool FaultDetailsKnownLocked() const;
  bool FaultPendingLocked() const {
    return sample_.low.error_state() || sample_.low.error_pending();
  }
  std::string StateTextLocked() const;  // "RUN, INIT Done, In Position A"
  void MarkUrgentLocked();
  void SetControlWordLocked(uint16_t cw);
  uint16_t MotorMask() const { return MotorBit(options_.motor); }

  template <typename Pred>
  Wait WaitLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline, Pred reached);
  // Waits for a response to a poll that carried the current control word.
  Wait WaitControlWordLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline);
  absl::Status WaitOnlineLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline,
                                const char* operation);
  absl::Status WaitFailure(Wait w, const std::string& operation, const std::string& detail) const;
  absl::StatusOr<CommandInfo> Finish(uint64_t id, const absl::Status& status);

  // One Addressed command (§11.4): waits for the echo (and the toggle), then, if ERROR Pending
  // rose meanwhile, reads the coded error and fails with it. Needs tx_mu_ held by the caller's
  // thread; takes mu_ through `lock`.
  absl::StatusOr<Transaction> TransactLocked(std::unique_lock<std::mutex>& lock,
                                             const Command& command, TimePoint deadline,
                                             const std::string& what, bool strict = true);
  absl::StatusOr<int32_t> GetLocked(std::unique_lock<std::mutex>& lock, CommandId id,
                                    std::optional<Motor> motor, TimePoint deadline);
  absl::Status CodedErrorStatus(std::unique_lock<std::mutex>& lock, const std::string& what,
                                TimePoint deadline);

  absl::StatusOr<CommandInfo> RunMove(const MotionCommand& cmd);
  absl::Status WriteFilterLocked(std::unique_lock<std::mutex>& lock, CommandId id, uint16_t value,
                                 TimePoint deadline, const std::string& what);

  const Clock& clock_;
  const std::shared_ptr<std::atomic<bool>> wire_trace_ = std::make_shared<std::atomic<bool>>(false);
  const std::string name_;
  const DnDriveOptions options_;

  std::mutex op_mu_;  // one control-word / motion / parameter operation at a time
  std::mutex tx_mu_;  // one Addressed transaction at a time (§11.4)

  mutable std::mutex mu_;  // below; lock order: session lock -> mu_ -> DriveBase's lock
  std::condition_variable cv_;
  bool active_ = false;
  std::shared_ptr<Session> session_;
  PeerId peer_id_ = 0;
  LinkState link_ = LinkState::kUnknown;
  std::string link_reason_;
  Sample sample_;
  Cache cache_;
  struct PositionSample {
    TimePoint t;
    int16_t actual;
  };
  std::deque<PositionSample> history_;  // velocity window (decision 982)
  double velocity_mm_s_ = 0;

  // Outbound image (§11.3: the whole image, every poll).
  uint16_t control_word_ = 0;
  uint64_t cw_generation_ = 0;
  uint64_t cw_in_flight_ = 0;
  uint64_t cw_answered_ = 0;
  uint64_t poll_gen_ = 0;      // polls built
  uint64_t answered_gen_ = 0;  // poll generation the newest response answered
  bool urgent_ = false;
  std::optional<Transaction> tx_;
  uint64_t tx_serial_ = 0;
  size_t rotation_ = 0;
  int fault_hold_ = 0;       // responses held back while a new fault's details are read (982)
  uint64_t connection_ = 0;  // increments per OFFLINE: transactions of an older one fail

  std::optional<MotionTracker> motion_;
  std::optional<HomingTracker> homing_;
  std::optional<DriveStatus> published_;
  TimePoint published_at_{};
  std::optional<uint64_t> curve_command_;  // the latest RunCurve handle (decision 987)

  std::mutex curve_mu_;                 // guards curve_ (never held with mu_ or op_mu_)
  std::shared_ptr<CurveRunner> curve_;  // the latest RunCurve's leg scheduler
};

}  // namespace drivegw::linmot::devicenet
