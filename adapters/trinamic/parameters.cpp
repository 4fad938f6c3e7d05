// Trinamic parameter catalogue (one definition per writable configuration field) and the per-axis
// shadow with the CT-55 validation rules (trinamic-sixpack.md §4.2, §5.12, §8.7; decisions
// 1071-1074).
#include "adapters/trinamic/parameters.h"

#include <array>
#include <charconv>
#include <cmath>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/parameter_catalogue.h"
#include "adapters/trinamic/units.h"

namespace drivegw::trinamic {
namespace {

using O = Opcode;
using S = ParameterScope;
using W = WriteRule;

// One catalogue row. The range comes from the codec's FieldSpec (decision 1014); `line` is the
// manual line cited by range errors.
struct Row {
  Opcode opcode;
  const char* field;
  ParameterScope scope;
  WriteRule rule;
  int64_t default_value;  // §5.12 (L359-371); sim/trinamic/controller.h holds the same values
  const char* unit;
  const char* line;
  const char* description;
};

// In opcode order: ApplyCommands emits one word per opcode in this order. `$17` (microstep
// table) is left out: its four entries per word are addressed by a pointer in P0, so the
// P-index id scheme cannot name them (decision 1071).
constexpr std::array kRows = {
    Row{O::kPeakCurrent, "value", S::kAxis, W::kAnyTime, 128, "1/256 of Imax full scale", "L511",
        "Peak current of the motor pair 0+1/2+3/4+5 (SIXpack 0.8 A x value/256, QUADpack 1.5 A x "
        "value/256 x DIP), sent with motnr 0/2/4 (L505-512)"},
    Row{O::kCurrentControl, "i0", S::kAxis, W::kAnyTime, 8, "current index (0=100 % .. 8=0 %)",
        "L520", "I0: current after T0 at standstill (L516-520)"},
    Row{O::kCurrentControl, "i1", S::kAxis, W::kAnyTime, 2, "current index (0=100 % .. 8=0 %)",
        "L520", "I1: current while the motor stands still (L516-520)"},
    Row{O::kCurrentControl, "i2", S::kAxis, W::kAnyTime, 1, "current index (0=100 % .. 8=0 %)",
        "L520", "I2: current at constant velocity (L516-520)"},
    Row{O::kCurrentControl, "i3", S::kAxis, W::kAnyTime, 0, "current index (0=100 % .. 8=0 %)",
        "L520", "I3: current while accelerating and decelerating (L516-520, G-09)"},
    Row{O::kCurrentControl, "t0", S::kAxis, W::kAnyTime, 500, "2 ms", "L524",
        "T0: power-down delay at standstill, also the DelayTestNull delay (L524-528)"},
    Row{O::kVelocitySetting, "clkdiv", S::kController, W::kAllStopped, 5, "clock divider", "L493",
        "Clock divider of all motors: f = 20 MHz/(clkdiv+1) x v/2^(14+div); all motors stopped "
        "(L530-535, L493)"},
    Row{O::kStartingVelocity, "vmin", S::kAxis, W::kAxisStopped, 4, "velocity register (div 3)",
        "L543", "Slow reference approach velocity at div 3, 0 = automatic, <= vstart (L543-544)"},
    Row{O::kStartingVelocity, "vstart", S::kAxis, W::kAxisStopped, 5, "velocity register", "L545",
        "Start/end velocity of the ramp; amax <= vstart x 64 (L545, L559, G-08)"},
    Row{O::kStartingVelocity, "div", S::kAxis, W::kAxisStopped, 2, "predivider exponent", "L495",
        "Per-motor velocity predivider div_i (L495, L537-546)"},
    Row{O::kSetRamp, "amax", S::kAxis, W::kAnyTime, 128, "1/64 velocity register per 2 ms", "L556",
        "Acceleration: amax/64 added to vact every 2 ms; 0 < amax <= vstart x 64 (L556-559)"},
    Row{O::kSetRamp, "vmax", S::kAxis, W::kAnyTime, 511, "velocity register", "L560",
        "Maximum velocity, evaluated at once, also during motion (L552, L560-561)"},
    Row{O::kMotorParameters, "poslimit", S::kAxis, W::kAnyTime, 6400, "microsteps", "L570",
        "Microsteps per revolution (rotary) or total travel (linear, reference search) (L570-571, "
        "G-37)"},
    Row{O::kMotorParameters, "motor_type_low", S::kAxis, W::kAnyTime, 0xA0, "bits", "L573",
        "Motor type bits 0-7: PI, RotaryAxis, AutoNullCmd, TestNull, NullLeft, NullCenter, "
        "StopNull, FilterSwitch (L573-586, G-33)"},
    Row{O::kMotorParameters, "motor_type_high", S::kAxis, W::kAnyTime, 0x0A, "bits", "L587",
        "Motor type bits 8-15: WayOptimization, FastRef, MechRef, DelayTestNull, StopSoft, "
        "StopNoRef, NullPositive, StopAtFullsteps (L587-603, G-10, G-33)"},
    Row{O::kReferenceParameters, "vrefmax", S::kAxis, W::kAxisStopped, 100, "velocity register",
        "L613", "Fast reference search velocity, vrefmax <= vmax; motor stopped (L609-614)"},
    Row{O::kReferenceParameters, "debounce_mask", S::kAxis, W::kAxisStopped, 0x0FFF,
        "bits (2 ms samples)", "L615",
        "Reference switch de-bounce window, $0FFF = 22 ms; motor stopped (L615, L368)"},
    Row{O::kReferenceParameters, "stop_after_search", S::kAxis, W::kAxisStopped, 0, "flag", "L616",
        "1 = stop after the reference search, 0 = resume the previous action (L616, L680)"},
    Row{O::kNullOffset, "nulloffset", S::kAxis, W::kAnyTime, 0, "microsteps", "L629",
        "Distance between zero point and reference switch (L629, L633, G-12)"},
    Row{O::kNullOffset, "testnullrange", S::kAxis, W::kAnyTime, 240, "microsteps", "L634",
        "Zero switch tolerance +/- around the zero point before StopNull (L629, L634)"},
    Row{O::kPiParameters, "propdiv", S::kAxis, W::kAnyTime, 8, "divisor", "L636",
        "PI proportional part = 64 x position difference / propdiv (L636-645)"},
    Row{O::kPiParameters, "intdiv", S::kAxis, W::kAnyTime, 129, "divisor", "L636",
        "PI divisor of the integral part (L636-645)"},
    Row{O::kPiParameters, "intclip", S::kAxis, W::kAnyTime, 129, "microsteps x 2 ms", "L636",
        "PI clip limit of the position-difference integral (L636-645)"},
    Row{O::kPiParameters, "intinpclip", S::kAxis, W::kAnyTime, 1, "microsteps", "L636",
        "PI: position difference clipped to this before integration (L636-645)"},
    Row{O::kAnalogStopLimits, "min_left", S::kAxis, W::kAnyTime, 0, "ADC counts", "L796",
        "Analogue stop: minimum value while moving left, 0 = off; channel = motor (L794-801, "
        "decision 1014)"},
    Row{O::kAnalogStopLimits, "max_right", S::kAxis, W::kAnyTime, 1023, "ADC counts", "L796",
        "Analogue stop: maximum value while moving right, >= 1023 = off (L794-801)"},
    Row{O::kSetOutputs, "ttlout1_level", S::kController, W::kAnyTime, 1, "flag", "L803",
        "TTLOUT1 logic level, 1 = high/READY; reset state per G-20 (L803-814)"},
    Row{O::kSetOutputs, "ttlio1_direction", S::kController, W::kAnyTime, 1, "flag", "L803",
        "TTLIO1 direction, 1 = input, 0 = output; reset state per G-20 (L803-814)"},
    Row{O::kSetOutputs, "ttlio1_level", S::kController, W::kAnyTime, 0, "flag", "L803",
        "TTLIO1 logic level when it is an output (L803-814)"},
    Row{O::kSetOutputs, "ttlout1_ready", S::kController, W::kAnyTime, 0, "flag", "L803",
        "1 = TTLOUT1 works as ready output; off after reset per G-20 (L803-814)"},
    Row{O::kReadyOutput, "active_mask", S::kController, W::kAnyTime, 0x3F, "motor mask", "L816",
        "Motors whose activity makes the ready output active (L816-825, L368)"},
    Row{O::kReadyOutput, "reference_mask", S::kController, W::kAnyTime, 0x3F, "motor mask", "L816",
        "Motors whose reference search makes the ready output active (L816-825, L368)"},
    Row{O::kSetBaudRate, "divisor", S::kController, W::kAnyTime, 65, "1 250 000 / baud", "L832",
        "Serial baud-rate divisor, 65 = 19200 baud (L829-832, G-40)"},
    Row{O::kSetBaudRate, "switchover", S::kController, W::kAnyTime, 3, "2 ms", "L833",
        "RS-485 transmitter switchover delay, 1..1000 (L833)"},
    Row{O::kSetPacketTimeout, "timeout", S::kController, W::kAnyTime, 50, "2 ms", "L838",
        "Packet abort timeout, at least one 9-byte word at the line rate (L835-838, G-04)"},
};

constexpr uint32_t kI1 = ParameterId(O::kCurrentControl, 2);
constexpr uint32_t kI3 = ParameterId(O::kCurrentControl, 4);
constexpr uint32_t kClkdiv = ParameterId(O::kVelocitySetting, 0);
constexpr uint32_t kVmin = ParameterId(O::kStartingVelocity, 1);
constexpr uint32_t kVstart = ParameterId(O::kStartingVelocity, 3);
constexpr uint32_t kDiv = ParameterId(O::kStartingVelocity, 5);
constexpr uint32_t kAmax = ParameterId(O::kSetRamp, 1);
constexpr uint32_t kVmax = ParameterId(O::kSetRamp, 3);
constexpr uint32_t kPoslimit = ParameterId(O::kMotorParameters, 1);
constexpr uint32_t kTypeLow = ParameterId(O::kMotorParameters, 5);
constexpr uint32_t kTypeHigh = ParameterId(O::kMotorParameters, 6);
constexpr uint32_t kVrefmax = ParameterId(O::kReferenceParameters, 1);
constexpr uint32_t kDivisor = ParameterId(O::kSetBaudRate, 0);
constexpr uint32_t kTimeout = ParameterId(O::kSetPacketTimeout, 0);

constexpr int64_t kRotaryAxisBit = motor_type::kRotaryAxis;  // in the low byte (P5)
constexpr int64_t kMechRefBit = motor_type::kMechRef >> 8;   // in the high byte (P6)
constexpr double kBaudClock = 1'250'000.0;                   // baud = 1 250 000 / divisor (L832)
constexpr double kWordBits = static_cast<double>(kCommandSize) * 10.0;  // 9 bytes of 8N1 (G-03)

std::string HexDigits(uint32_t v, int digits) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string s(static_cast<size_t>(digits), '0');
  for (int i = digits - 1; i >= 0; --i, v >>= 4) s[static_cast<size_t>(i)] = kDigits[v & 0xF];
  return s;
}

const FieldSpec* FieldOf(Opcode opcode, std::string_view field) {
  for (const FieldSpec& f : SpecOf(opcode).Fields()) {
    if (field == f.name) return &f;
  }
  return nullptr;
}

struct Catalogue {
  std::vector<ParameterDefinition> definitions;
  std::vector<const Row*> rows;  // parallel to definitions
};

const Catalogue& TheCatalogue() {
  static const Catalogue catalogue = [] {
    Catalogue c;
    for (const Row& r : kRows) {
      const FieldSpec* f = FieldOf(r.opcode, r.field);
      if (f == nullptr) continue;  // the catalogue test catches a misspelt field
      ParameterDefinition d;
      d.id = ParameterId(r.opcode, f->param);
      d.name = absl::StrCat("$", HexDigits(static_cast<uint8_t>(r.opcode), 2), ".", r.field);
      d.opcode = r.opcode;
      d.field = r.field;
      d.scope = r.scope;
      d.rule = r.rule;
      d.min = f->min;
      d.max = f->max;
      d.default_value = r.default_value;
      d.unit = r.unit;
      d.description = r.description;
      c.definitions.push_back(std::move(d));
      c.rows.push_back(&r);
    }
    return c;
  }();
  return catalogue;
}

const Row* RowOf(uint32_t id) {
  const Catalogue& c = TheCatalogue();
  for (size_t i = 0; i < c.definitions.size(); ++i) {
    if (c.definitions[i].id == id) return c.rows[i];
  }
  return nullptr;
}

std::optional<ParameterScope> ScopeOfOpcode(Opcode opcode) {
  for (const ParameterDefinition& d : TheCatalogue().definitions) {
    if (d.opcode == opcode) return d.scope;
  }
  return std::nullopt;
}

// "4.69" — two decimals without pulling in str_format.
std::string Fixed2(double v) {
  const int64_t hundredths = std::llround(v * 100.0);
  const int64_t frac = hundredths % 100;
  return absl::StrCat(hundredths / 100, ".", frac < 10 ? "0" : "", frac);
}

// Duration of one 9-byte word on the line in ms (10 bits per byte, 8N1: G-03).
double WordMs(double baud) { return kWordBits * 1000.0 / baud; }

absl::Status Invalid(std::string message) { return absl::InvalidArgumentError(message); }

}  // namespace

std::span<const ParameterDefinition> ParameterCatalogue() { return TheCatalogue().definitions; }

absl::StatusOr<const ParameterDefinition*> FindParameter(uint32_t id) {
  for (const ParameterDefinition& d : TheCatalogue().definitions) {
    if (d.id == id) return &d;
  }
  return absl::NotFoundError(absl::StrCat(
      "parameter id 0x", HexDigits(id, 4), " ($", HexDigits((id >> 8) & 0xFF, 2), " P", id & 0xFF,
      ") is not in the Trinamic catalogue; ids are opcode << 8 | P index of the field, e.g. "
      "0x1403 = $14.vmax (see ListParameterDefinitions)"));
}

absl::StatusOr<const ParameterDefinition*> FindParameter(std::string_view name) {
  if (name.size() > 2 && name[0] == '0' && (name[1] == 'x' || name[1] == 'X')) {
    uint32_t id = 0;
    const char* first = name.data() + 2;
    const char* last = name.data() + name.size();
    const auto [ptr, ec] = std::from_chars(first, last, id, 16);
    if (ec == std::errc() && ptr == last && id <= 0xFFFF) {
      auto found = FindParameter(id);
      if (found.ok()) return found;
    }
  } else {
    for (const ParameterDefinition& d : TheCatalogue().definitions) {
      if (NameEqualsIgnoreCase(d.name, name)) return &d;
    }
  }
  return absl::NotFoundError(absl::StrCat(
      "parameter \"", std::string(name),
      "\" is not in the Trinamic catalogue; use a name like \"$14.vmax\" or an id like "
      "\"0x1403\" (see ListParameterDefinitions)"));
}

std::optional<std::string> ParameterWarning(uint32_t id, int64_t value) {
  if (id == kVstart && value < 8) {
    return absl::StrCat("$13.vstart: ", value,
                        " is below 8; the manual's default comment asks for >= 8 (L363, G-08)");
  }
  if (id >= kI1 && id <= kI3 && value > 5) {
    static constexpr std::array<const char*, 9> kPercent = {"100", "75", "50", "38", "25",
                                                            "19",  "13", "9",  "0"};
    const auto def = FindParameter(id);
    return absl::StrCat((*def)->name, ": index ", value, " (",
                        value <= 8 ? kPercent[static_cast<size_t>(value)] : "?",
                        " %) is below the 19 % needed for proper microstepping (L329, G-09)");
  }
  return std::nullopt;
}

ParameterShadow::ParameterShadow(uint8_t axis, int axes) : axis_(axis), axes_(axes) {
  for (const ParameterDefinition& d : TheCatalogue().definitions) values_[d.id] = d.default_value;
}

int64_t ParameterShadow::Get(uint32_t id) const {
  const auto it = values_.find(id);
  return it == values_.end() ? 0 : it->second;
}

int64_t ParameterShadow::Get(Opcode opcode, std::string_view field) const {
  const FieldSpec* f = FieldOf(opcode, field);
  return f == nullptr ? 0 : Get(ParameterId(opcode, f->param));
}

void ParameterShadow::Set(uint32_t id, int64_t value) {
  const auto it = values_.find(id);
  if (it != values_.end()) it->second = value;
}

int ParameterShadow::clkdiv() const { return static_cast<int>(Get(kClkdiv)); }
int ParameterShadow::div() const { return static_cast<int>(Get(kDiv)); }

absl::Status ParameterShadow::Validate(uint32_t id, int64_t value, int baud) const {
  const auto found = FindParameter(id);
  if (!found.ok()) return found.status();
  const ParameterDefinition& d = **found;
  const Row& row = *RowOf(id);
  const std::string head = absl::StrCat(d.name, ": ", value);

  if (d.scope == ParameterScope::kAxis && axis_ >= axes_) {
    return Invalid(absl::StrCat(d.name, ": axis ", axis_, " exceeds ", axes_ - 1, " (the PACK has ",
                                axes_, " motors, G-17, L475)"));
  }
  if (value < d.min) return Invalid(absl::StrCat(head, " below ", d.min, " (", row.line, ")"));
  if (value > d.max) return Invalid(absl::StrCat(head, " exceeds ", d.max, " (", row.line, ")"));
  if (baud <= 0) return Invalid(absl::StrCat("baud: ", baud, " below 1"));
  // G-40: the gateway switches its own port to the new rate, so only divisors of standard
  // termios rates are accepted (§2.1 table, L832).
  if (id == kDivisor) {
    if (auto b = BaudOfDivisor(value); !b.ok()) return b.status();
  }

  // Every cross-field rule sees the candidate value for `id` and the shadow for the rest.
  const auto v = [&](uint32_t k) { return k == id ? value : Get(k); };

  // L556-559: 0 < amax <= vstart x 64.
  if ((id == kAmax || id == kVstart) && v(kAmax) > v(kVstart) * 64) {
    if (id == kAmax) {
      return Invalid(absl::StrCat(head, " exceeds vstart x 64 = ", v(kVstart) * 64, " (L556)"));
    }
    return Invalid(
        absl::StrCat(head, " x 64 = ", value * 64, " is below amax ", v(kAmax), " (L556)"));
  }
  // L543-544: vmin <= vstart.
  if ((id == kVmin || id == kVstart) && v(kVmin) > v(kVstart)) {
    if (id == kVmin) return Invalid(absl::StrCat(head, " exceeds vstart ", v(kVstart), " (L544)"));
    return Invalid(absl::StrCat(head, " below vmin ", v(kVmin), " (L544)"));
  }
  // L613-614: vrefmax <= vmax.
  if ((id == kVrefmax || id == kVmax) && v(kVrefmax) > v(kVmax)) {
    if (id == kVrefmax) {
      return Invalid(absl::StrCat(head, " exceeds vmax ", v(kVmax), " (L613)"));
    }
    return Invalid(absl::StrCat(head, " below vrefmax ", v(kVrefmax), " (L613)"));
  }
  // L497: no velocity register may give more than 200 kHz microstep frequency. vmax, vrefmax and
  // vstart run at this motor's div; vmin is always evaluated with div 3 (L541).
  if (id == kClkdiv || id == kDiv || id == kVmax || id == kVrefmax || id == kVstart ||
      id == kVmin) {
    struct Check {
      uint32_t velocity;
      const char* name;
      bool div3;
    };
    for (const Check& c : {Check{kVmax, "vmax", false}, Check{kVrefmax, "vrefmax", false},
                           Check{kVstart, "vstart", false}, Check{kVmin, "vmin", true}}) {
      if (id != kClkdiv && id != kDiv && id != c.velocity) continue;
      const VelocityScale scale{static_cast<int>(v(kClkdiv)),
                                c.div3 ? 3 : static_cast<int>(v(kDiv))};
      const auto k = MicrostepsPerVelocityUnit(scale);
      if (!k.ok()) return k.status();
      const double hz = *k * static_cast<double>(v(c.velocity));
      if (hz <= kMaxMicrostepHz) continue;
      const std::string at = absl::StrCat("clkdiv ", scale.clkdiv, ", div ", scale.div);
      if (id == c.velocity) {
        return Invalid(absl::StrCat(head, " at ", at, " is ", std::llround(hz),
                                    " Hz microstep frequency, above 200000 Hz (L497)"));
      }
      return Invalid(absl::StrCat(head, " puts ", c.name, " ", v(c.velocity), " at ",
                                  std::llround(hz), " Hz microstep frequency (", at,
                                  "), above 200000 Hz (L497)"));
    }
  }
  // L838: the packet timeout must not expire while one 9-byte word is still arriving.
  if (id == kTimeout || id == kDivisor) {
    const double line_baud = id == kDivisor ? kBaudClock / static_cast<double>(value) : baud;
    const double word_ms = WordMs(line_baud);
    const int64_t timeout = v(kTimeout);
    if (static_cast<double>(timeout) * 2.0 < word_ms) {
      if (id == kTimeout) {
        return Invalid(absl::StrCat(head, " (", timeout * 2,
                                    " ms) is shorter than one 9-byte word at ", baud, " baud (",
                                    Fixed2(word_ms), " ms) (L838)"));
      }
      return Invalid(absl::StrCat(
          head, " (", std::llround(line_baud), " baud) makes one 9-byte word ", Fixed2(word_ms),
          " ms, longer than the packet timeout ", timeout, " x 2 ms (L838)"));
    }
  }
  // G-37: poslimit 0 is meaningless for a rotary axis (cycle length) and for a mechanical
  // reference (5/4 x poslimit is driven), L570-571, L589-590.
  const bool rotary = (v(kTypeLow) & kRotaryAxisBit) != 0;
  const bool mech_ref = (v(kTypeHigh) & kMechRefBit) != 0;
  if (v(kPoslimit) == 0 && (rotary || mech_ref)) {
    if (id == kPoslimit) {
      return Invalid(absl::StrCat(head, " with ", rotary ? "RotaryAxis" : "MechRef",
                                  " set in the motor type; must be 1..134217727 (L570, G-37)"));
    }
    if (id == kTypeLow || id == kTypeHigh) {
      return Invalid(absl::StrCat(head, " sets ", id == kTypeLow ? "RotaryAxis" : "MechRef",
                                  " while poslimit is 0 (L570, G-37)"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<Command> ParameterShadow::WriteCommand(uint8_t address, uint32_t id, int64_t value,
                                                      int baud) const {
  if (auto s = Validate(id, value, baud); !s.ok()) return s;
  const ParameterDefinition& d = **FindParameter(id);
  ParameterShadow next = *this;
  next.values_[id] = value;
  Command c = next.Word(address, d.opcode);
  if (auto s = ValidateCommand(c); !s.ok()) return s;
  return c;
}

Command ParameterShadow::Word(uint8_t address, Opcode opcode) const {
  Command c{address, opcode, {}};
  const OpcodeSpec& spec = SpecOf(opcode);
  const bool axis_scoped = ScopeOfOpcode(opcode) == ParameterScope::kAxis;
  for (size_t i = 0; i < spec.field_count; ++i) {
    if (axis_scoped && i == 0) {
      // P0 selects the motor (motnr; `$31` channel = motor, decision 1014). `$10` is set per
      // pair and only the even motnr is effective (L507).
      c.values[i] = opcode == Opcode::kPeakCurrent ? (axis_ & ~1) : axis_;
    } else {
      c.values[i] = Get(ParameterId(opcode, spec.fields[i].param));
    }
  }
  return c;
}

void ParameterShadow::Absorb(const Command& command) {
  const std::optional<ParameterScope> scope = ScopeOfOpcode(command.opcode);
  if (!scope.has_value()) return;
  // The PACK ignores a word outside the ranges (G-06, decision 1031), so the shadow does too.
  if (!ValidateCommand(command).ok()) return;
  if (*scope == ParameterScope::kAxis) {
    const int64_t motor = command.values[0];
    if (command.opcode == Opcode::kPeakCurrent) {
      // L507: only motnr 0/2/4 are valid and set both motors of the pair.
      if (motor % 2 != 0 || motor != (axis_ & ~1)) return;
    } else if (motor != axis_) {
      return;
    }
  }
  const OpcodeSpec& spec = SpecOf(command.opcode);
  for (size_t i = 0; i < spec.field_count; ++i) {
    Set(ParameterId(command.opcode, spec.fields[i].param), command.values[i]);
  }
}

std::vector<Command> ParameterShadow::ApplyCommands(uint8_t address, bool controller) const {
  std::vector<Command> out;
  std::optional<Opcode> last;
  for (const ParameterDefinition& d : TheCatalogue().definitions) {
    if (last == d.opcode) continue;
    last = d.opcode;
    if (d.scope == ParameterScope::kController && !controller) continue;
    out.push_back(Word(address, d.opcode));
  }
  return out;
}

}  // namespace drivegw::trinamic
