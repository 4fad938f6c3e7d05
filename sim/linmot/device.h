// LinMotDevice: one simulated LinMot drive (MC SW + LinUDP interface), pure: no I/O and no clock
// reads. Time moves only through Advance(); telegrams go through Handle().
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/codec.h"
#include "sim/linmot/error_log.h"
#include "sim/linmot/interpreter.h"
#include "sim/linmot/options.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/rtc_channel.h"
#include "sim/linmot/snapshot.h"
#include "sim/linmot/state_machine.h"
#include "sim/linmot/time_curve.h"
#include "sim/motion/axis.h"
#include "sim/motion/homing.h"

namespace drivegw::sim::linmot {

class LinMotDevice {
 public:
  // InvalidArgument for bad options (ValidateOptions). The drive starts powered up: state 0,
  // RAM = ROM = defaults, not homed (D-39), counts 0 (§4.3, A-08).
  static absl::StatusOr<std::unique_ptr<LinMotDevice>> Create(const SimOptions& options);

  // Moves simulated time forward in fixed ticks of options.tick (D-23); a remainder shorter than
  // a tick is kept for the next call, so Advance(0.4 ms) x 5 runs two 1 ms ticks.
  void Advance(Duration dt);

  // One LinUDP telegram (already decoded). Order within the telegram: control word, MC command,
  // RTC command; the reply shows the state after all three. nullopt = the drive does not answer
  // (booting after restart 0x30 / Reset 00F0h, A-11).
  std::optional<linudp::Reply> Handle(const linudp::Request& request);

  // ---- test hooks (fault injection) ----
  // A §10 code with the D-34 reaction (D-03 for Setup/Cfg errors while not switched on).
  // InvalidArgument for 0 or a code not in the table (D-33).
  absl::Status RaiseError(uint16_t code);
  // Warn word bits forced on (§13.5: supply voltages, temperatures, PTC ...).
  void SetInjectedWarnings(uint16_t warn_bits) { injected_warnings_ = warn_bits; }
  // The slider stops following the demand (collision / blocked load): lag grows to 000Bh/000Ch.
  void SetMotorBlocked(bool blocked) { blocked_ = blocked; }
  // Trigger input X4.6 (D-35: trigger out = trigger in for modes 1-4; mode 0 never fires).
  void SetTriggerInput(bool level);
  // The next curve stored through the curve service gets set point `index` changed (a read-back
  // mismatch for the master to detect; decision 607).
  void CorruptNextStoredCurvePoint(size_t index) { rtc_.CorruptNextStoredPoint(index); }

  // ---- observation ----
  DeviceSnapshot Snapshot() const;
  uint16_t status_word() const;
  uint16_t state_var() const;
  uint16_t warn_word() const;
  uint16_t error_code() const;  // pending error (states 3, 4, 14) else 0
  uint8_t main_state() const { return sm_.main_state(); }
  int32_t actual_position() const;  // 0.1 um
  int32_t demand_position() const;  // 0.1 um
  int16_t current_ma() const;
  bool homed() const { return homed_; }
  bool booting() const { return booting_; }
  bool event_handler_active() const;
  Duration sim_time() const { return sim_time_; }
  const Parameters& parameters() const { return params_; }
  Parameters& parameters() { return params_; }
  const ErrorLog& error_log() const { return error_log_; }
  // Motion log for fault-injection properties: the target (0.1 um) of every VAI move the
  // interpreter actually started, in order (a retried or duplicated frame that the count rule
  // ignored leaves no entry; a relative move executed twice leaves two).
  const std::vector<int64_t>& started_targets() const { return started_targets_; }
  // The stored curve `curve_id` (info and data bytes as downloaded), or nullptr.
  const RtcChannel::StoredCurve* stored_curve(uint16_t curve_id) const {
    return rtc_.FindCurve(curve_id);
  }
  // The time curve running now (040h-045h), if any.
  const std::optional<TimeCurve>& running_curve() const { return curve_; }
  const sim::motion::Axis& axis() const { return axis_; }
  const SimOptions& options() const { return options_; }

 private:
  explicit LinMotDevice(const SimOptions& options);

  // Power-up of the whole drive (creation, end of a reboot) or of the MC SW only (0x36).
  void PowerUp();
  void StartBoot();
  void Tick();
  bool Quiescent() const;
  SmInputs Inputs() const;
  void Apply(const SmEffects& fx);
  void ApplyControlWord(uint16_t control_word);
  void Execute(const Interpretation& in);
  void StartMove(const VaiMove& move);
  // 040h-045h (decision 606): resolve, then run from the next tick; errors 0062h/0089h.
  void StartCurve(const action::RunCurve& command);
  // One tick of a running curve: the axis gets the piece of the curve this tick covers.
  void StepCurve(double dt_s);
  void FireEvents(double previous_demand_mm);
  void Monitor();
  void Raise(uint16_t code);
  void ResyncAxisToSlider();
  void RefreshVariables();
  linudp::Reply ComposeReply(const linudp::Request& request,
                             const std::optional<linudp::RtcReply>& rtc);

  double actual_mm() const;  // reported frame
  double window_mm() const;
  bool motion_active() const;
  bool in_target() const;
  uint64_t operating_ms() const;

  SimOptions options_;
  Parameters params_;
  StateMachine sm_;
  Interpreter interpreter_;
  RtcChannel rtc_;
  ErrorLog error_log_;
  sim::motion::Axis axis_;
  std::optional<sim::motion::Homing> homing_;
  double slider_mm_ = 0;        // physical slider position (follows the axis unless blocked)
  double slider_velocity_ = 0;  // mm/s

  // Time.
  Duration sim_time_{0};
  Duration remainder_{0};
  bool booting_ = false;
  Duration boot_left_{0};
  bool mc_stopped_ = false;

  // Motion bookkeeping.
  bool homed_ = false;
  int64_t target_ = 0;  // last VAI target, 0.1 um (Increment Target Pos base, §5.0)
  struct Resumable {
    bool infinite = false;
    double target_mm = 0;
    int direction = 1;
    sim::motion::Limits limits;
  };
  std::optional<Resumable> running_;  // the motion a freeze would resume (T16)
  std::optional<Resumable> frozen_;
  std::optional<Resumable> last_vai_;  // the last VAI move started (freeze after a curve, §7)
  std::optional<TimeCurve> curve_;     // the running time curve
  // Event handler (§4.5): one armed command at a time.
  std::optional<VaiMove> after_actual_;  // D-12 one-shot
  std::optional<VaiMove> trigger_move_;  // re-fires on every edge until 008x
  std::optional<action::ChangeOnTransition> transition_;
  bool trigger_level_ = false;

  // Faults and counters.
  uint16_t injected_warnings_ = 0;
  bool blocked_ = false;
  uint64_t mc_executed_ = 0;
  uint64_t mc_rejected_ = 0;
  std::vector<int64_t> started_targets_;
  uint64_t boots_ = 0;
  std::set<uint16_t> unsupported_logged_;
};

}  // namespace drivegw::sim::linmot
