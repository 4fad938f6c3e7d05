// LinMotDnDevice: application state, command execution and motion of the simulated LinMot
// DeviceNet controller (linmot-devicenet.md §7, §8, §12.5; decisions 951-954).
#include "sim/linmot_devicenet/device.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

using dn::CommandId;
using dn::Raw;

constexpr int32_t kPosMin = -32256;  // §0.5: ±32256 = ±630 mm
constexpr int32_t kPosMax = 32256;

// Motor Error State "Init Failed" (§8.5).
constexpr uint16_t kErrorInitFailed = 1u << 5;

int32_t ClampI16(double v) {
  if (!std::isfinite(v)) return 0;
  return static_cast<int32_t>(std::clamp(std::lround(v), -32768L, 32767L));
}

uint16_t Word(int32_t v) { return static_cast<uint16_t>(static_cast<int16_t>(ClampI16(v))); }

// Per-motor parameters reachable by a Get/Set pair (§8.9), keyed by the Get ID; Set = Get + 1.
constexpr uint8_t kMotorParameterGets[] = {
    0x24, 0x26, 0x28, 0x2A, 0x2C, 0x30, 0x32, 0x34, 0x36, 0x38, 0x3A, 0x3C, 0x3E, 0x40, 0x42,
    0x44, 0x46, 0x48, 0x4A, 0x4C, 0x4E, 0x50, 0x52, 0x56, 0x58, 0x5A, 0x5C, 0x62, 0x6A};

bool IsMotorParameterGet(uint8_t id) {
  return std::find(std::begin(kMotorParameterGets), std::end(kMotorParameterGets), id) !=
         std::end(kMotorParameterGets);
}

absl::Status Coded(uint16_t code, const std::string& message) {
  absl::Status s = absl::FailedPreconditionError(message);
  dn::AttachCodedError(s, code);
  return s;
}

}  // namespace

absl::StatusOr<std::unique_ptr<LinMotDnDevice>> LinMotDnDevice::Create(
    const DnSimOptions& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  std::unique_ptr<LinMotDnDevice> d(new LinMotDnDevice(options));
  d->PowerUp(/*keep_positions=*/false);
  return d;
}

LinMotDnDevice::LinMotDnDevice(const DnSimOptions& options)
    : options_(options), poll_layout_(PollLayout(options)), cos_layout_(CosLayout(options)) {}

// Power-up (creation, 0x0F, identity Reset): D-29 volatile parameters back to their defaults,
// the sliders stay where they physically are; injected causes (external conditions) persist.
void LinMotDnDevice::PowerUp(bool keep_positions) {
  for (size_t i = 0; i < 4; ++i) {
    MotorState& m = motors_[i];
    const MotorOptions cfg = options_.motors[i];
    const double position =
        keep_positions && m.present ? m.axis.physical_position() : cfg.initial_position_mm;
    MotorState fresh;
    fresh.present = i < options_.motor_count;
    fresh.config = cfg;
    fresh.run_mode = cfg.run_mode;
    sim::motion::AxisConfig axis_config;
    axis_config.min_position_mm = cfg.stroke_min_mm;
    axis_config.max_position_mm = cfg.stroke_max_mm;
    axis_config.lag_time_constant_s = options_.lag_time_constant_s;
    auto axis = sim::motion::Axis::Create(axis_config, position);
    fresh.axis = axis.ok() ? *std::move(axis) : sim::motion::Axis();
    // §8.9 defaults (project values; the seed gives none). Positions in increments.
    auto& p = fresh.params;
    p[0x24] = 0;                                                     // rise curve
    p[0x26] = 1;                                                     // fall curve
    p[0x28] = 0;                                                     // curve offset
    p[0x2A] = 4096;                                                  // curve amplitude 100 %
    p[0x2C] = 4096;                                                  // curve speed 100 %
    p[0x30] = options_.series == ControllerSeries::k100 ? 64 : 128;  // 1.5 A / 3 A
    p[0x32] = 0;
    p[0x34] = 1000;  // P
    p[0x36] = 100;   // D
    p[0x38] = 0;     // I
    p[0x3A] = 0;
    p[0x3C] = 0;
    p[0x3E] = 0;
    p[0x40] = std::clamp(ClampI16(cfg.stroke_min_mm * 51.2), kPosMin, kPosMax);  // min position
    p[0x42] = std::clamp(ClampI16(cfg.stroke_max_mm * 51.2), kPosMin, kPosMax);  // max position
    p[0x44] = p[0x40];                                                           // pos range min
    p[0x46] = p[0x42];                                                           // pos range max
    p[0x48] = 10;    // in position -  (0.195 mm)
    p[0x4A] = 10;    // in position +
    p[0x4C] = 256;   // following error - (5 mm)
    p[0x4E] = 256;   // following error +
    p[0x50] = 5243;  // filter max speed ≈ 1 m/s
    p[0x52] = 42;    // filter max acceleration ≈ 10 m/s²
    p[0x56] = 0;     // 0 V position
    p[0x58] = 5120;  // 10 V position
    p[0x5A] = 0;     // '0' position
    p[0x5C] = 5120;  // '1' position
    p[0x62] = 1000;  // CAM length
    p[0x6A] = 0;     // CAM delay
    fresh.setpoint = ToIncrements(position);
    fresh.target_mm = position;
    fresh.direct_out_1 = cfg.direct_out_1;
    fresh.direct_out_2 = cfg.direct_out_2;
    // External conditions survive a controller reset.
    fresh.blocked = m.blocked;
    fresh.blocked_at_mm = position;
    fresh.disturbance_mm = m.disturbance_mm;
    fresh.error_cause = m.error_cause;
    fresh.warn_cause = m.warn_cause;
    m = std::move(fresh);
  }
  init_done_ = options_.initialised;
  state_ = init_done_ ? ControllerState::kStopped : ControllerState::kDisable;
  control_word_ = 0;
  prev_run_request_ = prev_init_request_ = false;
  warn_latch_ = Latch{};
  error_latch_ = Latch{};
  coded_error_ = 0;
  controller_outputs_ = 0;
  extended_outputs_ = 0;
  encoder_offset_ = 0;
  prev_addressed_.reset();
  prev_direct_.fill(std::nullopt);
  response_queue_.clear();
  addressed_out_ = dn::CommandSlot{};
  CheckCauses();
  EvaluateState();
}

// ---------------------------------------------------------------------------------------------
// Time.

void LinMotDnDevice::Advance(Duration dt) {
  if (dt <= Duration{0}) return;
  remainder_ += dt;
  while (remainder_ >= options_.tick) {
    remainder_ -= options_.tick;
    Tick();
  }
}

void LinMotDnDevice::Tick() {
  const double dt = ToSeconds(options_.tick);
  for (size_t i = 0; i < options_.motor_count; ++i) {
    MotorState& m = motors_[i];
    if (m.init) {
      m.init->Advance(m.axis, dt);
      if (m.init->phase() == sim::motion::HomingPhase::kDone) {
        m.init.reset();
        m.setpoint = ToIncrements(m.axis.demand().position);
        m.target_mm = m.axis.demand().position;
      } else if (m.init->phase() == sim::motion::HomingPhase::kAborted) {
        m.init.reset();
        m.error_cause |= kErrorInitFailed;  // §8.5 Motor Error "Init Failed"
      }
    } else {
      m.axis.Advance(dt);
    }
    if (!m.blocked) m.blocked_at_mm = m.axis.actual().position;
    // §7.4: Curve Done toggles each time a curve ends on the motor.
    if (m.running_curve && !m.frozen && !m.axis.motion_active()) {
      m.running_curve.reset();
      m.curve_done = !m.curve_done;
      ++m.curves_completed;
    }
  }
  if (state_ == ControllerState::kInit) {
    bool all = true;
    for (size_t i = 0; i < options_.motor_count; ++i) all = all && !motors_[i].init;
    if (all) {
      init_done_ = true;
      state_ = ControllerState::kStopped;
    }
  }
  sim_time_ += options_.tick;
  CheckCauses();
  EvaluateState();
}

// ---------------------------------------------------------------------------------------------
// State model (D-10, decision 951).

void LinMotDnDevice::ApplyControlWord(uint16_t raw) {
  control_word_ = raw;
  const dn::ControlWord cw{raw};
  const bool run = cw.run_request();
  const bool init = cw.init_request();
  EvaluateState();
  if (init && !prev_init_request_ && !cw.stop_request() && !ErrorPending() && !emergency_stop_ &&
      (state_ == ControllerState::kDisable || state_ == ControllerState::kStopped)) {
    state_ = ControllerState::kInit;
    for (size_t i = 0; i < options_.motor_count; ++i) {
      MotorState& m = motors_[i];
      sim::motion::HomingConfig hc;
      hc.method = sim::motion::HomingMethod::kMoveToFeature;
      hc.limits = {m.config.init_velocity_mm_s, m.config.init_acceleration_mm_s2,
                   m.config.init_acceleration_mm_s2};
      hc.feature_position_mm = m.config.init_position_mm;
      hc.home_position_mm = m.config.init_position_mm;
      auto homing = sim::motion::Homing::Create(hc);
      if (!homing.ok()) continue;
      m.running_curve.reset();
      m.resume_target_mm.reset();
      if (homing->Start(m.axis).ok()) m.init = *std::move(homing);
    }
  }
  // Seed lines 864, 910: RUN only on a 0 -> 1 edge of the RUN request.
  if (run && !prev_run_request_ && state_ == ControllerState::kStopped && init_done_ &&
      !cw.stop_request() && !ErrorPending() && !emergency_stop_ &&
      (io_connected_ || !options_.run_requires_io_connection)) {
    EnterRun();
  }
  prev_run_request_ = run;
  prev_init_request_ = init;
  UpdateTriggers();
  UpdateFreeze();
}

void LinMotDnDevice::EvaluateState() {
  const dn::ControlWord cw{control_word_};
  auto abort_init = [&] {
    for (size_t i = 0; i < options_.motor_count; ++i) {
      MotorState& m = motors_[i];
      if (m.init) {
        m.init->Abort(m.axis, FilterLimits(static_cast<Motor>(i)).deceleration);
        m.init.reset();
      }
    }
  };
  if (ErrorPending()) {
    if (state_ == ControllerState::kRun) LeaveRun();
    if (state_ == ControllerState::kInit) abort_init();
    state_ = ControllerState::kError;
    return;
  }
  if (state_ == ControllerState::kError) {
    state_ = init_done_ ? ControllerState::kStopped : ControllerState::kDisable;
  }
  const bool stop = cw.stop_request() || emergency_stop_;
  if (state_ == ControllerState::kInit && stop) {
    abort_init();
    state_ = init_done_ ? ControllerState::kStopped : ControllerState::kDisable;
  }
  if (state_ == ControllerState::kRun && (stop || !cw.run_request())) {
    LeaveRun();
    state_ = ControllerState::kStopped;
  }
}

void LinMotDnDevice::EnterRun() {
  state_ = ControllerState::kRun;
  // Decision 951: entering RUN holds the motors where they are (no jump to a stale set-point).
  for (size_t i = 0; i < options_.motor_count; ++i) {
    MotorState& m = motors_[i];
    m.setpoint = ToIncrements(m.axis.demand().position);
    m.target_mm = m.axis.demand().position;
    m.resume_target_mm.reset();
  }
}

void LinMotDnDevice::LeaveRun() {
  for (size_t i = 0; i < options_.motor_count; ++i) {
    StopMotor(static_cast<Motor>(i));
    motors_[i].running_curve.reset();  // an interrupted curve never reports Curve Done
    motors_[i].resume_target_mm.reset();
  }
}

void LinMotDnDevice::StopMotor(Motor mo) {
  MotorState& m = motor(mo);
  if (!m.axis.motion_active()) return;
  (void)m.axis.Stop(FilterLimits(mo).deceleration, sim::motion::ZeroLimits::kHoldPosition);
  m.target_mm = m.axis.target();
}

// D-9: a motor's trigger is the rising edge of (control word bit 8+k OR Analog/Trigger input k).
void LinMotDnDevice::UpdateTriggers() {
  const dn::ControlWord cw{control_word_};
  for (size_t i = 0; i < options_.motor_count; ++i) {
    const Motor mo = static_cast<Motor>(i);
    MotorState& m = motors_[i];
    const bool level = cw.trigger(mo) || ((controller_inputs_ >> (4 + i)) & 1u) != 0;
    if (level && !m.trigger_level) {
      m.trigger_level = true;
      FireTrigger(mo);
    }
    m.trigger_level = level;
  }
}

// FREEZE request (bit 4) or per-motor freeze (bits 12-15, seed line 351): the motion is held
// and resumed when the freeze ends (decision 951).
void LinMotDnDevice::UpdateFreeze() {
  const dn::ControlWord cw{control_word_};
  for (size_t i = 0; i < options_.motor_count; ++i) {
    const Motor mo = static_cast<Motor>(i);
    MotorState& m = motors_[i];
    const bool f = cw.freeze_request() || cw.freeze_motor(mo);
    if (f && !m.frozen) {
      m.frozen = true;
      if (m.axis.motion_active()) {
        m.resume_target_mm = m.target_mm;
        m.resume_limits = m.last_limits;  // a curve resumes with its own limits
        StopMotor(mo);
      }
    } else if (!f && m.frozen) {
      m.frozen = false;
      if (m.resume_target_mm && state_ == ControllerState::kRun) {
        const double target = *m.resume_target_mm;
        const auto curve = m.running_curve;
        StartMotion(mo, target, m.resume_limits);
        m.running_curve = curve;
      }
      m.resume_target_mm.reset();
    }
  }
}

void LinMotDnDevice::FireTrigger(Motor mo) {
  MotorState& m = motor(mo);
  if (!m.armed) return;
  const Armed a = *m.armed;
  absl::Status s;
  switch (a.id) {
    case Raw(CommandId::kSetPositionSetpointWaitingForTrigger):
      m.armed.reset();
      m.setpoint = std::clamp(a.value, m.params[0x40], m.params[0x42]);
      s = MoveToSetpoint(mo);
      break;
    case Raw(CommandId::kIncrementPositionSetpointWaitingForTrigger):
      m.armed.reset();
      m.setpoint = std::clamp(m.setpoint + a.value, m.params[0x40], m.params[0x42]);
      s = MoveToSetpoint(mo);
      break;
    case Raw(CommandId::kStartCurveWaitingForTrigger):
      // Seed line 1272: restarted on every trigger; stays armed.
      s = StartCurve(mo, static_cast<uint8_t>(a.value), false);
      break;
    case Raw(CommandId::kStartCurveIncrementalWaitingForTrigger):
      s = StartCurve(mo, static_cast<uint8_t>(a.value), true);
      break;
    default:
      m.armed.reset();
  }
  if (!s.ok()) {
    if (auto code = dn::GetCodedError(s)) Raise(*code);
  }
}

// ---------------------------------------------------------------------------------------------
// Errors and warnings (§8.5, §8.6, D-7, D-23).

void LinMotDnDevice::Raise(uint16_t code) {
  ++coded_errors_raised_;
  if (coded_error_ == 0) {
    coded_error_ = code;
    log::Debug("linmot_dn_sim.coded_error",
               log::Fields().Add("drive", options_.name).Add("code", dn::CodedErrorText(code)));
  }
  EvaluateState();
}

void LinMotDnDevice::RaiseCodedError(uint16_t code) { Raise(code); }

// D-23: the first cause is latched until reset; later causes are not added; a cause that
// persists re-latches after the reset.
void LinMotDnDevice::CheckCauses() {
  if (!error_latch_.active()) {
    if (system_error_cause_ != 0) {
      error_latch_.system = system_error_cause_ & 0x007F;
    } else {
      for (size_t i = 0; i < options_.motor_count; ++i) {
        const Motor mo = static_cast<Motor>(i);
        uint16_t bits = motors_[i].error_cause;
        if (FollowingErrorLive(mo)) bits |= dn::kMotorFollowingError;
        if (bits != 0) {
          error_latch_.motor = mo;
          error_latch_.motor_bits = bits;
          break;
        }
      }
    }
  }
  if (!warn_latch_.active()) {
    if (system_warn_cause_ != 0) {
      warn_latch_.system = system_warn_cause_ & 0x003F;
    } else {
      for (size_t i = 0; i < options_.motor_count; ++i) {
        if (motors_[i].warn_cause != 0) {
          warn_latch_.motor = static_cast<Motor>(i);
          warn_latch_.motor_bits = motors_[i].warn_cause;
          break;
        }
      }
    }
  }
}

uint16_t LinMotDnDevice::SystemWarnWord() const {
  uint16_t w = warn_latch_.system;
  if (warn_latch_.motor) w |= static_cast<uint16_t>(1u << (12 + Index(*warn_latch_.motor)));
  return w;
}

uint16_t LinMotDnDevice::SystemErrorWord() const {
  uint16_t w = error_latch_.system;
  if (error_latch_.motor) w |= static_cast<uint16_t>(1u << (12 + Index(*error_latch_.motor)));
  if (coded_error_ != 0) w |= dn::kSystemErrorCodedError;  // seed line 847
  return w;
}

uint16_t LinMotDnDevice::MotorWarnWord(Motor m) const {
  return warn_latch_.motor == m ? warn_latch_.motor_bits : 0;
}

uint16_t LinMotDnDevice::MotorErrorWord(Motor m) const {
  return error_latch_.motor == m ? error_latch_.motor_bits : 0;
}

// D-2: the hexadecimal reading is the default; the decimal alternative reports "8108" as 8108.
uint16_t LinMotDnDevice::ReportedCodedError() const {
  if (!options_.coded_errors_decimal || coded_error_ == 0) return coded_error_;
  uint32_t decimal = 0;
  for (int shift = 12; shift >= 0; shift -= 4) {
    decimal = decimal * 10 + std::min<uint32_t>((coded_error_ >> shift) & 0xF, 9);
  }
  return static_cast<uint16_t>(decimal);
}

// ---------------------------------------------------------------------------------------------
// Motion helpers.

int32_t LinMotDnDevice::ToIncrements(double mm) const { return ClampI16(mm * 51.2); }

double LinMotDnDevice::ActualMm(Motor mo) const {
  const MotorState& m = motor(mo);
  const double base = m.blocked ? m.blocked_at_mm : m.axis.actual().position;
  return base + m.disturbance_mm;
}

// Filter Max Speed / Max Acceleration (0x50-0x53, §0.5 units), capped by the motor.
sim::motion::Limits LinMotDnDevice::FilterLimits(Motor mo) const {
  const MotorState& m = motor(mo);
  const double v = std::min(m.params[0x50] * kMmSPerSpeedIncrement, m.config.max_velocity_mm_s);
  const double a = std::max(m.params[0x52], 1) * kMmS2PerAccIncrement;
  return {std::max(v, 1e-3), a, a};
}

void LinMotDnDevice::StartMotion(Motor mo, double target_mm, const sim::motion::Limits& limits) {
  MotorState& m = motor(mo);
  m.target_mm = target_mm;
  m.last_limits = limits;
  m.running_curve.reset();
  if (m.frozen) {
    m.resume_target_mm = target_mm;
    m.resume_limits = limits;
    return;
  }
  if (m.axis
          .MoveTo(target_mm, limits, sim::motion::StartFrom::kDemand,
                  sim::motion::ZeroLimits::kHoldPosition)
          .ok()) {
    started_motions_.push_back({mo, target_mm});
  }
}

// Serial-mode position control: outside RUN the set-point is stored, the motor does not move.
absl::Status LinMotDnDevice::MoveToSetpoint(Motor mo) {
  MotorState& m = motor(mo);
  if (state_ != ControllerState::kRun) return absl::OkStatus();
  StartMotion(mo, ToMm(m.setpoint), FilterLimits(mo));
  return absl::OkStatus();
}

// Decision 953: a curve runs as a VA move to offset + amplitude x end point (absolute) or to
// demand + amplitude x end point (incremental), at the curve's speed scaled by Curve Speed.
absl::Status LinMotDnDevice::StartCurve(Motor mo, uint8_t number, bool incremental) {
  MotorState& m = motor(mo);
  const CurveOptions* curve = nullptr;
  for (const CurveOptions& c : options_.curves) {
    if (c.number == number) curve = &c;
  }
  if (curve == nullptr) {
    return Coded(dn::kCodedCurveMissing, absl::StrCat("curve ", number, " does not exist"));
  }
  if (incremental && curve->start != 0) {
    return Coded(dn::kCodedCurveTypeMismatch,
                 absl::StrCat("curve ", number, " starts at ", curve->start, ", not 0"));
  }
  if (state_ != ControllerState::kRun) return absl::OkStatus();
  const double amplitude = m.params[0x2A] / 4096.0;
  const double speed = m.params[0x2C] / 4096.0;
  const double base = incremental ? m.axis.demand().position : ToMm(m.params[0x28]);
  const double target = base + ToMm(curve->end) * amplitude;
  sim::motion::Limits limits{std::min(curve->velocity_mm_s * speed, m.config.max_velocity_mm_s),
                             curve->acceleration_mm_s2 * speed * speed,
                             curve->acceleration_mm_s2 * speed * speed};
  StartMotion(mo, target, limits);
  m.running_curve = number;
  m.setpoint = ToIncrements(target);
  return absl::OkStatus();
}

bool LinMotDnDevice::FollowingErrorLive(Motor mo) const {
  const MotorState& m = motor(mo);
  if (!m.present) return false;
  const double error_inc = (m.axis.demand().position - ActualMm(mo)) * 51.2;
  return error_inc > m.params[0x4E] || -error_inc > m.params[0x4C];
}

bool LinMotDnDevice::AnyFollowingError() const {
  for (size_t i = 0; i < options_.motor_count; ++i) {
    if (FollowingErrorLive(static_cast<Motor>(i)) ||
        (MotorErrorWord(static_cast<Motor>(i)) & dn::kMotorFollowingError) != 0) {
      return true;
    }
  }
  return false;
}

// §7.4 line 440: within [target - In Position -, target + In Position +] after the profile.
bool LinMotDnDevice::InPosition(Motor mo) const {
  const MotorState& m = motor(mo);
  if (!m.present || m.axis.motion_active() || m.init) return false;
  const double d = (ActualMm(mo) - m.target_mm) * 51.2;
  return d <= m.params[0x4A] && -d <= m.params[0x48];
}

bool LinMotDnDevice::PositionRange(Motor mo) const {
  const MotorState& m = motor(mo);
  if (!m.present) return false;
  const double p = ActualMm(mo) * 51.2;
  return p >= m.params[0x44] && p <= m.params[0x46];
}

// §6.2 codes; D-21 scaling of 4-7 (raw increments of the filter and current units).
uint16_t LinMotDnDevice::DirectOutValue(Motor mo, uint8_t code) const {
  const MotorState& m = motor(mo);
  const double actual_mm = ActualMm(mo);
  const auto& demand = m.axis.demand();
  const double actual_v = m.blocked ? 0.0 : m.axis.actual().velocity;
  switch (static_cast<dn::DirectOutVariable>(code)) {
    case dn::DirectOutVariable::kActualPos:
      return Word(ClampI16(actual_mm * 51.2));
    case dn::DirectOutVariable::kDemandPos:
      return Word(ClampI16(demand.position * 51.2));
    case dn::DirectOutVariable::kPositionError:
      return Word(ClampI16((demand.position - actual_mm) * 51.2));
    case dn::DirectOutVariable::kDemPosUnfiltered:
      return Word(ClampI16(m.target_mm * 51.2));
    case dn::DirectOutVariable::kActualSpeed:
      return Word(ClampI16(actual_v / kMmSPerSpeedIncrement));
    case dn::DirectOutVariable::kDemandSpeed:
      return Word(ClampI16(demand.velocity / kMmSPerSpeedIncrement));
    case dn::DirectOutVariable::kDemandAcc:
      return Word(ClampI16(demand.acceleration / kMmS2PerAccIncrement));
    case dn::DirectOutVariable::kCurrent: {
      const double amps =
          options_.moving_mass_kg * demand.acceleration / 1000.0 / options_.force_constant_n_per_a;
      return Word(ClampI16(amps / kAmpPerCurrentIncrement));
    }
  }
  return 0;
}

// §8.5 Controller IO word: inputs 0..9 from the hardware, outputs 10..15 either their software
// function (sw_assigned_outputs) or what 0x0D wrote (seed lines 952, 963).
uint16_t LinMotDnDevice::ControllerIoWord() const {
  uint16_t functions = 0;
  if (warn_latch_.active()) functions |= 1u << 10;  // Warn out
  if (ErrorPending()) functions |= 1u << 11;        // Error out
  if (AnyFollowingError()) functions |= 1u << 12;   // Pos error out
  const uint16_t assigned = options_.sw_assigned_outputs & dn::kControllerIoOutputMask;
  return static_cast<uint16_t>((controller_inputs_ & 0x03FF) | (functions & assigned) |
                               (controller_outputs_ & ~assigned & dn::kControllerIoOutputMask));
}

uint16_t LinMotDnDevice::ExtendedIoWord() const {
  return static_cast<uint16_t>((extended_outputs_ << 8) | extended_inputs_);
}

// ---------------------------------------------------------------------------------------------
// Status words (§7.4).

uint16_t LinMotDnDevice::status_low() const {
  dn::StatusLowWord w;
  using SL = dn::StatusLowWord;
  w = w.With(SL::kInitDone, init_done_);
  w = w.With(SL::kRunState, state_ == ControllerState::kRun);
  w = w.With(SL::kErrorState, state_ == ControllerState::kError);
  w = w.With(SL::kInitState, state_ == ControllerState::kInit);
  w = w.With(SL::kDisableState, state_ == ControllerState::kDisable);
  w = w.With(SL::kEmergencyStop, emergency_stop_);
  w = w.With(SL::kErrorPending, ErrorPending());
  w = w.With(SL::kWarningPending, warn_latch_.active());
  for (size_t i = 0; i < options_.motor_count; ++i) {
    const Motor mo = static_cast<Motor>(i);
    w = w.With(static_cast<uint16_t>(SL::kCurveDoneA << i), motors_[i].curve_done);
    w = w.With(static_cast<uint16_t>(SL::kInPositionA << i), InPosition(mo));
  }
  return w.raw;
}

uint16_t LinMotDnDevice::status_high() const {
  dn::StatusHighWord w;
  using SH = dn::StatusHighWord;
  for (size_t i = 0; i < options_.motor_count; ++i) {
    const Motor mo = static_cast<Motor>(i);
    const MotorState& m = motors_[i];
    const bool fe = FollowingErrorLive(mo) || (MotorErrorWord(mo) & dn::kMotorFollowingError) != 0;
    const uint16_t hot = dn::kMotorTooHotCalc | dn::kMotorTooHotSensor;
    w = w.With(SH::Bit(mo, SH::kFollowingError), fe);
    w = w.With(SH::Bit(mo, SH::kPositionRange), PositionRange(mo));
    w = w.With(SH::Bit(mo, SH::kOverTemperature), ((m.error_cause | m.warn_cause) & hot) != 0);
    w = w.With(SH::Bit(mo, SH::kCommandToggle), m.toggle);
  }
  return w.raw;
}

// ---------------------------------------------------------------------------------------------
// I/O images.

void LinMotDnDevice::SetIoConnected(bool connected) {
  if (io_connected_ && !connected && options_.io_loss_reaction == IoLossReaction::kReleaseRun) {
    // D-15: the control word is treated as 0x0000 (RUN request released); no coded error.
    ApplyControlWord(0);
  }
  io_connected_ = connected;
}

ConsumeOutcome LinMotDnDevice::Consume(IoConnection connection, std::span<const uint8_t> message) {
  const dn::IoLayout& layout = connection == IoConnection::kPoll ? poll_layout_ : cos_layout_;
  auto image = dn::DecodeConsumed(layout, message);
  if (!image.ok()) return ConsumeOutcome::kRespond;  // D-24 is the stack's; nothing to execute
  return ConsumeImage(*image);
}

ConsumeOutcome LinMotDnDevice::ConsumeImage(const dn::ConsumedImage& image) {
  ++messages_consumed_;
  bool reset = false;
  // D-8: image order Control In, Addressed In, Direct In slots; last writer wins.
  if (image.control) ApplyControlWord(image.control->raw);
  if (image.addressed) {
    const std::optional<dn::CommandSlot> previous = prev_addressed_;
    prev_addressed_ = *image.addressed;
    SlotResult r = ExecuteSlot(*image.addressed, dn::Module::kAddressed, std::nullopt, previous);
    reset = reset || r.reset_controller;
  }
  const std::vector<Motor> masters = dn::MasterDrives(poll_layout_);
  for (size_t s = 0; s < image.direct.size() && s < masters.size(); ++s) {
    const std::optional<dn::CommandSlot> previous = prev_direct_[s];
    prev_direct_[s] = image.direct[s];
    SlotResult r = ExecuteSlot(image.direct[s], dn::Module::kDirect, masters[s], previous);
    reset = reset || r.reset_controller;
  }
  CheckCauses();
  EvaluateState();
  if (reset) {
    ResetController();
    return ConsumeOutcome::kResetController;
  }
  return ConsumeOutcome::kRespond;
}

void LinMotDnDevice::ResetController() {
  ++controller_resets_;
  log::Info("linmot_dn_sim.controller_reset", log::Fields().Add("drive", options_.name));
  io_connected_ = false;
  PowerUp(/*keep_positions=*/true);
}

dn::ProducedImage LinMotDnDevice::ProduceImage(IoConnection connection) const {
  const dn::IoLayout& layout = connection == IoConnection::kPoll ? poll_layout_ : cos_layout_;
  dn::ProducedImage out;
  if (layout.modules.status_out) {
    out.status_low = dn::StatusLowWord{status_low()};
    out.status_high = dn::StatusHighWord{status_high()};
  }
  if (layout.modules.addressed_out) out.addressed = addressed_out_;
  if (layout.modules.direct_out_1 || layout.modules.direct_out_2) {
    for (Motor mo : dn::MasterDrives(layout)) {
      dn::DirectOut d;
      if (layout.modules.direct_out_1) d.out_1 = DirectOutValue(mo, motor(mo).direct_out_1);
      if (layout.modules.direct_out_2) d.out_2 = DirectOutValue(mo, motor(mo).direct_out_2);
      out.direct.push_back(d);
    }
  }
  return out;
}

std::vector<uint8_t> LinMotDnDevice::Produce(IoConnection connection) {
  const dn::IoLayout& layout = connection == IoConnection::kPoll ? poll_layout_ : cos_layout_;
  auto bytes = dn::EncodeProduced(layout, ProduceImage(connection));
  if (!bytes.ok()) {
    log::Error("linmot_dn_sim.produce_failed",
               log::Fields().Add("drive", options_.name).Add("error", bytes.status().message()));
    return std::vector<uint8_t>(dn::ProducedSize(layout), 0);
  }
  return *std::move(bytes);
}

// ---------------------------------------------------------------------------------------------
// Commands (§8.2-§8.4, D-4, D-6, D-7, D-18-D-20).

LinMotDnDevice::SlotResult LinMotDnDevice::ExecuteSlot(dn::CommandSlot slot, dn::Module module,
                                                       std::optional<Motor> slot_motor,
                                                       std::optional<dn::CommandSlot> previous) {
  SlotResult result;
  const bool addressed = module == dn::Module::kAddressed;
  const bool changed = !previous || *previous != slot;
  auto respond = [&](int32_t value, const dn::DecodedCommand* decoded) {
    if (!addressed) return;
    dn::CommandSlot out{slot.word, 0};
    if (decoded != nullptr) {
      auto encoded = dn::EncodeResponse(*decoded, value);
      if (encoded.ok()) out = *encoded;
    }
    response_queue_.push_back(out);
    while (response_queue_.size() > static_cast<size_t>(options_.response_latency_cycles)) {
      addressed_out_ = response_queue_.front();
      response_queue_.pop_front();
    }
  };
  auto fail = [&](const absl::Status& s) {
    if (auto code = dn::GetCodedError(s)) {
      Raise(*code);
    } else {
      log::Error("linmot_dn_sim.internal",
                 log::Fields().Add("drive", options_.name).Add("error", s.message()));
    }
    respond(0, nullptr);  // D-7: echo, value 0x0000
  };

  auto decoded = dn::DecodeCommand(slot, module);
  if (!decoded.ok()) {
    fail(decoded.status());
    return result;
  }
  const dn::CommandSpec& spec = *decoded->spec;
  std::optional<Motor> m = addressed ? decoded->motor : slot_motor;
  // D-20: a Get in a Direct slot is ignored and counted.
  if (!addressed && spec.kind == dn::CommandKind::kGet) {
    ++direct_gets_ignored_;
    return result;
  }
  if (spec.id == Raw(CommandId::kNoCommand)) {
    respond(0, &*decoded);
    return result;
  }
  // D-6: motor select bits on a system command name no drive the command can act on.
  if (addressed && spec.motor_select == dn::MotorSelect::kSystem && decoded->word.motor_mask != 0) {
    fail(Coded(dn::kCodedDriveNotSpecified,
               absl::StrCat(spec.key(), ": motor select on a system command")));
    return result;
  }
  if (!spec.documented) {
    // D-19: echo without effect (option: 0x8108).
    if (options_.undocumented_commands_error) {
      fail(Coded(dn::kCodedUnknownCommand, absl::StrCat(spec.key(), ": undocumented (D-19)")));
    } else {
      log::Debug("linmot_dn_sim.undocumented_command",
                 log::Fields().Add("drive", options_.name).Add("id", static_cast<int>(spec.id)));
      respond(decoded->value, &*decoded);
    }
    return result;
  }
  if (absl::Status s = CheckMotor(spec, m); !s.ok()) {
    fail(s);
    return result;
  }
  // D-4 rule 1: a T-command executes only when T differs from the motor's Command Toggle, which
  // then takes T (before the command's own checks, so the master sees the toggle and the error).
  if (spec.toggle) {
    MotorState& ms = motor(*m);
    if (decoded->word.toggle == ms.toggle) {
      ++toggle_commands_ignored_;
      respond(decoded->value, &*decoded);  // D-4 rule 3: still echoed
      return result;
    }
    ms.toggle = decoded->word.toggle;
  } else if (spec.trigger_armed && !changed) {
    respond(decoded->value, &*decoded);  // D-4 rule 2: armed only by a new word/value
    return result;
  } else if (options_.x_commands_edge_triggered && !changed && spec.kind != dn::CommandKind::kGet) {
    respond(decoded->value, &*decoded);  // D-4 alternative
    return result;
  }
  if (absl::Status s = CheckRequirements(spec, m, decoded->value); !s.ok()) {
    fail(s);
    return result;
  }
  bool reset = false;
  auto value = Execute(*decoded, m, &reset);
  if (!value.ok()) {
    fail(value.status());
    return result;
  }
  ++commands_executed_;
  ++executed_by_id_[spec.id];
  if (reset) {
    result.reset_controller = true;  // seed line 984: no response at all
    return result;
  }
  respond(*value, &*decoded);
  return result;
}

absl::Status LinMotDnDevice::CheckMotor(const dn::CommandSpec& spec, std::optional<Motor> m) const {
  if (spec.motor_select == dn::MotorSelect::kSystem) return absl::OkStatus();
  if (!m) {
    if (spec.motor_select == dn::MotorSelect::kRequired) {
      return Coded(dn::kCodedDriveNotSpecified, absl::StrCat(spec.key(), ": no motor selected"));
    }
    return absl::OkStatus();
  }
  if (Index(*m) >= options_.motor_count) {
    return Coded(dn::kCodedDriveNotSpecified,
                 absl::StrCat(spec.key(), ": motor ", dn::MotorName(*m), " does not exist"));
  }
  if (spec.motor_select == dn::MotorSelect::kRequired && !motor(*m).config.master) {
    return Coded(dn::kCodedDriveNotMaster,
                 absl::StrCat(spec.key(), ": motor ", dn::MotorName(*m), " is not a master"));
  }
  return absl::OkStatus();
}

absl::Status LinMotDnDevice::CheckRequirements(const dn::CommandSpec& spec, std::optional<Motor> m,
                                               int32_t value) const {
  if (spec.requirement == dn::Requirement::kMasterEncoder && !options_.master_encoder_module) {
    return Coded(dn::kCodedEncoderNotExists, absl::StrCat(spec.key(), ": no master encoder"));
  }
  if (spec.requirement == dn::Requirement::kEncoderOrDigitalIo && !options_.master_encoder_module &&
      !options_.digital_io_module) {
    return Coded(dn::kCodedEncoderNotExists,
                 absl::StrCat(spec.key(), ": no master encoder or digital IO module"));
  }
  // Decision 952: setting the position or offset of an SSI (absolute) encoder is refused.
  if ((spec.id == Raw(CommandId::kSetEncoder1Position) ||
       spec.id == Raw(CommandId::kSetEncoder1Offset)) &&
      options_.encoder_mode == EncoderMode::kSsi) {
    return Coded(dn::kCodedEncoderSsiMode, absl::StrCat(spec.key(), ": encoder in SSI mode"));
  }
  if (spec.serial_mode && m && motor(*m).run_mode != RunMode::kSerial) {
    return Coded(dn::kCodedDriveNotSerial,
                 absl::StrCat(spec.key(), ": motor ", dn::MotorName(*m), " run mode ",
                              RunModeName(motor(*m).run_mode)));
  }
  if (spec.kind != dn::CommandKind::kGet) {
    if (absl::Status s = dn::CheckRange(spec, value); !s.ok()) return s;
    // Seed line 1618: the 100 series has half the current range.
    if (options_.series == ControllerSeries::k100 &&
        ((spec.id == Raw(CommandId::kSetControllerMaximalCurrent) && value > 128) ||
         (spec.id == Raw(CommandId::kSetControllerCurrentOffset) && (value < -64 || value > 64)))) {
      return Coded(dn::kCodedRangeError,
                   absl::StrCat(spec.key(), ": ", value, " outside the 100 series range"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<int32_t> LinMotDnDevice::Execute(const dn::DecodedCommand& c,
                                                std::optional<Motor> mo, bool* reset) {
  const uint8_t id = c.spec->id;
  const int32_t v = c.value;
  // §8.9 parameter pairs.
  if (mo && IsMotorParameterGet(id)) return motor(*mo).params[id];
  if (mo && id > 0 && IsMotorParameterGet(static_cast<uint8_t>(id - 1)) &&
      c.spec->kind == dn::CommandKind::kSet) {
    motor(*mo).params[id - 1] = v;
    return v;
  }
  switch (static_cast<CommandId>(id)) {
    case CommandId::kGetStatusLowWord:
      return status_low();
    case CommandId::kGetStatusHighWord:
      return status_high();
    case CommandId::kGetControlWord:
      return control_word_;
    case CommandId::kSetControlWord:
      ApplyControlWord(static_cast<uint16_t>(c.raw_value));
      return v;
    case CommandId::kGetWarnState:
      return mo ? MotorWarnWord(*mo) : SystemWarnWord();
    case CommandId::kResetWarnState:
      warn_latch_ = Latch{};
      return v;
    case CommandId::kGetErrorState:
      return mo ? MotorErrorWord(*mo) : SystemErrorWord();
    case CommandId::kResetErrorState:
      // D-22: a selected motor clears only its latch; none selected clears all.
      if (!mo || error_latch_.motor == mo) error_latch_ = Latch{};
      return v;
    case CommandId::kGetCodedError:
      return ReportedCodedError();
    case CommandId::kResetCodedError:
      coded_error_ = 0;
      return v;
    case CommandId::kGetControllerIo:
      return ControllerIoWord();
    case CommandId::kSetControllerIo:
      controller_outputs_ = static_cast<uint16_t>(c.raw_value & dn::kControllerIoOutputMask);
      return ControllerIoWord();
    case CommandId::kResetController:
      *reset = true;
      return 0;
    case CommandId::kGetPositionSetpoint:
      return motor(*mo).setpoint;
    case CommandId::kSetPositionSetpoint: {
      MotorState& m = motor(*mo);
      const int32_t target = std::clamp(v, m.params[0x40], m.params[0x42]);
      // Level command (D-4): re-evaluated every message; a new target starts a new move.
      if (target != m.setpoint || std::abs(m.target_mm - ToMm(target)) > 1e-9) {
        m.setpoint = target;
        DGW_RETURN_IF_ERROR(MoveToSetpoint(*mo));
      }
      return v;
    }
    case CommandId::kSetPositionSetpointWaitingForTrigger:
    case CommandId::kIncrementPositionSetpointWaitingForTrigger:
    case CommandId::kStartCurveWaitingForTrigger:
    case CommandId::kStartCurveIncrementalWaitingForTrigger:
      if (id == Raw(CommandId::kStartCurveWaitingForTrigger) ||
          id == Raw(CommandId::kStartCurveIncrementalWaitingForTrigger)) {
        bool exists = false;
        for (const CurveOptions& cv : options_.curves) exists = exists || cv.number == v;
        if (!exists) return Coded(dn::kCodedCurveMissing, absl::StrCat("curve ", v, " missing"));
      }
      motor(*mo).armed = Armed{id, v};
      return v;
    case CommandId::kIncrementPositionSetpoint: {
      MotorState& m = motor(*mo);
      m.setpoint = std::clamp(m.setpoint + v, m.params[0x40], m.params[0x42]);
      DGW_RETURN_IF_ERROR(MoveToSetpoint(*mo));
      return v;
    }
    case CommandId::kMoveHomePosition:
    case CommandId::kSetActualPosition: {
      // Seed lines 1151, 1213: no movement, only while the drive is not moving (decision 952:
      // otherwise ignored and logged).
      MotorState& m = motor(*mo);
      if (m.axis.motion_active() || m.init) {
        log::Debug("linmot_dn_sim.ignored_while_moving",
                   log::Fields().Add("drive", options_.name).Add("id", static_cast<int>(id)));
        return v;
      }
      const double before = m.axis.actual().position;
      if (id == Raw(CommandId::kSetActualPosition)) {
        m.axis.SetPosition(ToMm(v));  // the actual position now reads v
      } else {
        // Move Home Position: the zero moves to `v` (physical = reported + home).
        m.axis.SetPosition(m.axis.physical_position() - ToMm(v));
      }
      const double shift = m.axis.actual().position - before;
      m.target_mm += shift;
      m.blocked_at_mm += shift;
      m.setpoint = ToIncrements(m.axis.demand().position);
      return v;
    }
    case CommandId::kGetActualPosition:
      return ClampI16(ActualMm(*mo) * 51.2);
    case CommandId::kStartCurve:
    case CommandId::kStartCurveIncremental: {
      if (motor(*mo).running_curve) {
        return Coded(dn::kCodedCurveProcessing,
                     absl::StrCat("curve running on motor ", dn::MotorName(*mo)));
      }
      DGW_RETURN_IF_ERROR(
          StartCurve(*mo, static_cast<uint8_t>(v), id == Raw(CommandId::kStartCurveIncremental)));
      return v;
    }
    case CommandId::kGetEncoder1Position:
      return ClampI16(encoder_counts_);
    case CommandId::kSetEncoder1Position:
      encoder_counts_ = v;
      return v;
    case CommandId::kGetEncoder1Offset:
      return encoder_offset_;
    case CommandId::kSetEncoder1Offset:
      encoder_offset_ = v;
      return v;
    case CommandId::kGetExtendedIo:
      return ExtendedIoWord();
    case CommandId::kSetExtendedIo:
      extended_outputs_ = static_cast<uint8_t>(c.raw_value >> 8);
      return ExtendedIoWord();
    case CommandId::kSetSerialRunMode:
      motor(*mo).run_mode = RunMode::kSerial;  // D-18
      return v;
    case CommandId::kSetMasterEncoderRunMode:
      motor(*mo).run_mode = RunMode::kMasterEncoder;
      StopMotor(*mo);
      return v;
    case CommandId::kGetDirectOut1Variable:
      return motor(*mo).direct_out_1;
    case CommandId::kSetDirectOut1Variable:
      motor(*mo).direct_out_1 = static_cast<uint8_t>(v);
      return v;
    case CommandId::kGetDirectOut2Variable:
      return motor(*mo).direct_out_2;
    case CommandId::kSetDirectOut2Variable:
      motor(*mo).direct_out_2 = static_cast<uint8_t>(v);
      return v;
    default:
      break;
  }
  return absl::InternalError(absl::StrFormat("linmot_dn_sim: command 0x%02X not implemented", id));
}

// ---------------------------------------------------------------------------------------------
// Fault injection and inputs.

void LinMotDnDevice::SetMotorErrorCause(Motor m, uint16_t bits) {
  motor(m).error_cause = bits;
  CheckCauses();
  EvaluateState();
}

void LinMotDnDevice::SetMotorWarningCause(Motor m, uint16_t bits) {
  motor(m).warn_cause = bits;
  CheckCauses();
}

void LinMotDnDevice::SetSystemErrorCause(uint16_t bits) {
  system_error_cause_ = bits & 0x007F;
  CheckCauses();
  EvaluateState();
}

void LinMotDnDevice::SetSystemWarningCause(uint16_t bits) {
  system_warn_cause_ = bits & 0x003F;
  CheckCauses();
}

void LinMotDnDevice::SetMotorBlocked(Motor m, bool blocked) {
  MotorState& ms = motor(m);
  if (blocked && !ms.blocked) ms.blocked_at_mm = ms.axis.actual().position;
  ms.blocked = blocked;
}

void LinMotDnDevice::SetDisturbance(Motor m, double offset_mm) {
  motor(m).disturbance_mm = std::isfinite(offset_mm) ? offset_mm : 0.0;
}

void LinMotDnDevice::SetControllerInputs(uint16_t bits) {
  controller_inputs_ = bits & 0x03FF;
  UpdateTriggers();
}

void LinMotDnDevice::SetExtendedInputs(uint8_t bits) { extended_inputs_ = bits; }

void LinMotDnDevice::SetEncoderCounts(int32_t counts) { encoder_counts_ = counts; }

void LinMotDnDevice::SetEmergencyStop(bool active) {
  emergency_stop_ = active;
  EvaluateState();
}

void LinMotDnDevice::SetRunMode(Motor m, RunMode mode) { motor(m).run_mode = mode; }

// ---------------------------------------------------------------------------------------------
// Observation.

std::optional<int32_t> LinMotDnDevice::Parameter(Motor m, uint8_t get_id) const {
  if (!IsMotorParameterGet(get_id)) return std::nullopt;
  return motor(m).params[get_id];
}

DeviceSnapshot LinMotDnDevice::Snapshot() const {
  DeviceSnapshot s;
  s.sim_time = sim_time_;
  s.state = state_;
  s.control_word = control_word_;
  s.status_low = status_low();
  s.status_high = status_high();
  s.system_warn = SystemWarnWord();
  s.system_error = SystemErrorWord();
  s.coded_error = coded_error_;
  s.controller_io = ControllerIoWord();
  s.extended_io = ExtendedIoWord();
  s.init_done = init_done_;
  s.io_connected = io_connected_;
  s.motor_count = options_.motor_count;
  for (size_t i = 0; i < 4; ++i) {
    const Motor mo = static_cast<Motor>(i);
    const MotorState& m = motors_[i];
    MotorSnapshot& o = s.motors[i];
    o.present = m.present;
    if (!m.present) continue;
    o.master = m.config.master;
    o.run_mode = m.run_mode;
    o.actual_mm = ActualMm(mo);
    o.demand_mm = m.axis.demand().position;
    o.demand_velocity_mm_s = m.axis.demand().velocity;
    o.setpoint = m.setpoint;
    o.actual_position = ClampI16(o.actual_mm * 51.2);
    o.demand_position = ClampI16(o.demand_mm * 51.2);
    o.motion_active = m.axis.motion_active();
    o.in_position = InPosition(mo);
    o.curve_done = m.curve_done;
    o.command_toggle = m.toggle;
    o.following_error = dn::StatusHighWord{s.status_high}.following_error(mo);
    o.position_range = PositionRange(mo);
    o.over_temperature = dn::StatusHighWord{s.status_high}.over_temperature(mo);
    o.frozen = m.frozen;
    o.running_curve = m.running_curve;
    if (m.armed) o.armed_command = m.armed->id;
    o.direct_out_1 = m.direct_out_1;
    o.direct_out_2 = m.direct_out_2;
    o.curves_completed = m.curves_completed;
  }
  s.messages_consumed = messages_consumed_;
  s.commands_executed = commands_executed_;
  s.executed_by_id = executed_by_id_;
  s.coded_errors_raised = coded_errors_raised_;
  s.toggle_commands_ignored = toggle_commands_ignored_;
  s.direct_gets_ignored = direct_gets_ignored_;
  s.controller_resets = controller_resets_;
  return s;
}

const char* ControllerStateName(ControllerState s) {
  switch (s) {
    case ControllerState::kDisable:
      return "DISABLE";
    case ControllerState::kInit:
      return "INIT";
    case ControllerState::kStopped:
      return "STOPPED";
    case ControllerState::kRun:
      return "RUN";
    case ControllerState::kError:
      return "ERROR";
  }
  return "unknown";
}

}  // namespace drivegw::sim::linmot_devicenet
