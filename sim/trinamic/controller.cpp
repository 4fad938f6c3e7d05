// Simulated SIXpack/QUADpack controller: register writes, 2 ms motion ticks and query replies
// (trinamic-sixpack.md §4.2, §5.1-5.9; decisions 1031-1036, 1043, 1044).
#include "sim/trinamic/controller.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <string_view>

namespace drivegw::sim::trinamic {

namespace mt = drivegw::trinamic::motor_type;
using drivegw::trinamic::Opcode;
using drivegw::trinamic::Reply;
using drivegw::trinamic::SpecOf;

namespace {
int Sign(int64_t v) { return (v > 0) - (v < 0); }
}  // namespace

absl::StatusOr<Controller> Controller::Create(const ControllerOptions& options) {
  if (options.axes != 4 && options.axes != 6) {
    return absl::InvalidArgumentError("controller.axes: must be 4 (QUADpack) or 6 (SIXpack)");
  }
  if (options.address == 0) {
    return absl::InvalidArgumentError("controller.address: 0 is no unit address (1..255)");
  }
  if (options.amax_divisor != 64 && options.amax_divisor != 16) {
    return absl::InvalidArgumentError("controller.amax_divisor: must be 64 or 16 (G-07)");
  }
  return Controller(options);
}

Controller::Controller(const ControllerOptions& options) : options_(options) { Reset(); }

void Controller::Reset() {
  // `$CC` / power-on: every parameter back to the defaults of §5.12 (L902, L371); the reset
  // flag reads 1 once (L853). Positions restart at 0; the rotors stay where they are.
  ++reset_count_;
  address_ = options_.address;
  globals_ = Globals{};
  previous_v64_ = {};
  standing_ticks_ = {};
  velocity_changing_ = {};
  for (int m = 0; m < 6; ++m) {
    regs_[m] = MotorRegisters{};
    const int64_t rotor = state_[m].rotor;
    state_[m] = MotorState{};
    state_[m].rotor = rotor;
    accumulator_[m] = 0;
    switch_samples_[m] = 0;
    interp_master_[m] = -1;
    ref_[m] = RefSearch{};
    state_[m].switch_filtered = SwitchActive(m);
  }
  delayed_.reset();
  reset_flag_ = true;
}

double Controller::K(int motor, bool vmin_div) const {
  const int div = vmin_div ? 3 : regs_[motor].div;  // vmin always with div 3 (L543)
  return 20'000'000.0 / ((globals_.clkdiv + 1) * std::pow(2.0, 14 + div));
}

bool Controller::SwitchActive(int m) const {
  if (stuck_[m].has_value()) return *stuck_[m];
  const MotorWorld& w = options_.world[m];
  return w.has_switch && state_[m].rotor >= w.switch_low && state_[m].rotor <= w.switch_high;
}

int Controller::Dir(int m) const { return Flag(m, mt::kNullLeft) ? -1 : 1; }  // L565

bool Controller::AnyMoving() const {
  for (int m = 0; m < options_.axes; ++m) {
    if (Moving(m)) return true;
  }
  return false;
}

std::vector<uint8_t> Controller::EncodeReply(uint8_t ra, Opcode opcode,
                                             std::array<int64_t, 7> values) const {
  Reply reply;
  reply.response_address = ra;
  reply.opcode = opcode;
  reply.values = values;
  auto bytes = drivegw::trinamic::EncodeReply(reply, options_.framing);
  if (!bytes.ok()) return {};  // values come from our own registers; cannot happen
  return *std::move(bytes);
}

std::optional<std::vector<uint8_t>> Controller::Handle(const Command& c) {
  // Words for other units, during the `$CC` busy second, or out of range are not executed and
  // get no answer: the protocol has no error reply (§2.6, G-06, decision 1031).
  if (c.address != address_ || busy()) return std::nullopt;
  if (!drivegw::trinamic::ValidateCommand(c).ok()) return std::nullopt;
  const auto& spec = SpecOf(c.opcode);
  if (spec.field_count > 0 && std::string_view(spec.fields[0].name) == "motnr" &&
      c.values[0] >= options_.axes) {
    return std::nullopt;  // QUADpack motnr 4/5 (G-17, decision 1032)
  }
  const auto& v = c.values;
  const int m = static_cast<int>(v[0]);
  switch (c.opcode) {
    case Opcode::kQueryPosition: {  // L649-663: stop flag cleared after read
      MotorState& s = state_[m];
      auto out = EncodeReply(static_cast<uint8_t>(v[1]), c.opcode,
                             {m, s.position, static_cast<int64_t>(s.action), s.stop_flag});
      s.stop_flag = false;
      return out;
    }
    case Opcode::kQueryVelocity:  // L665-676
      return EncodeReply(static_cast<uint8_t>(v[1]), c.opcode,
                         {m, vact(m), static_cast<int64_t>(state_[m].action)});
    case Opcode::kQueryActivities: {  // L738-756
      const uint8_t ra = static_cast<uint8_t>(v[0]);
      const uint8_t mask = static_cast<uint8_t>(v[1]);
      delayed_.reset();  // a new `$28` replaces a pending one (decision 1036)
      for (int i = 0; i < options_.axes; ++i) {
        if ((mask >> i) & 1 && Moving(i)) {
          delayed_ = std::make_pair(ra, mask);
          return std::nullopt;
        }
      }
      std::array<int64_t, 7> acts{};
      for (int i = 0; i < options_.axes; ++i) acts[i] = static_cast<int64_t>(state_[i].action);
      return EncodeReply(ra, c.opcode, acts);
    }
    case Opcode::kReadInputs: {  // L775-792; ref bits 1 = switch active (G-18, decision 1037)
      const int ch = m;
      int64_t analog = 0;
      if (ch < options_.axes) analog = options_.world[ch].analog;
      if (ch == 6) analog = options_.external_analog;
      if (ch == 7) analog = std::clamp<int64_t>(std::lround(options_.supply_volts * 22), 0, 1023);
      int64_t refs = 0;
      for (int i = 0; i < options_.axes; ++i) refs |= int64_t{SwitchActive(i)} << i;
      // Jumpers JP1/JP2 in P4 bits 6/7, 1 = set (L305, L790, G-19, decision 1044).
      refs |= int64_t{options_.jumper1} << 6 | int64_t{options_.jumper2} << 7;
      const int64_t ref = ch < options_.axes ? int64_t{SwitchActive(ch)} : 0;
      const int64_t ttlio = globals_.outputs[1] == 0 ? globals_.outputs[2] : 0;
      return EncodeReply(static_cast<uint8_t>(v[1]), c.opcode, {ch, analog, ref, refs, ttlio});
    }
    case Opcode::kUnitInformation: {  // L845-855: reset flag 1 at the first read after reset
      auto out = EncodeReply(
          static_cast<uint8_t>(v[0]), c.opcode,
          {options_.firmware, reset_flag_, options_.temperature_c, options_.serial_number});
      reset_flag_ = false;
      return out;
    }
    case Opcode::kRs232Tunnel:  // L857-869: P2 = 0 disables forwarding (§4.2 [P])
      globals_.tunnel_address = static_cast<uint8_t>(v[1]);
      globals_.tunnel_packet_size = static_cast<uint8_t>(v[2]);
      return EncodeReply(static_cast<uint8_t>(v[0]), c.opcode, {0, 0});
    case Opcode::kPowerDown: {  // L873-893; bits executed in order 0, 1, 2, 3 (G-23)
      // Only firmware 1.46 and since 1.49 know `$45` (L873); others ignore it (decision 1043).
      if (options_.firmware != 146 && options_.firmware < 149) return std::nullopt;
      const int64_t a = v[1];
      int64_t status = int64_t{globals_.power_down_state} << 2;
      if ((a & 1) && eeprom_.valid) {  // copy the saved positions into the counters (L881)
        for (int i = 0; i < options_.axes; ++i) {
          if (!Moving(i)) state_[i].position = eeprom_.positions[i];
        }
        status |= 1;
      }
      if (a & 2) eeprom_.valid = false;
      if (a & 4) globals_.power_down_enabled = true;
      // Re-enable only above the power-down level (L885, L891).
      if ((a & 8) && options_.supply_volts >= kPowerDownVolts) globals_.power_down_state = false;
      status |= int64_t{eeprom_.valid} << 1;
      status |= int64_t{globals_.power_down_state} << 3;
      return EncodeReply(static_cast<uint8_t>(v[0]), c.opcode, {status});
    }
    case Opcode::kFlashChecksum:  // harmless fingerprint (§4.2 service functions [P])
      return EncodeReply(static_cast<uint8_t>(v[0]), c.opcode, {options_.flash_checksum});
    default:
      Execute(c);
      return std::nullopt;
  }
}

void Controller::Execute(const Command& c) {
  const auto& v = c.values;
  const int m = static_cast<int>(v[0]);
  // P1 is a motor number for most opcodes but a motor mask (up to 63) for a few ($28, $29, $2A);
  // bind the per-motor references only to a valid index — the mask opcodes never use them.
  const size_t idx = m >= 0 && static_cast<size_t>(m) < regs_.size() ? static_cast<size_t>(m) : 0;
  MotorRegisters& r = regs_[idx];
  MotorState& s = state_[idx];
  auto to_int = [](int64_t x) { return static_cast<int>(x); };
  if (motors_disabled()) {
    // Undervoltage stopped the motors; they stay off until `$45` bit 3 (L877, L891, G-23).
    switch (c.opcode) {
      case Opcode::kStartReferenceSearch:
      case Opcode::kStartRamp:
      case Opcode::kActivatePi:
      case Opcode::kStartRotation:
      case Opcode::kStartRampParallel:
      case Opcode::kInterpolate:
        return;
      default:
        break;
    }
  }
  switch (c.opcode) {
    case Opcode::kPeakCurrent:  // L507: per pair, only motnr 0/2/4 effective
      if (m % 2 == 0) {
        regs_[m].peak_current = static_cast<uint8_t>(v[1]);
        if (m + 1 < options_.axes) regs_[m + 1].peak_current = static_cast<uint8_t>(v[1]);
      }
      break;
    case Opcode::kCurrentControl:  // L514-528
      for (int i = 0; i < 4; ++i) r.current_index[i] = static_cast<uint8_t>(v[1 + i]);
      r.t0 = static_cast<uint16_t>(v[5]);
      break;
    case Opcode::kVelocitySetting:  // L532: only while all motors stand still
      if (!AnyMoving()) globals_.clkdiv = to_int(v[0]);
      break;
    case Opcode::kStartingVelocity:  // L539: only while the motor stands still
      if (!Moving(m)) {
        r.vmin = to_int(v[1]);
        r.vstart = to_int(v[2]);
        r.div = to_int(v[3]);
      }
      break;
    case Opcode::kSetRamp:  // L552: effective immediately, also during motion
      r.amax = to_int(v[1]);
      r.vmax = to_int(v[2]);
      break;
    case Opcode::kMotorParameters:  // L563-603; AutoNullCmd starts a search (L682)
      r.poslimit = v[1];
      r.motor_type = static_cast<uint16_t>(v[2] | (v[3] << 8));
      if (r.motor_type & mt::kAutoNullCmd) {
        r.motor_type &= static_cast<uint16_t>(~mt::kAutoNullCmd);
        if (!motors_disabled()) StartReferenceSearch(m);
      }
      break;
    case Opcode::kReferenceParameters:  // L607-616: only while stopped
      if (!Moving(m)) {
        r.vrefmax = to_int(v[1]);
        r.debounce_mask = static_cast<uint16_t>(v[2]);
        r.stop_after_search = v[3] != 0;
      }
      break;
    case Opcode::kWriteTable:  // L618-625: common to all motors
      for (int i = 0; i < 4; ++i) globals_.table[v[0] + i] = static_cast<uint8_t>(v[1 + i]);
      break;
    case Opcode::kNullOffset:  // L627-634
      r.nulloffset = static_cast<int32_t>(v[1]);
      r.testnullrange = static_cast<uint16_t>(v[2]);
      break;
    case Opcode::kPiParameters:  // L636-645
      r.propdiv = to_int(v[1]);
      r.intdiv = to_int(v[2]);
      r.intclip = to_int(v[3]);
      r.intinpclip = to_int(v[4]);
      break;
    case Opcode::kStartReferenceSearch:  // L678-685
      StartReferenceSearch(m);
      break;
    case Opcode::kStartRamp:  // L689-701
      if (s.action == Action::kRotation) {
        s.rotation_velocity = 0;  // only stops the rotation (L693, G-36)
      } else if (!Moving(m)) {
        s.target = static_cast<int32_t>(v[1]);
        s.decelerating = false;
        if (s.target != s.position) {
          s.action = Action::kRamp;
          started_targets_.push_back({m, s.target});
        }
      }
      break;
    case Opcode::kActivatePi:  // L703-709: immediate, clears the integral (§5.6)
      ReleaseInterpolation(m);
      s.target = static_cast<int32_t>(v[1]);
      s.pi_integral = 0;
      s.action = Action::kPi;
      break;
    case Opcode::kStartRotation:  // L711-718: immediate even when active
      ReleaseInterpolation(m);
      s.rotation_velocity = to_int(v[1]);
      s.action = Action::kRotation;
      break;
    case Opcode::kSetTarget:  // L720-726: mode unchanged
      s.target = static_cast<int32_t>(v[1]);
      s.decelerating = false;
      started_targets_.push_back({m, s.target});
      break;
    case Opcode::kSetPosition:  // L728-734: counter only; the rotor stays
      s.position = static_cast<int32_t>(v[1]);
      break;
    case Opcode::kStartRampParallel:  // L758-763: same tick, own parameters
      for (int i = 0; i < options_.axes; ++i) {
        if ((v[0] >> i) & 1 && !Moving(i) && state_[i].target != state_[i].position) {
          state_[i].action = Action::kRamp;
          state_[i].decelerating = false;
        }
      }
      break;
    case Opcode::kStopMotors:  // L765-771: target := actual position, overshoot and return
      for (int i = 0; i < options_.axes; ++i) {
        if (!((v[0] >> i) & 1) || !Moving(i)) continue;
        MotorState& si = state_[i];
        const int master = interp_master_[i];
        if (master >= 0 && master != i) {
          si.action = Action::kInactive;  // a slave stops with its master (decision 1035)
          si.v64 = 0;
          interp_master_[i] = -1;
          continue;
        }
        ReleaseInterpolation(i);
        si.target = si.position;
        si.decelerating = false;
        si.action = Action::kRamp;
      }
      break;
    case Opcode::kAnalogStopLimits:  // L794-801, channel = motor (decision 1014)
      if (m < options_.axes) {
        r.stop_min_left = static_cast<uint16_t>(v[1]);
        r.stop_max_right = static_cast<uint16_t>(v[2]);
      }
      break;
    case Opcode::kSetOutputs:  // L803-814
      for (int i = 0; i < 4; ++i) globals_.outputs[i] = static_cast<uint8_t>(v[i]);
      break;
    case Opcode::kReadyOutput:  // L816-825
      globals_.ready_active_mask = static_cast<uint8_t>(v[0]);
      globals_.ready_reference_mask = static_cast<uint8_t>(v[1]);
      break;
    case Opcode::kSetBaudRate:  // L829-833, effective at once (G-40)
      globals_.baud_divisor = static_cast<uint16_t>(v[0]);
      globals_.switchover = static_cast<uint16_t>(v[1]);
      break;
    case Opcode::kSetPacketTimeout:  // L835-838
      globals_.packet_timeout = static_cast<uint16_t>(v[0]);
      break;
    case Opcode::kChangeAddress:  // L840-843: immediately, until reset (G-05, decision 1038)
      address_ = static_cast<uint8_t>(v[0]);
      break;
    case Opcode::kHardwareReset:  // L895-902: any P0 (G-21), ~1 s busy
      Reset();
      busy_ = options_.reset_busy;
      break;
    case Opcode::kInterpolate: {  // L904-912, model §5.5 (G-16)
      int master = -1;
      int64_t longest = 0;
      for (int i = 0; i < options_.axes; ++i) {
        if (!((v[0] >> i) & 1)) continue;
        if (Moving(i)) return;  // masked motors must stand (L908)
        const int64_t d = std::abs(int64_t{state_[i].target} - state_[i].position);
        if (d > longest) {
          longest = d;
          master = i;
        }
      }
      if (master < 0) return;
      const double km = K(master, false);
      double vlim = regs_[master].vmax;
      double alim = regs_[master].amax;
      for (int i = 0; i < options_.axes; ++i) {
        if (!((v[0] >> i) & 1)) continue;
        const int64_t d = std::abs(int64_t{state_[i].target} - state_[i].position);
        if (d == 0) continue;
        const double ratio = static_cast<double>(longest) / static_cast<double>(d);
        vlim = std::min(vlim, regs_[i].vmax * K(i, false) * ratio / km);
        alim = std::min(alim, regs_[i].amax * K(i, false) * ratio / km);
      }
      for (int i = 0; i < options_.axes; ++i) {
        if (!((v[0] >> i) & 1)) continue;
        interp_master_[i] = master;
        interp_start_[i] = state_[i].position;
        interp_delta_[i] = int64_t{state_[i].target} - state_[i].position;
        state_[i].action = Action::kRamp;
        state_[i].decelerating = false;
      }
      interp_vmax_[master] = std::max(1, static_cast<int>(vlim));
      interp_amax_[master] = std::max(1, static_cast<int>(alim));
      break;
    }
    default:  // service functions $F2 $F3 $F5-$F7: ignored (§4.2 [P], G-22)
      break;
  }
}

std::optional<std::vector<uint8_t>> Controller::TakeDelayedReply() {
  if (!delayed_) return std::nullopt;
  for (int i = 0; i < options_.axes; ++i) {
    if ((delayed_->second >> i) & 1 && Moving(i)) return std::nullopt;
  }
  std::array<int64_t, 7> acts{};
  for (int i = 0; i < options_.axes; ++i) acts[i] = static_cast<int64_t>(state_[i].action);
  const uint8_t ra = delayed_->first;
  delayed_.reset();
  return EncodeReply(ra, Opcode::kQueryActivities, acts);
}

void Controller::Advance(Duration dt) {
  remainder_ += dt;
  while (remainder_ >= kTick) {
    remainder_ -= kTick;
    if (busy_ > Duration::zero()) {
      busy_ -= kTick;
      continue;
    }
    Tick();
  }
}

void Controller::Tick() {
  ++ticks_;
  CheckSupply();
  for (int m = 0; m < options_.axes; ++m) UpdateSwitch(m);
  for (int m = 0; m < options_.axes; ++m) {
    if (interp_master_[m] >= 0 && interp_master_[m] != m) continue;  // slaves follow the master
    TickMotor(m);
  }
  for (int m = 0; m < options_.axes; ++m) UpdateCurrents(m);
}

void Controller::CheckSupply() {
  // L877: below 13 V the power-down state is entered (always tracked, L879); with `$45` bit 2
  // the positions are saved and the motors stopped at once (G-23, decision 1043).
  if (options_.supply_volts >= kPowerDownVolts || globals_.power_down_state) return;
  globals_.power_down_state = true;
  if (!globals_.power_down_enabled) return;
  for (int m = 0; m < options_.axes; ++m) {
    ReleaseInterpolation(m);
    MotorState& s = state_[m];
    s.action = Action::kInactive;
    s.v64 = 0;
    s.rotation_velocity = 0;
    s.target = s.position;
    accumulator_[m] = 0;
    eeprom_.positions[m] = s.position;
  }
  eeprom_.valid = true;
}

void Controller::UpdateCurrents(int m) {
  // §5.9 [P]: I3 while |v| changes, I2 at constant velocity, I1 standing, I0 after T0 (G-09).
  const int32_t v = state_[m].v64;
  velocity_changing_[m] = std::abs(v) != std::abs(previous_v64_[m]);
  previous_v64_[m] = v;
  if (state_[m].action == Action::kInactive) {
    ++standing_ticks_[m];
  } else {
    standing_ticks_[m] = 0;
  }
}

double Controller::PeakCurrentMa(int m) const {
  // SIXpack 0.8 A × value/256; QUADpack 1.5 A × value/256 × DIP (L511-512).
  const double full = options_.axes == 4 ? 1500.0 * options_.quad_dip_percent[m] / 100.0 : 800.0;
  return full * regs_[m].peak_current / 256.0;
}

double Controller::CoilCurrentMa(int m) const {
  static constexpr std::array<double, 9> kPercent = {100, 75, 50, 38, 25, 19, 13, 9, 0};  // L520
  const MotorRegisters& r = regs_[m];
  int index = 0;
  if (state_[m].action != Action::kInactive) {
    index = velocity_changing_[m] ? r.current_index[3] : r.current_index[2];
  } else {
    // Stand-by once at rest for T0 × 2 ms; standing_ticks_ counts the stop tick itself (L524).
    index = standing_ticks_[m] - 1 >= r.t0 ? r.current_index[0] : r.current_index[1];
  }
  return PeakCurrentMa(m) * kPercent[std::min(index, 8)] / 100.0;
}

bool Controller::Ttlout1High() const {
  // `$32` P3: TTLOUT1 is the ready output; `$33` P0 motors active (motion other than a
  // reference search), P1 motors in a reference search make it active = low (L816-825).
  if ((globals_.outputs[3] & 1) == 0) return (globals_.outputs[0] & 1) != 0;
  for (int m = 0; m < options_.axes; ++m) {
    const Action a = state_[m].action;
    const bool homing = a >= Action::kRefStop;
    if (a != Action::kInactive && !homing && ((globals_.ready_active_mask >> m) & 1)) return false;
    if (homing && ((globals_.ready_reference_mask >> m) & 1)) return false;
  }
  return true;
}

int Controller::DisplayDigit() const {
  int n = 0;
  for (int m = 0; m < options_.axes; ++m) n += Moving(m) ? 1 : 0;  // L66
  return n;
}

bool Controller::DisplayPoint() const {
  for (int m = 0; m < options_.axes; ++m) {
    if (state_[m].action >= Action::kRefStop) return true;  // L66: reference search running
  }
  return false;
}

void Controller::UpdateSwitch(int m) {
  // Sampled every 2 ms; with FilterSwitch a change needs popcount(mask) equal samples (§5.7).
  const bool raw = SwitchActive(m);
  MotorState& s = state_[m];
  if (!Flag(m, mt::kFilterSwitch)) {
    s.switch_filtered = raw;
    return;
  }
  if (raw == s.switch_filtered) {
    switch_samples_[m] = 0;
    return;
  }
  if (++switch_samples_[m] >= std::max(1, std::popcount(regs_[m].debounce_mask))) {
    s.switch_filtered = raw;
    switch_samples_[m] = 0;
  }
}

int64_t Controller::Steps(int m, int64_t v64, bool vmin_div) {
  // Phase accumulator of §5.1: acc += 40 000 × |V64|, one microstep per Dq.
  const int div = vmin_div ? 3 : regs_[m].div;
  const int64_t dq = int64_t{globals_.clkdiv + 1} * (int64_t{1} << (14 + div)) * 64;
  accumulator_[m] += 40'000 * std::abs(v64);
  const int64_t n = accumulator_[m] / dq;
  accumulator_[m] -= n * dq;
  return n;
}

void Controller::MoveCounter(int m, int64_t steps) {
  MotorState& s = state_[m];
  s.position = static_cast<int32_t>(s.position + steps);
  s.rotor += steps;
  Wrap(m);
}

void Controller::Wrap(int m) {
  // Rotary axes: NullLeft 0 ≤ pos < poslimit, else 0 ≥ pos > −poslimit (L695-698, L713).
  const int64_t lim = regs_[m].poslimit;
  if (!Flag(m, mt::kRotaryAxis) || lim <= 0) return;
  int64_t p = state_[m].position;
  if (Flag(m, mt::kNullLeft)) {
    p = ((p % lim) + lim) % lim;
  } else {
    p = -(((-p % lim) + lim) % lim);
  }
  state_[m].position = static_cast<int32_t>(p);
}

int64_t Controller::BrakeDistance(int m, int64_t v, int amax) const {
  // Discrete braking distance (§5.4 caution): ticks at v − a, v − 2a, … above vstart.
  const int64_t vs = int64_t{regs_[m].vstart} * 64;
  const int64_t a = std::max<int64_t>(1, amax * 64 / options_.amax_divisor);
  if (v <= vs) return 0;
  const int64_t n = (v - vs - 1) / a;
  const int64_t sum = n * v - a * n * (n + 1) / 2;
  const int64_t dq = int64_t{globals_.clkdiv + 1} * (int64_t{1} << (14 + regs_[m].div)) * 64;
  return sum * 40'000 / dq + 1;
}

void Controller::RampStep(int m, int vmax, int amax) {
  // §5.4 per-tick algorithm; Δv per tick = amax/64 velocity units (L557), in V64 = amax.
  MotorState& s = state_[m];
  const MotorRegisters& r = regs_[m];
  const int64_t a = std::max<int64_t>(1, amax * 64 / options_.amax_divisor);
  const int64_t vs = int64_t{r.vstart} * 64;
  const int64_t vmax64 = int64_t{vmax} * 64;
  const int64_t dq = int64_t{globals_.clkdiv + 1} * (int64_t{1} << (14 + r.div)) * 64;
  auto step_of = [&](int64_t v) { return v * 40'000 / dq; };
  int64_t d = int64_t{s.target} - s.position;
  const int64_t lim = r.poslimit;
  if (Flag(m, mt::kRotaryAxis) && Flag(m, mt::kWayOptimization) && lim > 0) {
    d %= lim;  // shortest way, ties positive (G-35)
    if (d > lim / 2) d -= lim;
    if (d <= -lim / 2 && d != lim / 2) d += lim;
  }
  if (s.v64 == 0) {
    if (d == 0) {
      s.action = Action::kInactive;
      return;
    }
    s.v64 = static_cast<int32_t>(Sign(d) * vs);  // start at vstart (L545)
    s.decelerating = false;
  }
  int64_t v = std::abs(s.v64);
  int dir = Sign(s.v64);
  if (dir != Sign(d)) {
    // Target behind or stop: brake, then reverse at vstart (L722, L767).
    v -= a;
    if (v <= vs) {
      v = vs;
      dir = Sign(d);
      s.decelerating = false;
    }
  } else if (s.decelerating) {
    v = std::max(vs, v - a);
  } else {
    const int64_t ad = std::abs(d);
    int64_t cand = v < vmax64 ? std::min(vmax64, v + a) : std::max(vmax64, v - a);
    if (cand < vs) cand = vs;
    if (step_of(cand) + BrakeDistance(m, cand, amax) <= ad) {
      v = cand;
    } else if (cand > v && step_of(v) + BrakeDistance(m, v, amax) <= ad) {
      // hold the velocity
    } else {
      v = std::max(vs, v - a);
      s.decelerating = BrakeDistance(m, v, amax) <= ad;
    }
  }
  s.v64 = static_cast<int32_t>(dir * v);
  if (dir == 0) {
    s.v64 = 0;
    s.action = Action::kInactive;
    return;
  }
  int64_t n = Steps(m, v, false);
  if (dir == Sign(d) && n >= std::abs(d) && (s.decelerating || v <= vs)) {
    n = std::abs(d);  // land exactly on the target (§5.4 caution)
  }
  MoveCounter(m, dir * n);
  if (s.position == s.target && v <= vs) {
    s.v64 = 0;
    s.decelerating = false;
    accumulator_[m] = 0;
    s.action = Action::kInactive;
  }
}

void Controller::StepAtVelocity(int m, int v64, bool vmin_div) {
  state_[m].v64 = v64;
  MoveCounter(m, Sign(v64) * Steps(m, v64, vmin_div));
}

void Controller::TickMotor(int m) {
  MotorState& s = state_[m];
  const MotorRegisters& r = regs_[m];
  const int64_t a = std::max<int64_t>(1, r.amax * 64 / options_.amax_divisor);
  switch (s.action) {
    case Action::kInactive:
      s.v64 = 0;
      return;
    case Action::kRamp:
      if (interp_master_[m] == m) {
        RampStep(m, interp_vmax_[m], interp_amax_[m]);
        for (int i = 0; i < options_.axes; ++i) {
          if (i == m || interp_master_[i] != m) continue;
          MotorState& si = state_[i];
          // pos_i = start_i + round(Δ_i × (pos_m − start_m) / Δ_m) (§5.5 [P])
          const double f = static_cast<double>(int64_t{s.position} - interp_start_[m]) /
                           static_cast<double>(interp_delta_[m]);
          const int64_t p = interp_start_[i] + std::llround(interp_delta_[i] * f);
          MoveCounter(i, p - si.position);
          si.v64 = static_cast<int32_t>(std::llround(s.v64 * static_cast<double>(interp_delta_[i]) /
                                                     static_cast<double>(interp_delta_[m])));
          if (s.action == Action::kInactive) {
            si.action = Action::kInactive;
            si.v64 = 0;
            interp_master_[i] = -1;
          }
        }
        if (s.action == Action::kInactive) interp_master_[m] = -1;
      } else {
        RampStep(m, r.vmax, r.amax);
      }
      break;
    case Action::kRotation: {  // L713: velocity changes obey amax; 0 → inactive (G-36)
      const int64_t want = int64_t{s.rotation_velocity} * 64;
      int64_t v = s.v64;
      if (v == 0 && want != 0) {
        v = Sign(want) * std::min<int64_t>(std::abs(want), int64_t{r.vstart} * 64);
      } else if (v < want) {
        v = std::min(want, v + a);
      } else if (v > want) {
        v = std::max(want, v - a);
      }
      if (want == 0 && std::abs(v) <= int64_t{r.vstart} * 64) v = 0;
      StepAtVelocity(m, static_cast<int>(v), false);
      if (v == 0 && want == 0) s.action = Action::kInactive;
      break;
    }
    case Action::kPi: {  // §5.6 model
      const int64_t e = int64_t{s.target} - s.position;
      s.pi_integral =
          std::clamp<int64_t>(s.pi_integral + std::clamp<int64_t>(e, -r.intinpclip, r.intinpclip),
                              -r.intclip, r.intclip);
      const int64_t v = std::clamp<int64_t>(64 * e / r.propdiv + 64 * s.pi_integral / r.intdiv,
                                            -64 * r.vmax, 64 * r.vmax);
      s.v64 = static_cast<int32_t>(v);
      int64_t n = Steps(m, v, false);
      if (Sign(v) == Sign(e)) n = std::min<int64_t>(n, std::abs(e));
      MoveCounter(m, Sign(v) * n);
      break;
    }
    default:
      ReferenceTick(m);
      return;
  }
  CheckStopConditions(m);
}

void Controller::ReleaseInterpolation(int m) {
  // A master leaving `$50` releases its slaves where they are (decision 1035).
  if (interp_master_[m] == m) {
    for (int i = 0; i < options_.axes; ++i) {
      if (i == m || interp_master_[i] != m) continue;
      interp_master_[i] = -1;
      state_[i].action = Action::kInactive;
      state_[i].v64 = 0;
    }
  }
  interp_master_[m] = -1;
}

void Controller::StartReferenceSearch(int m) {
  // L680: first stop; remember the operation to resume afterwards (L680, L616).
  MotorState& s = state_[m];
  ReleaseInterpolation(m);
  RefSearch& ref = ref_[m];
  if (s.action < Action::kRefStop) {
    ref.previous = s.action;
    ref.previous_target = s.action == Action::kInactive ? s.position : s.target;
    ref.previous_rotation = s.rotation_velocity;
  }
  ref.fast_found.reset();
  s.action = Action::kRefStop;
}

void Controller::ReferenceTick(int m) {
  // State machine of §5.7 [P] (decision 1033).
  MotorState& s = state_[m];
  const MotorRegisters& r = regs_[m];
  RefSearch& ref = ref_[m];
  const int dir = Dir(m);
  const bool sw = s.switch_filtered;
  int vmin = r.vmin;
  if (vmin == 0) vmin = std::max(1, static_cast<int>(250.0 / K(m, true)));  // L543 automatic
  const int64_t travelled = std::abs(int64_t{s.position} - ref.travel_start);
  const bool too_far = r.poslimit > 0 && travelled * 4 > r.poslimit * 5;  // 125 % (L680)
  auto set_zero = [&](int64_t edge) {
    // Zero point nulloffset beyond the edge in search direction (L629, G-12).
    const int64_t zero = edge + int64_t{dir} * r.nulloffset;
    s.position = static_cast<int32_t>(s.position - zero);
    s.v64 = 0;
    s.action = Action::kRefSetZero;
  };
  switch (s.action) {
    case Action::kRefStop: {
      const int64_t a = std::max<int64_t>(1, r.amax * 64 / options_.amax_divisor);
      int64_t v = std::abs(s.v64) - a;
      if (v <= int64_t{r.vstart} * 64) v = 0;
      StepAtVelocity(m, static_cast<int>(Sign(s.v64) * v), false);
      if (v != 0) return;
      ref.travel_start = s.position;
      accumulator_[m] = 0;
      if (Flag(m, mt::kMechRef)) {
        s.target = static_cast<int32_t>(s.position + dir * (r.poslimit * 5 / 4));  // L571
        s.action = Action::kMechRef;
      } else if (sw) {
        s.action = Action::kRefBackOff;
      } else {
        s.action = Flag(m, mt::kFastRef) ? Action::kRefFastSeek : Action::kRefSlowApproach;
      }
      return;
    }
    case Action::kRefFastSeek:
      StepAtVelocity(m, dir * r.vrefmax * 64, false);
      if (s.switch_filtered || SwitchActive(m)) {
        if (!s.switch_filtered) return;  // wait for the filter
        ref.fast_found = s.position;
        s.action = Action::kRefBackOff;
      } else if (too_far) {
        s.action = Action::kRefStop;
      }
      return;
    case Action::kRefBackOff:
      StepAtVelocity(m, -dir * vmin * 64, true);
      if (!sw) {
        s.action = Action::kRefSlowApproach;
        ref.travel_start = s.position;
      }
      return;
    case Action::kRefSlowApproach: {
      StepAtVelocity(m, dir * vmin * 64, true);
      if (sw) {
        ref.p1 = s.position;
        if (Flag(m, mt::kNullCenter)) {
          s.action = Action::kRefCentreScan;
        } else {
          set_zero(s.position);
        }
        return;
      }
      // Not found again where the fast seek found it (L680): tolerance = the fast seek's
      // travel during the filter delay plus one full step (decision 1033).
      const int64_t tol = static_cast<int64_t>(K(m, false) * r.vrefmax * 0.002 *
                                               (std::popcount(r.debounce_mask) + 1)) +
                          16;
      if (too_far || (ref.fast_found && dir * (int64_t{s.position} - *ref.fast_found) > tol)) {
        ref.fast_found.reset();
        s.action = Action::kRefStop;
      }
      return;
    }
    case Action::kRefCentreScan:
      StepAtVelocity(m, dir * vmin * 64, true);
      if (!sw) set_zero((ref.p1 + s.position) / 2);  // L567: centre of the active area
      return;
    case Action::kRefSetZero:
      s.action = Action::kRefFinish;
      s.decelerating = false;
      if (r.stop_after_search) {
        s.target = 0;  // L616
      } else if (ref.previous == Action::kRotation) {
        s.rotation_velocity = ref.previous_rotation;
        s.action = Action::kRotation;
      } else if (ref.previous == Action::kPi) {
        s.target = ref.previous_target;
        s.pi_integral = 0;
        s.action = Action::kPi;
      } else {
        s.target = ref.previous_target;  // resume: the numeric position held before (L680)
      }
      return;
    case Action::kRefFinish:
      RampStep(m, r.vmax, r.amax);
      if (s.action == Action::kInactive) return;
      s.action = Action::kRefFinish;
      return;
    case Action::kMechRef:
      RampStep(m, r.vmax, r.amax);
      if (s.action == Action::kInactive) {
        s.position = 0;  // L570-571, L662
        return;
      }
      s.action = Action::kMechRef;
      return;
    default:
      return;
  }
}

void Controller::CheckStopConditions(int m) {
  // §5.8: analogue limits by direction (L796-801), StopNull outside ±testnullrange (L581-583).
  const MotorState& s = state_[m];
  const MotorRegisters& r = regs_[m];
  if (s.v64 == 0 || s.action == Action::kInactive) return;
  const uint16_t analog = options_.world[m].analog;
  bool stop = false;
  if (s.v64 < 0 && r.stop_min_left != 0 && analog < r.stop_min_left) stop = true;
  if (s.v64 > 0 && r.stop_max_right < 1023 && analog > r.stop_max_right) stop = true;
  if (Flag(m, mt::kStopNull) && s.switch_filtered && Sign(s.v64) == Dir(m) &&
      std::abs(int64_t{s.position}) > r.testnullrange) {
    stop = true;
  }
  if (stop) StopCondition(m);
}

void Controller::StopCondition(int m) {
  MotorState& s = state_[m];
  const MotorRegisters& r = regs_[m];
  s.stop_flag = true;  // L576, L581, L663
  ReleaseInterpolation(m);
  const bool soft = Flag(m, mt::kStopSoft);
  if (!soft) {
    // Abrupt stop: above vstart the rotor loses round(K × v × 0.004) steps (§5.8 [P]).
    const int64_t v = std::abs(s.v64);
    if (options_.lose_steps_on_abrupt_stop && v > int64_t{r.vstart} * 64) {
      s.rotor -= Sign(s.v64) * std::llround(K(m, false) * (v / 64.0) * 0.004);
    }
    s.v64 = 0;
    accumulator_[m] = 0;
  }
  if (!Flag(m, mt::kStopNoRef)) {
    StartReferenceSearch(m);  // AutoNullCmd (L582, L598); soft stops too (G-15)
    ref_[m].previous = Action::kInactive;
    ref_[m].previous_target = s.position;
    return;
  }
  if (soft) {
    s.rotation_velocity = 0;  // decelerate with amax to 0 (L593-596)
    s.action = Action::kRotation;
  } else {
    s.action = Action::kInactive;
  }
  if (Flag(m, mt::kStopAtFullsteps) && !soft) {
    s.position = static_cast<int32_t>(std::lround(s.position / 16.0) * 16);  // G-35
  }
}

}  // namespace drivegw::sim::trinamic
