// LinMotDnDevice: the application of a simulated LinMot DeviceNet controller (firmware 1.3):
// D-10 state model, the 102 general-purpose commands, latches and coded errors, Direct Out
// variables and motion on sim/motion. Pure: no I/O, no clock reads; time moves only through
// Advance() (linmot-devicenet.md §7, §8, §12.5).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/commands.h"
#include "sim/linmot_devicenet/io_application.h"
#include "sim/linmot_devicenet/options.h"
#include "sim/linmot_devicenet/snapshot.h"
#include "sim/motion/axis.h"
#include "sim/motion/homing.h"

namespace drivegw::sim::linmot_devicenet {

using dn::Motor;

class LinMotDnDevice final : public IoApplication {
 public:
  // InvalidArgument for bad options (ValidateOptions). Powers up: DISABLE (or initialised and
  // STOPPED with options.initialised), parameters at their defaults, no I/O connection.
  static absl::StatusOr<std::unique_ptr<LinMotDnDevice>> Create(const DnSimOptions& options);

  // Advances simulated time in fixed ticks of options.tick; a remainder shorter than a tick is
  // kept for the next call.
  void Advance(Duration dt);

  // ---- IoApplication (the DeviceNet stack's view) ----
  // Decodes the image with the connection's layout and executes it in image order: Control
  // In, Addressed In, Direct In slots (D-8). A message of the wrong size is ignored (the stack
  // already counts D-24) and answered.
  ConsumeOutcome Consume(IoConnection connection, std::span<const uint8_t> message) override;
  std::vector<uint8_t> Produce(IoConnection connection) override;
  void SetIoConnected(bool connected) override;
  // Latches `code` as the coded error unless one is latched already (D-23); ERROR (D-7).
  void RaiseCodedError(uint16_t code) override;
  void ResetController() override;

  // Decoded images, for device-level tests.
  ConsumeOutcome ConsumeImage(const dn::ConsumedImage& image);
  dn::ProducedImage ProduceImage(IoConnection connection) const;

  // ---- fault injection and inputs (§12.8); causes persist until cleared ----
  // Motor Error State bits (§8.5: too hot calc/sensor, following error, slider missing, init
  // failed, wrong motor type, curve missing); the first error is latched (D-23).
  void SetMotorErrorCause(Motor motor, uint16_t bits);
  // Motor Warn State bits (too hot, following error, slider missing, init position not done,
  // not in position range, not in position).
  void SetMotorWarningCause(Motor motor, uint16_t bits);
  // System Error State bits 0-6 (low capacity, DCLV PWR/SIG low/high, controller hot, MSG).
  void SetSystemErrorCause(uint16_t bits);
  // System Warn State bits 0-5.
  void SetSystemWarningCause(uint16_t bits);
  // The slider stops where it is while the demand goes on: the position error grows into a
  // following error beyond the limits of 0x4C/0x4E.
  void SetMotorBlocked(Motor motor, bool blocked);
  // An external force holds the slider `offset_mm` away from the demand (TC-17).
  void SetDisturbance(Motor motor, double offset_mm);
  // Controller IO inputs, bits 0..9 of the §8.5 word (run/init/freeze/stop inputs, the
  // Analog/Trigger inputs 1-4 that act as the motors' triggers (D-9), Dig In 5/6).
  void SetControllerInputs(uint16_t bits);
  // Extended IO module inputs 7..0 (0x64/0x65).
  void SetExtendedInputs(uint8_t bits);
  // Master encoder 1 counts (0x60).
  void SetEncoderCounts(int32_t counts);
  // Emergency stop: status low bit 5, the controller leaves RUN and RUN cannot be entered.
  void SetEmergencyStop(bool active);
  void SetRunMode(Motor motor, RunMode mode);

  // ---- observation ----
  DeviceSnapshot Snapshot() const;
  uint16_t status_low() const;
  uint16_t status_high() const;
  uint16_t control_word() const { return control_word_; }
  uint16_t coded_error() const { return coded_error_; }
  ControllerState state() const { return state_; }
  bool io_connected() const { return io_connected_; }
  // A per-motor parameter by its Get command ID (§8.9), e.g. 0x4A for In Position +.
  std::optional<int32_t> Parameter(Motor motor, uint8_t get_id) const;
  const sim::motion::Axis& axis(Motor motor) const { return motors_[Index(motor)].axis; }
  const DnSimOptions& options() const { return options_; }
  // Motion log for fault-injection properties: every motion the motor started (set-point moves,
  // relative moves, curves, resumes), target in mm, in order. A retried or duplicated poll
  // that the toggle handshake ignored leaves no entry.
  struct StartedMotion {
    Motor motor = Motor::kA;
    double target_mm = 0;
  };
  const std::vector<StartedMotion>& started_motions() const { return started_motions_; }

 private:
  struct Latch {
    uint16_t system = 0;
    std::optional<Motor> motor;
    uint16_t motor_bits = 0;
    bool active() const { return system != 0 || motor.has_value(); }
  };
  struct Armed {
    uint8_t id = 0;
    int32_t value = 0;
  };
  struct MotorState {
    bool present = false;
    MotorOptions config;
    RunMode run_mode = RunMode::kSerial;
    sim::motion::Axis axis;
    std::optional<sim::motion::Homing> init;  // INIT procedure running
    std::array<int32_t, 128> params{};        // by Get command ID (§8.9)
    int32_t setpoint = 0;                     // increments (0x10)
    double target_mm = 0;                     // target of the last started motion
    uint8_t direct_out_1 = 0;
    uint8_t direct_out_2 = 0;
    bool toggle = false;
    bool curve_done = false;
    std::optional<uint8_t> running_curve;
    std::optional<Armed> armed;
    bool trigger_level = false;
    bool frozen = false;
    std::optional<double> resume_target_mm;  // motion a freeze interrupted
    sim::motion::Limits resume_limits;
    sim::motion::Limits last_limits;  // of the last started motion
    bool blocked = false;
    double blocked_at_mm = 0;
    double disturbance_mm = 0;
    uint16_t error_cause = 0;
    uint16_t warn_cause = 0;
    uint64_t curves_completed = 0;
  };
  // What Execute decided for one slot.
  struct SlotResult {
    int32_t response_value = 0;
    bool reset_controller = false;
  };

  explicit LinMotDnDevice(const DnSimOptions& options);
  static size_t Index(Motor m) { return static_cast<size_t>(m); }
  MotorState& motor(Motor m) { return motors_[Index(m)]; }
  const MotorState& motor(Motor m) const { return motors_[Index(m)]; }

  void PowerUp(bool keep_positions);
  void Tick();
  void ApplyControlWord(uint16_t raw);
  void UpdateTriggers();
  void UpdateFreeze();
  void EvaluateState();
  void EnterRun();
  void LeaveRun();
  void CheckCauses();
  void Raise(uint16_t code);
  SlotResult ExecuteSlot(dn::CommandSlot slot, dn::Module module, std::optional<Motor> slot_motor,
                         std::optional<dn::CommandSlot> previous);
  absl::StatusOr<int32_t> Execute(const dn::DecodedCommand& command, std::optional<Motor> m,
                                  bool* reset_controller);
  absl::Status CheckMotor(const dn::CommandSpec& spec, std::optional<Motor> m) const;
  absl::Status CheckRequirements(const dn::CommandSpec& spec, std::optional<Motor> m,
                                 int32_t value) const;
  absl::Status StartCurve(Motor m, uint8_t number, bool incremental);
  absl::Status MoveToSetpoint(Motor m);
  void StartMotion(Motor m, double target_mm, const sim::motion::Limits& limits);
  void FireTrigger(Motor m);
  sim::motion::Limits FilterLimits(Motor m) const;
  void StopMotor(Motor m);

  double ActualMm(Motor m) const;
  int32_t ToIncrements(double mm) const;
  double ToMm(int32_t increments) const { return increments * kMmPerIncrement; }
  bool FollowingErrorLive(Motor m) const;
  bool InPosition(Motor m) const;
  bool PositionRange(Motor m) const;
  bool AnyFollowingError() const;
  uint16_t DirectOutValue(Motor m, uint8_t code) const;
  uint16_t SystemWarnWord() const;
  uint16_t SystemErrorWord() const;
  uint16_t MotorWarnWord(Motor m) const;
  uint16_t MotorErrorWord(Motor m) const;
  uint16_t ControllerIoWord() const;
  uint16_t ExtendedIoWord() const;
  uint16_t ReportedCodedError() const;
  bool ErrorPending() const { return error_latch_.active() || coded_error_ != 0; }

  DnSimOptions options_;
  dn::IoLayout poll_layout_;
  dn::IoLayout cos_layout_;
  std::array<MotorState, 4> motors_{};
  std::vector<StartedMotion> started_motions_;

  // Time.
  Duration sim_time_{0};
  Duration remainder_{0};

  // Controller.
  ControllerState state_ = ControllerState::kDisable;
  bool init_done_ = false;
  bool io_connected_ = false;
  uint16_t control_word_ = 0;      // last written (Control In or 0x05)
  bool prev_run_request_ = false;  // for the RUN 0 -> 1 edge (seed lines 864, 910)
  bool prev_init_request_ = false;
  bool emergency_stop_ = false;
  Latch warn_latch_;
  Latch error_latch_;
  uint16_t system_error_cause_ = 0;
  uint16_t system_warn_cause_ = 0;
  uint16_t coded_error_ = 0;
  uint16_t controller_inputs_ = 0;   // bits 0..9
  uint16_t controller_outputs_ = 0;  // bits 10..15 as written by 0x0D
  uint8_t extended_inputs_ = 0;
  uint8_t extended_outputs_ = 0;
  int32_t encoder_counts_ = 0;
  int32_t encoder_offset_ = 0;

  // I/O.
  std::optional<dn::CommandSlot> prev_addressed_;
  std::array<std::optional<dn::CommandSlot>, 4> prev_direct_{};
  std::deque<dn::CommandSlot> response_queue_;  // D-5 latency
  dn::CommandSlot addressed_out_{};

  // Counters.
  uint64_t messages_consumed_ = 0;
  uint64_t commands_executed_ = 0;
  std::array<uint64_t, 256> executed_by_id_{};  // per command ID (recovery tests, decision 1451)
  uint64_t coded_errors_raised_ = 0;
  uint64_t toggle_commands_ignored_ = 0;
  uint64_t direct_gets_ignored_ = 0;
  uint64_t controller_resets_ = 0;
};

}  // namespace drivegw::sim::linmot_devicenet
