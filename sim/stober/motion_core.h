// The simulated STOBER motion core (stober-motion.md §1-§4, §8, §9): the 12 MC_* commands
// selected by I401 and started by the rising edge of Execute I402, one status set per axis, the
// denial rules, limits, endless axes, homing, cyclic and torque commands, brake and the CiA 402
// power state machine in front of it. Pure: no I/O, no clock; time moves only through
// Advance() in motion-core cycles A150. Gap choices: docs/decisions/1141-1169.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "sim/motion/profile.h"
#include "sim/stober/cia402.h"
#include "sim/stober/parameters.h"

namespace drivegw::sim::stober {

// Command numbers of I401 (§1.1).
enum class Command : int {
  kDoNothing = 0,
  kMoveAbsolute = 1,
  kMoveRelative = 2,
  kMoveAdditive = 3,
  kMoveVelocity = 4,
  kStop = 5,
  kHome = 6,
  kCyclicSpeed = 7,
  kMoveSpeed = 8,
  kTorqueControl = 9,
  kCyclicPosition = 10,
  kHalt = 11,
};

// PLCopen state I89 (§2.6; 0 = axis disabled, decision 1146 / G-18).
enum class PlcState : int {
  kDisabled = 0,
  kStandstill = 2,
  kDiscreteMotion = 3,
  kContinuousMotion = 4,
  kStopping = 6,
  kErrorStop = 7,
  kHoming = 8,
  kCyclicMotion = 11,
};

// I90 cause codes of the simulator (G-06 [P], decision 1145).
enum class Cause : int {
  kNone = 0,
  kSoftwareLimit = 1,
  kHardwareLimit = 2,
  kPermittedDirection = 3,
  kRevolutionLength = 4,
  kZeroProfileValue = 5,
  kZeroMaximumValue = 6,
  kNotReferenced = 7,
  kNotStandstill = 8,
  kReferencingInactive = 9,
  kStopActive = 10,
  kLimitSwitchFault = 11,
  kEvent78 = 12,
  kNotEnabled = 13,
  kErrorStopActive = 14,
  kZeroPulseNotFound = 15,
};

// Drive events the model raises (§5.7: event 78 "Position limit cyclic" causes 2 and 3).
// number 0: no STOBER event but a CiA 402 reaction (6007h on a lost connection, decision 1483),
// cause = the EMCY code that triggered it.
struct Event {
  uint64_t cycle = 0;
  int number = 0;
  int cause = 0;
  std::string text;
};

// Physics and simulated sensors (§8, G-28); all positions of sensors are machine positions
// (the actual position before any referencing offset).
struct MotionCoreOptions {
  // Start in CiA 402 "Operation enabled" (the §10.1 fixtures) instead of "Not ready to switch on".
  bool start_operation_enabled = false;
  // Following model (§8.1): first-order lag of the actual position behind the set position,
  // time constant in ms; 0 = ideal (the default, §10.1).
  double following_time_constant_ms = 0;
  // Quick stop (G-20): deceleration and jerk; 0 = I11 / I16.
  double quick_stop_deceleration = 0;
  double quick_stop_jerk = 0;
  // Enable-off (G-18, decision 1146): true = the axis is held where it is (brake/short-circuit
  // braking, the default that Table 11 rows 3/6/9 need), false = quick-stop ramp.
  bool enable_off_stops_immediately = true;
  // Hardware limit switches: active at machine position >= positive / <= negative.
  std::optional<double> positive_limit_switch;
  std::optional<double> negative_limit_switch;
  // Reference switch: active inside [first, second] (machine positions).
  std::optional<std::pair<double, double>> reference_switch;
  // Encoder zero pulse every `zero_pulse_spacing` starting at `zero_pulse_offset`.
  double zero_pulse_spacing = 360;
  double zero_pulse_offset = 0;
  // Mechanical end stops (torque/force-stop homing, TorqueControl).
  std::optional<double> positive_end_stop;
  std::optional<double> negative_end_stop;
  // Brake release time (§8.10 [P]): a motion started with the brake engaged waits this long
  // (0 = the brake opens in the start cycle).
  double brake_release_ms = 0;
  // Torque mechanics (§8.9): acceleration per % torque, friction and constant load (in %).
  double acceleration_per_torque = 100;  // u/s² per %
  double viscous_friction = 0;           // % per u/s
  double coulomb_friction = 0;           // %
  double load_torque = 0;                // %, signed
};

class MotionCore {
 public:
  explicit MotionCore(MotionCoreOptions options = {});

  // Parameter access by id, as a CANopen object dictionary binds it (§5, §7.2). Status values
  // reflect the end of the last cycle. Writes are checked against the catalogue: unknown id →
  // NotFound, read-only → FailedPrecondition, range → OutOfRange naming the limit.
  absl::StatusOr<double> Read(ParamId id) const;
  absl::Status Write(ParamId id, double value);

  // Runs `cycles` motion-core cycles of A150 each.
  void Advance(int cycles = 1);
  // The next cycle samples Execute as if it had been low at the previous one: the device's
  // fieldbus input latch (sim/stober/axis_device.h, decision 1182) saw a low level in between.
  void LatchExecuteLow() { previous_execute_ = false; }
  // Motion log for fault-injection properties: the target of every positioning command (1-3)
  // the core started, in order. A repeated Execute edge that started the command again leaves
  // a second entry (a relative move executed twice shows up as two different targets).
  const std::vector<double>& started_targets() const { return started_targets_; }

  // --- Fault injection and simulated inputs -------------------------------------------------
  // Force a limit-switch / reference-switch signal (nullopt = follow the simulated position).
  void ForceLimitSwitch(bool positive, std::optional<bool> active);
  void ForceReferenceSwitch(std::optional<bool> active);
  void SetFollowingTimeConstant(double ms) { options_.following_time_constant_ms = ms; }
  void SetLoadTorque(double percent) { options_.load_torque = percent; }
  // While true, written cyclic set values (I421/I426/I428 and their CiA 402 sources) are lost
  // on the way: the fine interpolator extrapolates and raises event 78/3 after I423.
  void DropCyclicSetValues(bool drop) { drop_cyclic_ = drop; }
  // A drive fault (CiA 402 Fault reaction active → Fault; reset with control word bit 7).
  void InjectFault();
  // The drive's reaction to a lost connection (CiA 402 6007h, decision 1483): 1 fault, 2 disable
  // voltage, 3 quick stop (ramp with the quick-stop deceleration, then Switch on disabled), 0 and
  // others nothing. Recorded in events() as number 0, cause = `emcy_code`, with `reason`.
  void AbortConnection(int option, uint16_t emcy_code, const std::string& reason);
  // Commissioning helpers of the fixtures (§10.1): referenced state and position at rest.
  void SetReferenced(bool referenced);
  void SetActualPosition(double position);

  // --- Observation --------------------------------------------------------------------------
  uint64_t cycle() const { return cycle_; }
  // Rising edges of Execute I402 with a command other than MC_DoNothing since power-up, started,
  // buffered or denied alike: the record the recovery tests read to prove that a master sent no
  // motion command (docs/reliability.md "Safe recovery", decision 1451).
  uint64_t execute_edges() const { return execute_edges_; }
  PowerState power_state() const { return power_.state(); }
  bool brake_engaged() const { return brake_engaged_; }
  double set_acceleration() const { return set_.acceleration; }
  // Unwrapped set / actual position (endless axes report I96/I80 modulo I01).
  double set_position_unwrapped() const { return set_.position; }
  double actual_position_unwrapped() const { return actual_position_; }
  double torque() const { return torque_; }
  const std::vector<Event>& events() const { return events_; }
  // Text of the current I90 cause, naming the rule ("position outside software limits
  // I50..I51"); empty when I91 = 0.
  const std::string& error_text() const { return error_text_; }

 private:
  enum class Drive {
    kRest,            // holding the set position
    kProfile,         // a sim/motion profile (positioning, velocity, stop, halt, homing phases)
    kCyclicTakeover,  // MoveVelocity with I113 = cyclical takeover (no ramps, L859)
    kCyclicSpeed,
    kCyclicPosition,
    kTorque,
  };
  enum class HomingPhase { kSearch, kReturn, kZeroPulse, kStopAfterReference, kToReference, kEnd };
  struct Homing {
    int type = 0;  // I30 values 1..5
    int direction = 1;
    bool zero_pulse = false;
    HomingPhase phase = HomingPhase::kSearch;
    bool was_active = false;
    int blocked_cycles = 0;
    double velocity = 0;  // velocity of the current search phase, before override
    double last_machine = 0;
    double zero_search_start = 0;  // machine position where the zero-pulse search began
  };
  struct Interpolator {  // fine interpolator of the cyclic commands (§8.8)
    double from = 0;
    double to = 0;
    int step = 0;   // cycles of the current segment done
    int steps = 1;  // A291 / A150
    int extrapolated = 0;
    double slope = 0;  // per cycle, for extrapolation
    double value = 0;  // current output
  };

  double Get(const char* id) const;
  double Get(ParamId id) const;
  void Set(const char* id, double value);
  void ApplySourceWrite(ParamId id, double value);
  double dt() const;

  // One cycle, in this order (decision 1142).
  void Step();
  void StepPower();
  void StartCommand(Command command);
  void UpdateContinuousInputs();
  void Integrate();
  void CheckLimitSwitches();
  void StartLimitStop();
  void EvaluateStatus();
  void ArmBrake();
  void Publish();
  static double cmd_sign(double v);

  // Buffered (subsequent) motion blocks, End velocity (motion_core_blocks.cpp; §2.5, G-09,
  // decisions 1161-1163).
  struct BlockInputs {  // the inputs a block latches at its edge (§2.2 L113, L183)
    Command command = Command::kDoNothing;
    double position = 0;      // I403
    double velocity = 0;      // I404
    double acceleration = 0;  // I405
    double deceleration = 0;  // I406
    double jerk = 0;          // I407
    double end_velocity = 0;  // I429
    double direction = 0;     // I411
    double brake_at_end = 0;  // I410
    double motion_id = 0;     // I400
  };
  BlockInputs ReadInputs(Command command) const;
  void WriteInputs(const BlockInputs& in);
  void OnExecuteEdge(Command command);
  bool AcceptsSuccessor() const;
  void BufferBlock(Command command);
  void EndOfBlock(double end_time);
  void TakeOverBuffered(double end_time);
  void PassWithoutSuccessor(double end_time);

  // Starting and stopping (motion_core_commands.cpp).
  std::optional<std::pair<Cause, std::string>> CheckDenial(Command command);
  void StartPositioning(Command command);
  void StartMoveVelocity();
  void StartStopOrHalt(Command command);
  void StartHome();
  void StartCyclic(Command command);
  void StartMoveSpeed();
  void StartTorque();
  void Deny(Cause cause, std::string text);
  void Cancel(Cause cause, std::string text);
  void QuickStop();
  void DropForeignAcceleration();
  void ReleaseBrake();
  void PlanPositioning();
  void PlanVelocity(double velocity, double acceleration, double deceleration, double jerk);
  void PlanMoveSpeed();
  void UpdateMoveSpeed();
  std::optional<std::pair<Cause, std::string>> ComputeTarget(Command command);
  bool SetProfile(absl::StatusOr<motion::Profile> profile);

  // Homing, cyclic, torque (motion_core_modes.cpp).
  void StepHoming();
  void HomingVelocity(double velocity);
  void ReferenceAt(double machine_position);
  void StepCyclicSpeed();
  void StepCyclicPosition();
  void StepTorque();
  void OnCyclicSetValue(double value);
  std::optional<double> Interpolate();
  void ResetInterpolator();

  // Sensors and geometry.
  double MachinePosition() const { return actual_position_ - offset_; }
  bool PositiveLimitActive() const;
  bool NegativeLimitActive() const;
  bool ReferenceSwitchActive() const;
  bool Endless() const { return Get("I00") == 1; }
  double Modulo(double x) const;
  bool SoftwareLimitsUsed() const;
  bool DirectionPermitted(double direction) const;
  bool Moving() const;
  // Velocity override I230 (L357-359); the CiA 402 halt bit A515.8 acts as override 0 while
  // set (G-19 [P], decision 1159).
  double OverrideFactor() const {
    return (control_word_ & cw::kHalt) != 0 ? 0.0 : Get("I230") / 100.0;
  }

  MotionCoreOptions options_;
  PowerStateMachine power_;
  std::map<ParamId, double> values_;
  uint64_t cycle_ = 0;
  uint64_t execute_edges_ = 0;

  // Inputs of the cycle.
  uint16_t control_word_ = 0;
  bool previous_execute_ = false;
  bool was_enabled_ = false;

  // Command and status (§2.3: one status set per axis).
  Command command_ = Command::kDoNothing;
  bool command_active_ = false;   // the latest command runs (not denied, cancelled or disabled)
  bool command_started_ = false;  // any command (other than 0) started since power-up
  uint64_t start_cycle_ = 0;
  bool error_ = false;
  Cause cause_ = Cause::kNone;
  std::string error_text_;
  bool done_ = false;
  bool done_latched_ = false;
  PlcState plc_ = PlcState::kStandstill;
  int window_cycles_ = 0;
  bool profile_done_ = false;          // I85
  bool speed_reached_ = false;         // I183
  bool in_window_ = false;             // I180
  bool standstill_ = true;             // I199
  bool velocity_limited_ = false;      // I190
  bool dynamics_limited_ = false;      // I191
  bool override_limited_ = false;      // I193 (override > 100 % clipped, or direction filter)
  bool position_limited_ = false;      // I192
  bool acceleration_limited_ = false;  // I195
  bool torque_limited_ = false;        // I194
  bool stop_held_by_override_ = false;
  bool brake_at_end_ = false;
  std::optional<int> brake_timer_;  // cycles until the brake engages
  bool brake_engaged_ = true;
  int brake_release_cycles_ = 0;  // motion waits while the brake opens
  bool event78_warning_ = false;

  // Latched set values of the running command.
  double cmd_velocity_ = 0;
  double cmd_acceleration_ = 0;
  double cmd_deceleration_ = 0;
  double cmd_jerk_ = 0;
  double target_ = 0;  // unwrapped target position of 1-3
  double applied_override_ = 1;
  double movespeed_acceleration_ = 0;  // last non-zero cyclic acceleration (L1497)
  double movespeed_deceleration_ = 0;
  double movespeed_target_ = 0;
  bool cyclic_only_at_start_ = false;

  // Motion state.
  Drive drive_ = Drive::kRest;
  motion::Profile profile_;
  double t_ = 0;         // seconds since the profile start
  double ramp_end_ = 0;  // end of the last segment (velocity profiles: ramp finished)
  double velocity_target_ = 0;
  bool limit_stop_ = false;  // quick stop by limit-switch fault inside 7-10 (decision 1153)
  motion::Profile limit_stop_profile_;
  double limit_stop_time_ = 0;
  motion::Kinematics set_;
  double actual_position_ = 0;
  double actual_velocity_ = 0;
  double offset_ = 0;  // user position = machine position + offset (referencing)
  double torque_ = 0;
  bool quick_stopping_ = false;

  // MoveAdditive base (§3.4.6, G-16).
  std::optional<double> last_set_position_;
  std::vector<double> started_targets_;
  bool window_reached_ = false;
  bool window_left_ = false;

  // Buffering and End velocity (decisions 1161-1163).
  std::optional<BlockInputs> buffered_;  // the subsequent block, one deep (I409 = 1)
  double end_velocity_ = 0;              // I429 of the running positioning block
  bool passing_ = false;                 // its profile passes the target (JerkProfile::PlanPass)
  double pass_time_ = 0;                 // profile time of the pass

  Homing homing_;
  Interpolator interp_;
  bool cyclic_fresh_ = false;
  double cyclic_value_ = 0;
  bool drop_cyclic_ = false;
  int limit_blocked_direction_ = 0;  // +1 / -1: set values towards that switch are ignored

  std::optional<bool> forced_positive_limit_;
  std::optional<bool> forced_negative_limit_;
  std::optional<bool> forced_reference_switch_;
  std::vector<Event> events_;
};

}  // namespace drivegw::sim::stober
