// TrinamicDrive: one motor of a SIXpack/QUADpack (motnr = config.trinamic.axis) behind the unified
// Drive API. Words go through the controller's shared Pack; state comes from the Pack's `$20`/`$21`
// samples. The PACK acknowledges nothing (G-06): acceptance and completion are confirmed by the
// next samples. Sources: trinamic-sixpack.md §4.2, §5.4-5.8, §8, §9; decisions 1081-1099.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_base.h"
#include "adapters/trinamic/pack.h"
#include "adapters/trinamic/parameters.h"
#include "adapters/trinamic/units.h"

namespace drivegw::trinamic {

// Action codes of `$20` P5 (L661-662, G-13).
inline constexpr uint8_t kActionInactive = 0;
inline constexpr uint8_t kActionRamp = 5;
inline constexpr uint8_t kActionPi = 10;
inline constexpr uint8_t kActionRotation = 15;
inline bool IsReferenceAction(uint8_t a) { return (a >= 20 && a <= 29) || a == 30; }
// "inactive", "ramp", "PI control", "rotation", "reference search (phase 23)", ...
std::string ActionText(uint8_t action);

// Fault codes of the unified status (decision 1083).
inline constexpr uint32_t kFaultStopCondition = 1;
inline constexpr uint32_t kFaultDuplicateAddress = 2;

struct TrinamicDriveCounters {
  uint64_t samples = 0;
  uint64_t words = 0;            // words this drive sent (motion, currents, parameters, native)
  uint64_t stop_conditions = 0;  // `$20` P6 seen set
  uint64_t resets = 0;           // controller resets seen
  uint64_t accept_failures = 0;  // motion words the next `$20` did not confirm
};

class TrinamicDrive final : public DriveBase, private PackListener {
 public:
  // `shadow` holds the configured parameters (the factory validated them); `clock` must outlive
  // the drive.
  TrinamicDrive(DriveConfig config, const Clock& clock, ParameterShadow shadow);
  ~TrinamicDrive() override;

  std::string endpoint() const override;  // "trinamic://serial:/dev/ttyUSB0#1/motor/0"

  absl::StatusOr<CommandInfo> Enable() override;
  absl::StatusOr<CommandInfo> Disable() override;
  absl::StatusOr<CommandInfo> Home() override;
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override;
  absl::StatusOr<CommandInfo> AcknowledgeFault() override;
  absl::StatusOr<std::vector<CommandInfo>> MoveCoordinated(const CoordinatedMove& move,
                                                           std::span<Drive* const> group) override;
  // drive_curve.cpp: the curve as timed position-mode legs (decisions 1231-1233).
  absl::StatusOr<CommandInfo> RunCurve(const Curve& curve, const CurveRunOptions& options) override;

  // ParameterRef.id = opcode << 8 | P (parameters.h). Read = the shadow (no read-back, G-24).
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override;
  absl::Status WriteParameter(const ParameterRef& ref, int64_t value) override;
  // TrinamicRequest (any opcode but $F2..$F7) and TrinamicTunnelRequest (CAN only).
  absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) override;
  // Words of the controller's line while ACTIVE (the axes share it; ControllerSession).
  absl::Status SetWireTrace(bool on) override;

  // Diagnostics (dashboard); nullopt while not ACTIVE.
  TrinamicDriveCounters counters() const;
  // missed = motion words the next `$20` did not confirm; the round trip is per controller line
  // (session), not per axis: left empty.
  LinkHealth link_health() const override {
    const TrinamicDriveCounters c = counters();
    return {c.words, c.samples, c.accept_failures, std::nullopt};
  }
  std::optional<PackCounters> pack_counters() const;
  std::optional<SessionCounters> session_counters() const;
  uint8_t axis() const { return axis_; }
  ParameterShadow shadow() const;
  // CT-20: the CAN bit rate selected by the PACK's jumpers (`$30` P4, §3.2, G-19), read once per
  // connect; nullopt on serial drives, while not active or before the first read.
  std::optional<int> can_bit_rate() const;

 protected:
  absl::Status DoActivate() override;
  void DoDeactivate() override;

 private:
  // kCurve: a RunCurve; samples confirm its first leg, the curve runner ends it (drive_curve.cpp).
  enum class TrackKind { kMove, kStop, kRotation, kHome, kCoordinated, kCurve };
  // One open motion/homing handle and how it completes.
  struct Tracker {
    uint64_t id = 0;
    std::string kind;
    TrackKind track = TrackKind::kMove;
    int32_t target = 0;
    bool accepted = false;
    bool homing_seen = false;
    SessionClock::time_point sent{};      // the command word(s) completed at
    SessionClock::time_point deadline{};  // acceptance / homing deadline
  };
  enum class Wait { kReached, kDeadline, kOffline, kInactive };

  // PackListener (poll thread).
  void OnSample(const AxisSample& sample) noexcept override;
  void OnLink(LinkState state, const std::string& reason) noexcept override;
  void OnHealth(const HealthInfo& health) noexcept override { SetHealth(health); }
  void OnControllerReset() noexcept override;
  void OnDuplicateAddress(const std::string& detail) noexcept override;
  std::vector<Command> ApplyCommands(bool controller) const override;
  void AbsorbWord(const Command& word) noexcept override;
  absl::Status CheckShared(uint32_t id, int64_t value, int baud) const override;
  // The serial line rate now (the Pack's, after any `$40`), 19200 on CAN (G-40).
  int LineBaud() const;

  // One word through the Pack; errors name the drive and the opcode.
  absl::StatusOr<std::optional<Reply>> SendWord(const Command& command);
  absl::Status SendAll(const std::vector<Command>& commands);
  void PollSoon();  // asks the Pack for this axis's next sample now
  Command Word(Opcode opcode, std::initializer_list<int64_t> values) const;
  absl::StatusOr<Command> CurrentsWord(bool on) const;

  // Everything below with *Locked needs mu_ (never held while calling the Pack).
  bool OnlineLocked() const { return link_ == LinkState::kOnline && sample_.has_value(); }
  bool FaultLocked() const { return stop_fault_ || duplicate_fault_; }
  uint8_t ActionLocked() const { return sample_ ? sample_->action : 0; }
  void EvaluateLocked(std::vector<std::pair<uint64_t, std::pair<CommandState, std::string>>>& out);
  void PublishLocked();
  DriveStatus BuildStatusLocked() const;
  absl::Status RequireOnlineLocked(const std::string& what) const;
  absl::Status RequireOperationalLocked(const std::string& what) const;
  template <typename Pred>
  Wait WaitLocked(std::unique_lock<std::mutex>& lock, SessionClock::time_point deadline, Pred pred);
  // Waits for a sample sent after `after` satisfying pred.
  Wait WaitSampleLocked(std::unique_lock<std::mutex>& lock, SessionClock::time_point after,
                        SessionClock::time_point deadline,
                        const std::function<bool(const AxisSample&)>& pred);
  std::string Prefix(const std::string& what) const;

  // Motion helpers.
  struct Ramp {
    int vmax = 0;
    int amax = 0;
  };
  absl::StatusOr<Ramp> RampFor(const std::string& kind, double velocity_mm_s,
                               double acceleration_mm_s2, double deceleration_mm_s2) const;
  // mm/s² -> amax, refusing amax > vstart × 64 (L556) with the limit in mm/s².
  absl::StatusOr<int> AmaxFor(const std::string& field, double acceleration_mm_s2) const;
  absl::StatusOr<int32_t> TargetFor(const std::string& field, double mm) const;
  absl::Status WriteRamp(const Ramp& ramp);
  // Sends the target words for a move to `target` given the current action (CT-23, CT-27).
  absl::Status StartRampTo(int32_t target);
  absl::StatusOr<CommandInfo> RunMotion(const MotionCommand& cmd);
  absl::StatusOr<CommandInfo> AwaitAcceptance(uint64_t id, const std::string& kind);
  // Called on a member of a coordinated group.
  CommandInfo BeginTracker(const std::string& kind, TrackKind track, int32_t target,
                           SessionClock::time_point sent, SessionClock::time_point deadline);
  // Sends `word`, asks for the next sample at once and waits (timeouts.request) for a sample sent
  // after it that satisfies `reached`; otherwise returns `timed_out()`, called with mu_ held.
  absl::Status SendAndAwaitSample(const Command& word,
                                  const std::function<bool(const AxisSample&)>& reached,
                                  const std::function<absl::Status()>& timed_out);
  absl::Status StopAndWait(const std::string& what);
  class CurveRunner;       // drive_curve.cpp
  void StopCurveRunner();  // Deactivate ends the runner thread

  const Clock& clock_;
  const std::string name_;
  const uint8_t axis_;
  const double mpu_;  // microsteps per unit

  std::mutex op_mu_;  // one operation (command, parameter, native) at a time
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::shared_ptr<Pack> pack_;
  bool registered_ = false;
  ParameterShadow shadow_;
  LinkState link_ = LinkState::kUnknown;
  std::string link_reason_;
  std::optional<AxisSample> sample_;
  bool enabled_ = false;  // currents on (decision 1082: disabled = current off)
  bool homed_ = false;
  bool stop_fault_ = false;
  bool duplicate_fault_ = false;
  std::string duplicate_detail_;
  SessionClock::time_point duplicate_seen_{};
  bool reset_warning_ = false;
  std::optional<Tracker> tracker_;
  TrinamicDriveCounters counters_;
  std::mutex curve_mu_;                 // guards curve_ (never held with mu_ or op_mu_)
  std::shared_ptr<CurveRunner> curve_;  // the latest RunCurve's leg scheduler
};

}  // namespace drivegw::trinamic
