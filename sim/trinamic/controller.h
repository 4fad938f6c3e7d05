// Simulated Trinamic SIXpack/QUADpack controller: per-motor registers, the 2 ms ramp generator,
// reference search, stop conditions and the query replies. Pure: no I/O, no clock reads; time
// moves only through Advance() (trinamic-sixpack.md §4, §5, §7).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/trinamic/codec.h"

namespace drivegw::sim::trinamic {

using drivegw::trinamic::Command;
using drivegw::trinamic::ReplyFraming;

inline constexpr Duration kTick = std::chrono::milliseconds(2);  // internal cycle (L557, §5.3)
inline constexpr double kPowerDownVolts = 13.0;                  // `$45` undervoltage level (L877)

// Action codes of `$20` P5 (§4.2 `$20`, L661-662); 20..26 are the project's reference-search
// sub-phases (G-13, decision 1033).
enum class Action : uint8_t {
  kInactive = 0,
  kRamp = 5,
  kPi = 10,
  kRotation = 15,
  kRefStop = 20,
  kRefFastSeek = 21,
  kRefBackOff = 22,
  kRefSlowApproach = 23,
  kRefCentreScan = 24,
  kRefSetZero = 25,
  kRefFinish = 26,
  kMechRef = 30,
};

// The simulated world of one motor (§1.4, §7 "world model").
struct MotorWorld {
  // Reference switch active while the rotor lies in [switch_low, switch_high] (microsteps of the
  // rotor's own coordinate, which equals the counter at power-up).
  bool has_switch = true;
  int64_t switch_low = -1'000'000'000;
  int64_t switch_high = -999'999'000;
  uint16_t analog = 512;  // analogue input (0..1023) seen on this motor's channel
};

struct ControllerOptions {
  uint8_t address = 1;                       // rotary switches (L281)
  int axes = 6;                              // 6 = SIXpack, 4 = QUADpack (G-17)
  ReplyFraming framing = ReplyFraming::kR8;  // G-01, decision 1011
  uint8_t firmware = 148;                    // V1.4.8 (L852)
  uint16_t serial_number = 0x1234;
  int8_t temperature_c = 31;
  double supply_volts = 24.0;                     // channel 7 = 22 counts per volt (L779)
  uint16_t external_analog = 0;                   // channel 6
  int amax_divisor = 64;                          // 64 (L557) or 16 (L363), G-07
  uint16_t flash_checksum = 0xBEEF;               // answer of `$F4` (§4.2 service functions)
  Duration reset_busy = std::chrono::seconds(1);  // `$CC` takes ~1 s (L900)
  bool lose_steps_on_abrupt_stop = true;          // §5.8 fault model
  // CAN bit-rate jumpers, read by `$30` P4 bits 6/7 with 1 = set (L293-305, L790, G-19).
  bool jumper1 = false;
  bool jumper2 = false;
  // QUADpack coarse current per motor (DIP switches 0/33/66/100 %, L197-204, L512); not readable.
  std::array<int, 6> quad_dip_percent = {100, 100, 100, 100, 100, 100};
  std::array<MotorWorld, 6> world{};
};

// Registers of one motor, defaults of §5.12.
struct MotorRegisters {
  // `$10` / `$11`
  uint8_t peak_current = 128;
  std::array<uint8_t, 4> current_index = {8, 2, 1, 0};  // I0..I3
  uint16_t t0 = 500;
  // `$13` / `$14`
  int vmin = 4;
  int vstart = 5;
  int div = 2;
  int amax = 128;
  int vmax = 511;
  // `$15`
  int64_t poslimit = 6400;
  uint16_t motor_type = 0x0AA0;  // DelayTestNull|NullCenter|FilterSwitch|FastRef (G-33)
  // `$16`
  int vrefmax = 100;
  uint16_t debounce_mask = 0x0FFF;
  bool stop_after_search = false;
  // `$18`
  int32_t nulloffset = 0;
  uint16_t testnullrange = 240;
  // `$19`
  int propdiv = 8;
  int intdiv = 129;
  int intclip = 129;
  int intinpclip = 1;
  // `$31` (channel = motor)
  uint16_t stop_min_left = 0;
  uint16_t stop_max_right = 1023;
};

// Dynamic state of one motor.
struct MotorState {
  int32_t position = 0;  // posact, microsteps (L660)
  int64_t rotor = 0;     // physical rotor position in world coordinates
  int32_t target = 0;
  int32_t v64 = 0;  // 64 × vact (§5.3 fixed point)
  Action action = Action::kInactive;
  bool stop_flag = false;  // `$20` P6 bit 0, cleared on read (L663)
  bool switch_filtered = false;
  int rotation_velocity = 0;  // `$25` target velocity
  int64_t pi_integral = 0;
  bool decelerating = false;
};

struct Globals {
  int clkdiv = 5;
  std::array<uint8_t, 16> table = {13,  37,  62,  86,  109, 131, 152, 171,
                                   189, 205, 219, 231, 240, 247, 252, 255};  // §5.10
  uint8_t ready_active_mask = 0x3F;
  uint8_t ready_reference_mask = 0x3F;
  // `$32` P0..P3 bit 0; reset state TTLOUT1 high (READY), TTLIO1 input, ready function off (G-20).
  std::array<uint8_t, 4> outputs = {1, 1, 0, 0};
  uint16_t baud_divisor = 65;   // 19200 baud (L273)
  uint16_t switchover = 3;      // 6 ms (L833)
  uint16_t packet_timeout = 0;  // 0 = not set (G-04, decision 1037)
  uint8_t tunnel_address = 0;
  uint8_t tunnel_packet_size = 0;
  bool power_down_enabled = false;
  bool power_down_state = false;
};

// The position save area of `$45`: EEPROM, so it survives `$CC` and power cycles (L877-885).
struct PositionEeprom {
  bool valid = false;
  std::array<int32_t, 6> positions{};
};

class Controller {
 public:
  // InvalidArgument for axes other than 4/6, address 0 or an amax divisor other than 16/64.
  static absl::StatusOr<Controller> Create(const ControllerOptions& options);

  // Executes one decoded word. Returns the reply bytes (R8 or R9, §2.4) for queries, nullopt for
  // silent commands, ignored words (G-06) and a `$28` whose delayed reply is still pending.
  std::optional<std::vector<uint8_t>> Handle(const Command& command);

  // Advances time in 2 ms cycles; the remainder below one cycle is kept.
  void Advance(Duration dt);

  // The delayed `$28` reply, once all masked motors are inactive (L740); taken once.
  std::optional<std::vector<uint8_t>> TakeDelayedReply();

  // Power cycle / `$CC`: defaults restored, positions 0, reset flag 1 (L853, L902).
  void Reset();
  // Number of resets so far (construction counts as one): a server emits the stray `00` byte
  // (L228, L902) when this grows under a `$CC`.
  uint64_t reset_count() const { return reset_count_; }
  // A `$28` whose delayed reply is still outstanding (L740).
  bool delayed_pending() const { return delayed_.has_value(); }

  // ---- Introspection and fault injection (§7 "Test support") ----
  const MotorRegisters& registers(int motor) const { return regs_[motor]; }
  const MotorState& state(int motor) const { return state_[motor]; }
  // Motion log for fault-injection properties: every ramp target a word started or changed
  // (`$1A` start ramp, `$1E` set target), as (motor, target), in order.
  struct StartedTarget {
    int motor = 0;
    int32_t target = 0;
    friend bool operator==(const StartedTarget&, const StartedTarget&) = default;
  };
  const std::vector<StartedTarget>& started_targets() const { return started_targets_; }
  const Globals& globals() const { return globals_; }
  uint8_t address() const { return address_; }
  bool reset_flag() const { return reset_flag_; }
  bool busy() const { return busy_ > Duration::zero(); }
  int axes() const { return options_.axes; }
  int64_t ticks() const { return ticks_; }
  int vact(int motor) const { return state_[motor].v64 / 64; }
  bool SwitchActive(int motor) const;
  MotorWorld& world(int motor) { return options_.world[motor]; }
  void SetStuckSwitch(int motor, std::optional<bool> level) { stuck_[motor] = level; }
  // Moves the rotor against the counter (lost steps).
  void LoseSteps(int motor, int64_t steps) { state_[motor].rotor += steps; }
  void SetFraming(ReplyFraming framing) { options_.framing = framing; }
  ReplyFraming framing() const { return options_.framing; }
  // Supply voltage (channel 7, L779) and the `$45` undervoltage detection below 13 V (L877).
  void SetSupplyVolts(double volts) { options_.supply_volts = volts; }
  double supply_volts() const { return options_.supply_volts; }
  void SetAnalog(int motor, uint16_t value) { options_.world[motor].analog = value; }
  const PositionEeprom& eeprom() const { return eeprom_; }
  // Peak coil current of the motor's pair in mA (`$10`, L505-512).
  double PeakCurrentMa(int motor) const;
  // Present coil current in mA (`$11` indices and T0 stand-by, §5.9, G-09, decision 1044).
  double CoilCurrentMa(int motor) const;
  // TTLOUT1 level (true = high = READY) from `$32` and the `$33` masks (L803-825, decision 1044).
  bool Ttlout1High() const;
  // 7-segment display: number of active motors, decimal point while a reference search runs (L66).
  int DisplayDigit() const;
  bool DisplayPoint() const;
  // Motion commands are refused while the `$45` power-down state holds the motors (L877, L891).
  bool motors_disabled() const { return globals_.power_down_enabled && globals_.power_down_state; }
  // Microsteps per velocity unit K (§5.1) for the motor's div (or div 3 for vmin, L543).
  double K(int motor, bool vmin_div) const;

 private:
  explicit Controller(const ControllerOptions& options);
  std::vector<uint8_t> EncodeReply(uint8_t ra, drivegw::trinamic::Opcode opcode,
                                   std::array<int64_t, 7> values) const;
  void Execute(const Command& c);
  void Tick();
  void TickMotor(int m);
  void RampStep(int m, int vmax, int amax);
  void StepAtVelocity(int m, int v64, bool vmin_div);
  int64_t Steps(int m, int64_t v64, bool vmin_div);
  int64_t BrakeDistance(int m, int64_t v, int amax) const;
  void ReleaseInterpolation(int m);
  void StartReferenceSearch(int m);
  void ReferenceTick(int m);
  void CheckStopConditions(int m);
  void CheckSupply();
  void UpdateCurrents(int m);
  void StopCondition(int m);
  void MoveCounter(int m, int64_t steps);
  bool Moving(int m) const { return state_[m].action != Action::kInactive; }
  bool AnyMoving() const;
  void UpdateSwitch(int m);
  void Wrap(int m);
  bool Flag(int m, uint16_t bit) const { return (regs_[m].motor_type & bit) != 0; }
  int Dir(int m) const;

  ControllerOptions options_;
  uint8_t address_;
  Globals globals_;
  std::array<MotorRegisters, 6> regs_{};
  std::array<MotorState, 6> state_{};
  std::vector<StartedTarget> started_targets_;
  std::array<int64_t, 6> accumulator_{};
  std::array<int, 6> switch_samples_{};
  std::array<std::optional<bool>, 6> stuck_{};
  // Reference search bookkeeping (§5.7).
  struct RefSearch {
    Action previous = Action::kInactive;
    int32_t previous_target = 0;
    int previous_rotation = 0;
    int64_t travel_start = 0;
    std::optional<int64_t> fast_found;
    int64_t p1 = 0;
  };
  std::array<RefSearch, 6> ref_{};
  // `$50` interpolation: master per slave (-1 = none) and the master's reduced limits (§5.5).
  std::array<int, 6> interp_master_{-1, -1, -1, -1, -1, -1};
  std::array<int32_t, 6> interp_start_{};
  std::array<int64_t, 6> interp_delta_{};
  std::array<int, 6> interp_vmax_{};
  std::array<int, 6> interp_amax_{};
  std::array<int32_t, 6> previous_v64_{};
  std::array<int64_t, 6> standing_ticks_{};  // ticks at rest since the last motion (T0, L524)
  std::array<bool, 6> velocity_changing_{};
  PositionEeprom eeprom_;
  uint64_t reset_count_ = 0;
  bool reset_flag_ = true;
  Duration busy_{};
  Duration remainder_{};
  int64_t ticks_ = 0;
  std::optional<std::pair<uint8_t, uint8_t>> delayed_;  // RA, mask of a pending `$28`
};

}  // namespace drivegw::sim::trinamic
