// Trinamic parameter catalogue and shadow: catalogue shape and §5.12 defaults, FindParameter, every
// CT-55 rejection by name and message, byte-exact words (CT-43, CT-44, CT-57), the `$10` pair rule
// (L505-512), Absorb, ApplyCommands, and the apply words executed by the simulated PACK.
#include "adapters/trinamic/parameters.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/trinamic/codec.h"
#include "sim/trinamic/controller.h"

namespace drivegw::trinamic {
namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

uint32_t Id(std::string_view name) {
  auto def = FindParameter(name);
  EXPECT_TRUE(def.ok()) << name << ": " << def.status();
  return def.ok() ? (*def)->id : 0;
}

std::vector<uint8_t> Bytes(const Command& c) {
  auto wire = EncodeCommand(c);
  EXPECT_TRUE(wire.ok()) << wire.status();
  return wire.ok() ? *wire : std::vector<uint8_t>{};
}

// Sets a value the way the drive does: validate, build the word, then record it as sent.
void Write(ParameterShadow& shadow, std::string_view name, int64_t value, int baud = 19200) {
  auto word = shadow.WriteCommand(1, Id(name), value, baud);
  ASSERT_TRUE(word.ok()) << name << "=" << value << ": " << word.status();
  shadow.Absorb(*word);
  ASSERT_EQ(shadow.Get(Id(name)), value) << name;
}

// The rejection message for `name` = `value`; "" if it was accepted.
std::string Rejection(const ParameterShadow& shadow, std::string_view name, int64_t value,
                      int baud = 19200) {
  const absl::Status s = shadow.Validate(Id(name), value, baud);
  if (s.ok()) return "";
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  // CT-55: a refused value produces no word.
  EXPECT_FALSE(shadow.WriteCommand(1, Id(name), value, baud).ok()) << name;
  return std::string(s.message());
}

// ---- Catalogue --------------------------------------------------------------------------

TEST(TrinamicParameterCatalogue, HoldsEveryWritableConfigurationField) {
  std::vector<std::string> names;
  for (const ParameterDefinition& d : ParameterCatalogue()) names.push_back(d.name);
  EXPECT_THAT(
      names,
      ElementsAre("$10.value", "$11.i0", "$11.i1", "$11.i2", "$11.i3", "$11.t0", "$12.clkdiv",
                  "$13.vmin", "$13.vstart", "$13.div", "$14.amax", "$14.vmax", "$15.poslimit",
                  "$15.motor_type_low", "$15.motor_type_high", "$16.vrefmax", "$16.debounce_mask",
                  "$16.stop_after_search", "$18.nulloffset", "$18.testnullrange", "$19.propdiv",
                  "$19.intdiv", "$19.intclip", "$19.intinpclip", "$31.min_left", "$31.max_right",
                  "$32.ttlout1_level", "$32.ttlio1_direction", "$32.ttlio1_level",
                  "$32.ttlout1_ready", "$33.active_mask", "$33.reference_mask", "$40.divisor",
                  "$40.switchover", "$41.timeout"));
}

TEST(TrinamicParameterCatalogue, IdsUniqueFromTheCodecTableAndDefaultsInRange) {
  std::set<uint32_t> ids;
  std::set<std::string> names;
  uint8_t last_opcode = 0;
  for (const ParameterDefinition& d : ParameterCatalogue()) {
    SCOPED_TRACE(d.name);
    EXPECT_TRUE(ids.insert(d.id).second);
    EXPECT_TRUE(names.insert(d.name).second);
    // id = opcode << 8 | P index of the codec field; range = the codec's range (decision 1014).
    const FieldSpec* spec = nullptr;
    for (const FieldSpec& f : SpecOf(d.opcode).Fields()) {
      if (d.field == f.name) spec = &f;
    }
    ASSERT_NE(spec, nullptr);
    EXPECT_EQ(d.id, ParameterId(d.opcode, spec->param));
    EXPECT_EQ(d.id >> 8, static_cast<uint32_t>(d.opcode));
    EXPECT_EQ(d.min, spec->min);
    EXPECT_EQ(d.max, spec->max);
    EXPECT_GE(d.default_value, d.min);
    EXPECT_LE(d.default_value, d.max);
    EXPECT_NE(d.field, "motnr");
    EXPECT_FALSE(d.unit.empty());
    EXPECT_THAT(d.description, HasSubstr("(L"));
    // Opcode order (ApplyCommands relies on it).
    EXPECT_GE(static_cast<uint8_t>(d.opcode), last_opcode);
    last_opcode = static_cast<uint8_t>(d.opcode);
    const bool controller = d.opcode == Opcode::kVelocitySetting ||
                            d.opcode == Opcode::kSetOutputs || d.opcode == Opcode::kReadyOutput ||
                            d.opcode == Opcode::kSetBaudRate ||
                            d.opcode == Opcode::kSetPacketTimeout;
    EXPECT_EQ(d.scope, controller ? ParameterScope::kController : ParameterScope::kAxis);
    // Defaults are valid as a set: a fresh shadow accepts every default again.
    EXPECT_TRUE(ParameterShadow(0, 6).Validate(d.id, d.default_value).ok());
  }
}

TEST(TrinamicParameterCatalogue, WriteRulesFollowTheManual) {
  // L532 `$12` all motors stopped; L539 `$13`, L609 `$16` this motor stopped; L552 `$14` at once.
  EXPECT_EQ((*FindParameter("$12.clkdiv"))->rule, WriteRule::kAllStopped);
  for (const char* n : {"$13.vmin", "$13.vstart", "$13.div", "$16.vrefmax", "$16.debounce_mask",
                        "$16.stop_after_search"}) {
    EXPECT_EQ((*FindParameter(n))->rule, WriteRule::kAxisStopped) << n;
  }
  for (const char* n : {"$14.amax", "$14.vmax", "$10.value", "$15.poslimit", "$41.timeout"}) {
    EXPECT_EQ((*FindParameter(n))->rule, WriteRule::kAnyTime) << n;
  }
}

// §5.12 defaults; the same values as the simulated PACK's reset state (sim/trinamic/controller.h).
TEST(TrinamicParameterCatalogue, DefaultsEqualTheSimulatorResetState) {
  const ParameterShadow s(0, 6);
  const sim::trinamic::MotorRegisters r;
  const sim::trinamic::Globals g;
  EXPECT_EQ(s.Get(Id("$10.value")), r.peak_current);
  EXPECT_EQ(s.Get(Id("$11.i0")), r.current_index[0]);
  EXPECT_EQ(s.Get(Id("$11.i1")), r.current_index[1]);
  EXPECT_EQ(s.Get(Id("$11.i2")), r.current_index[2]);
  EXPECT_EQ(s.Get(Id("$11.i3")), r.current_index[3]);
  EXPECT_EQ(s.Get(Id("$11.t0")), r.t0);
  EXPECT_EQ(s.Get(Id("$12.clkdiv")), g.clkdiv);
  EXPECT_EQ(s.Get(Id("$13.vmin")), r.vmin);
  EXPECT_EQ(s.Get(Id("$13.vstart")), r.vstart);
  EXPECT_EQ(s.Get(Id("$13.div")), r.div);
  EXPECT_EQ(s.Get(Id("$14.amax")), r.amax);
  EXPECT_EQ(s.Get(Id("$14.vmax")), r.vmax);
  EXPECT_EQ(s.Get(Id("$15.poslimit")), r.poslimit);
  EXPECT_EQ(s.Get(Id("$15.motor_type_low")), r.motor_type & 0xFF);  // G-33: A0
  EXPECT_EQ(s.Get(Id("$15.motor_type_high")), r.motor_type >> 8);   // G-33: 0A
  EXPECT_EQ(s.Get(Id("$16.vrefmax")), r.vrefmax);
  EXPECT_EQ(s.Get(Id("$16.debounce_mask")), r.debounce_mask);
  EXPECT_EQ(s.Get(Id("$16.stop_after_search")), r.stop_after_search ? 1 : 0);
  EXPECT_EQ(s.Get(Id("$18.nulloffset")), r.nulloffset);
  EXPECT_EQ(s.Get(Id("$18.testnullrange")), r.testnullrange);
  EXPECT_EQ(s.Get(Id("$19.propdiv")), r.propdiv);
  EXPECT_EQ(s.Get(Id("$19.intdiv")), r.intdiv);
  EXPECT_EQ(s.Get(Id("$19.intclip")), r.intclip);
  EXPECT_EQ(s.Get(Id("$19.intinpclip")), r.intinpclip);
  EXPECT_EQ(s.Get(Id("$31.min_left")), r.stop_min_left);
  EXPECT_EQ(s.Get(Id("$31.max_right")), r.stop_max_right);
  EXPECT_EQ(s.Get(Id("$33.active_mask")), g.ready_active_mask);
  EXPECT_EQ(s.Get(Id("$33.reference_mask")), g.ready_reference_mask);
  EXPECT_EQ(s.Get(Id("$40.divisor")), g.baud_divisor);
  EXPECT_EQ(s.Get(Id("$40.switchover")), g.switchover);
  // Not in §5.12: `$41` = the simulator's 100 ms before any `$41` (G-04, decision 1037), `$32` =
  // G-20 (TTLOUT1 high, TTLIO1 input, ready function off); decision 1072.
  EXPECT_EQ(s.Get(Id("$41.timeout")), 50);
  EXPECT_EQ(s.Get(Id("$32.ttlout1_level")), 1);
  EXPECT_EQ(s.Get(Id("$32.ttlio1_direction")), 1);
  EXPECT_EQ(s.Get(Id("$32.ttlio1_level")), 0);
  EXPECT_EQ(s.Get(Id("$32.ttlout1_ready")), 0);
  EXPECT_EQ(s.clkdiv(), 5);
  EXPECT_EQ(s.div(), 2);
}

// ---- FindParameter ----------------------------------------------------------------------

TEST(TrinamicFindParameter, ByIdAndByName) {
  auto vmax = FindParameter(uint32_t{0x1403});
  ASSERT_TRUE(vmax.ok());
  EXPECT_EQ((*vmax)->name, "$14.vmax");
  EXPECT_EQ((*vmax)->field, "vmax");
  EXPECT_EQ((*vmax)->opcode, Opcode::kSetRamp);
  EXPECT_EQ((*vmax)->unit, "velocity register");
  for (const char* n : {"$14.vmax", "$14.VMAX", "0x1403", "0X1403"}) {
    auto d = FindParameter(std::string_view(n));
    ASSERT_TRUE(d.ok()) << n << ": " << d.status();
    EXPECT_EQ(*d, *vmax) << n;
  }
  EXPECT_EQ((*FindParameter(std::string_view("0x4100")))->name, "$41.timeout");
  EXPECT_EQ((*FindParameter(std::string_view("0x001001")))->name, "$10.value");
  EXPECT_EQ(Id("$13.vstart"), 0x1303u);
  EXPECT_EQ(Id("$15.motor_type_high"), 0x1506u);
  EXPECT_EQ(Id("$19.intinpclip"), 0x1906u);
  EXPECT_EQ(Id("$40.switchover"), 0x4002u);
  EXPECT_EQ(Id("$31.max_right"), 0x3103u);
}

TEST(TrinamicFindParameter, NotFoundNamesWhatWasAskedAndHints) {
  auto by_id = FindParameter(uint32_t{0x1404});
  ASSERT_EQ(by_id.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(by_id.status().message(), HasSubstr("0x1404"));
  EXPECT_THAT(by_id.status().message(), HasSubstr("ListParameterDefinitions"));
  // `$17` is not in the catalogue (decision 1071); motnr is no parameter.
  EXPECT_FALSE(FindParameter(uint32_t{0x1701}).ok());
  EXPECT_FALSE(FindParameter(uint32_t{0x1400}).ok());
  for (const char* n : {"$14.vmx", "vmax", "$14", "0x", "0x1403x", "0x11403", "", "$20.posact"}) {
    auto d = FindParameter(std::string_view(n));
    ASSERT_EQ(d.status().code(), absl::StatusCode::kNotFound) << n;
    EXPECT_THAT(d.status().message(), HasSubstr(absl::StrCat("\"", n, "\""))) << n;
    EXPECT_THAT(d.status().message(), HasSubstr("ListParameterDefinitions")) << n;
  }
}

// ---- CT-55 validation -------------------------------------------------------------------

TEST(TrinamicParameterValidation, FieldRanges) {
  const ParameterShadow s(0, 6);
  EXPECT_EQ(Rejection(s, "$12.clkdiv", 32), "$12.clkdiv: 32 exceeds 31 (L493)");
  EXPECT_EQ(Rejection(s, "$12.clkdiv", -1), "$12.clkdiv: -1 below 0 (L493)");
  EXPECT_EQ(Rejection(s, "$13.div", 4), "$13.div: 4 exceeds 3 (L495)");
  EXPECT_EQ(Rejection(s, "$14.vmax", 512), "$14.vmax: 512 exceeds 511 (L560)");
  EXPECT_EQ(Rejection(s, "$14.amax", 0), "$14.amax: 0 below 1 (L556)");
  EXPECT_EQ(Rejection(s, "$40.switchover", 0), "$40.switchover: 0 below 1 (L833)");
  EXPECT_EQ(Rejection(s, "$40.switchover", 1001), "$40.switchover: 1001 exceeds 1000 (L833)");
  EXPECT_EQ(Rejection(s, "$41.timeout", 1), "$41.timeout: 1 below 2 (L838)");
  // G-08: vstart 1..511 accepted (the warning below 8 is separate).
  EXPECT_EQ(Rejection(s, "$13.vstart", 0), "$13.vstart: 0 below 1 (L545)");
  EXPECT_EQ(Rejection(s, "$13.vstart", 4), "");
  ParameterShadow low(0, 6);
  Write(low, "$13.vmin", 0);
  Write(low, "$14.amax", 64);
  EXPECT_EQ(Rejection(low, "$13.vstart", 1), "");
  EXPECT_EQ(Rejection(s, "$11.i0", 9), "$11.i0: 9 exceeds 8 (L520)");
  EXPECT_EQ(Rejection(s, "$19.propdiv", 0), "$19.propdiv: 0 below 1 (L636)");
  EXPECT_EQ(Rejection(s, "$16.stop_after_search", 2), "$16.stop_after_search: 2 exceeds 1 (L616)");
  EXPECT_EQ(Rejection(s, "$15.poslimit", 0x8000000),
            "$15.poslimit: 134217728 exceeds 134217727 (L570)");
  EXPECT_EQ(Rejection(s, "$33.active_mask", 0x40), "$33.active_mask: 64 exceeds 63 (L816)");
  EXPECT_EQ(Rejection(s, "$40.switchover", 1000), "");
  EXPECT_EQ(Rejection(s, "$14.vmax", 511), "");
  // Unknown id: NotFound, no word.
  EXPECT_EQ(s.Validate(0x1404, 1).code(), absl::StatusCode::kNotFound);
  EXPECT_FALSE(s.WriteCommand(1, 0x1404, 1).ok());
}

TEST(TrinamicParameterValidation, AmaxAtMostVstartTimes64BothWays) {
  ParameterShadow s(0, 6);
  EXPECT_EQ(Rejection(s, "$14.amax", 321), "$14.amax: 321 exceeds vstart x 64 = 320 (L556)");
  EXPECT_EQ(Rejection(s, "$14.amax", 320), "");
  // Lowering vstart must respect the current amax.
  Write(s, "$13.vstart", 10);
  Write(s, "$14.amax", 640);
  EXPECT_EQ(Rejection(s, "$13.vstart", 9), "$13.vstart: 9 x 64 = 576 is below amax 640 (L556)");
  EXPECT_EQ(Rejection(s, "$13.vstart", 10), "");
  // Raising vstart allows more.
  Write(s, "$13.vstart", 20);
  EXPECT_EQ(Rejection(s, "$14.amax", 1280), "");
  EXPECT_EQ(Rejection(s, "$14.amax", 1281), "$14.amax: 1281 exceeds vstart x 64 = 1280 (L556)");
}

TEST(TrinamicParameterValidation, VminAtMostVstartBothWays) {
  ParameterShadow s(0, 6);
  EXPECT_EQ(Rejection(s, "$13.vmin", 6), "$13.vmin: 6 exceeds vstart 5 (L544)");
  EXPECT_EQ(Rejection(s, "$13.vmin", 5), "");
  EXPECT_EQ(Rejection(s, "$13.vmin", 0), "");  // 0 = automatic (L543)
  EXPECT_EQ(Rejection(s, "$13.vstart", 3), "$13.vstart: 3 below vmin 4 (L544)");
  Write(s, "$13.vmin", 2);
  EXPECT_EQ(Rejection(s, "$13.vstart", 3), "");
}

TEST(TrinamicParameterValidation, VrefmaxAtMostVmaxBothWays) {
  ParameterShadow s(0, 6);
  Write(s, "$14.vmax", 150);
  EXPECT_EQ(Rejection(s, "$16.vrefmax", 200), "$16.vrefmax: 200 exceeds vmax 150 (L613)");
  EXPECT_EQ(Rejection(s, "$16.vrefmax", 150), "");
  EXPECT_EQ(Rejection(s, "$14.vmax", 99), "$14.vmax: 99 below vrefmax 100 (L613)");
  EXPECT_EQ(Rejection(s, "$14.vmax", 100), "");
}

TEST(TrinamicParameterValidation, MicrostepFrequencyAt200kHz) {
  ParameterShadow s(0, 6);
  // clkdiv 0 with div 2: vmax 511 → 155 944 Hz, allowed.
  Write(s, "$12.clkdiv", 0);
  // div 0 would put the default vmax 511 at 623 779 Hz.
  EXPECT_EQ(Rejection(s, "$13.div", 0),
            "$13.div: 0 puts vmax 511 at 623779 Hz microstep frequency (clkdiv 0, div 0), above "
            "200000 Hz (L497)");
  Write(s, "$14.vmax", 150);
  Write(s, "$13.div", 0);  // 150 × 1220.7 = 183 105 Hz
  // The CT-55 example: clkdiv 0, div 0, v 200.
  EXPECT_EQ(Rejection(s, "$14.vmax", 200),
            "$14.vmax: 200 at clkdiv 0, div 0 is 244141 Hz microstep frequency, above 200000 Hz "
            "(L497)");
  EXPECT_EQ(Rejection(s, "$14.vmax", 163), "");  // 198 975 Hz (§5.1 table: max v 163)
  EXPECT_EQ(Rejection(s, "$14.vmax", 164),
            "$14.vmax: 164 at clkdiv 0, div 0 is 200195 Hz "
            "microstep frequency, above 200000 Hz (L497)");
  EXPECT_EQ(Rejection(s, "$13.vstart", 200),
            "$13.vstart: 200 at clkdiv 0, div 0 is 244141 Hz microstep frequency, above 200000 "
            "Hz (L497)");
  // vrefmax at the same scale (vmax raised on a slower clock first).
  ParameterShadow t(0, 6);
  Write(t, "$14.vmax", 300);
  Write(t, "$12.clkdiv", 1);
  Write(t, "$13.div", 0);  // K = 610.35: vmax 300 → 183 105 Hz
  Write(t, "$16.vrefmax", 300);
  EXPECT_EQ(Rejection(t, "$12.clkdiv", 0),
            "$12.clkdiv: 0 puts vmax 300 at 366211 Hz microstep frequency (clkdiv 0, div 0), "
            "above 200000 Hz (L497)");
  // vmin is evaluated with div 3 (L541): never above 200 kHz, even at clkdiv 0.
  EXPECT_EQ(Rejection(t, "$13.vmin", 5), "");
}

TEST(TrinamicParameterValidation, PacketTimeoutCoversOneWord) {
  ParameterShadow s(0, 6);
  // 19200 baud: 9 × 10 bits = 4.69 ms; 2 × 2 ms is shorter, 3 × 2 ms is not.
  EXPECT_EQ(Rejection(s, "$41.timeout", 2),
            "$41.timeout: 2 (4 ms) is shorter than one 9-byte word at 19200 baud (4.69 ms) (L838)");
  EXPECT_EQ(Rejection(s, "$41.timeout", 3), "");
  EXPECT_EQ(Rejection(s, "$41.timeout", 4, 9600),
            "$41.timeout: 4 (8 ms) is shorter than one 9-byte word at 9600 baud (9.38 ms) (L838)");
  EXPECT_EQ(Rejection(s, "$41.timeout", 5, 9600), "");
  EXPECT_EQ(Rejection(s, "$41.timeout", 37, 1200),
            "$41.timeout: 37 (74 ms) is shorter than one 9-byte word at 1200 baud (75.00 ms) "
            "(L838)");
  EXPECT_EQ(Rejection(s, "$41.timeout", 38, 1200), "");
  EXPECT_EQ(Rejection(s, "$41.timeout", 2, 115200), "");
  // A slower baud rate must still fit the current timeout.
  Write(s, "$41.timeout", 3);
  EXPECT_EQ(Rejection(s, "$40.divisor", 130),
            "$40.divisor: 130 (9615 baud) makes one 9-byte word 9.36 ms, longer than the packet "
            "timeout 3 x 2 ms (L838)");
  EXPECT_EQ(Rejection(s, "$40.divisor", 11), "");
  EXPECT_EQ(s.Validate(Id("$41.timeout"), 50, 0).message(), "baud: 0 below 1");
}

TEST(TrinamicParameterValidation, PoslimitZeroOnlyWithoutRotaryOrMechRef) {
  ParameterShadow s(0, 6);
  EXPECT_EQ(Rejection(s, "$15.poslimit", 0), "");  // linear axis, switch reference (G-37)
  Write(s, "$15.motor_type_low", 0xA2);            // + RotaryAxis
  EXPECT_EQ(Rejection(s, "$15.poslimit", 0),
            "$15.poslimit: 0 with RotaryAxis set in the motor type; must be 1..134217727 (L570, "
            "G-37)");
  EXPECT_EQ(Rejection(s, "$15.poslimit", 1), "");
  ParameterShadow t(0, 6);
  Write(t, "$15.poslimit", 0);
  EXPECT_EQ(Rejection(t, "$15.motor_type_low", 0xA2),
            "$15.motor_type_low: 162 sets RotaryAxis while poslimit is 0 (L570, G-37)");
  EXPECT_EQ(Rejection(t, "$15.motor_type_high", 0x0E),
            "$15.motor_type_high: 14 sets MechRef while poslimit is 0 (L570, G-37)");
  EXPECT_EQ(Rejection(t, "$15.motor_type_high", 0x2A), "");  // + StopNoRef
}

TEST(TrinamicParameterValidation, QuadpackAxisMustExist) {
  const ParameterShadow s(4, 4);
  EXPECT_EQ(Rejection(s, "$14.vmax", 300),
            "$14.vmax: axis 4 exceeds 3 (the PACK has 4 motors, G-17, L475)");
  EXPECT_EQ(Rejection(ParameterShadow(3, 4), "$14.vmax", 300), "");
  EXPECT_EQ(Rejection(ParameterShadow(5, 6), "$14.vmax", 300), "");
}

TEST(TrinamicParameterValidation, WarningsForDoubtfulValues) {
  EXPECT_THAT(ParameterWarning(Id("$13.vstart"), 5).value_or(""), HasSubstr("G-08"));
  EXPECT_FALSE(ParameterWarning(Id("$13.vstart"), 8).has_value());
  EXPECT_THAT(ParameterWarning(Id("$11.i2"), 6).value_or(""), HasSubstr("$11.i2: index 6 (13 %)"));
  EXPECT_FALSE(ParameterWarning(Id("$11.i2"), 5).has_value());
  EXPECT_FALSE(ParameterWarning(Id("$11.i0"), 8).has_value());  // I0 = 0 % saves energy (L516)
  EXPECT_FALSE(ParameterWarning(Id("$14.vmax"), 1).has_value());
}

// ---- Words ------------------------------------------------------------------------------

TEST(TrinamicParameterWords, ByteExact) {
  ParameterShadow s(0, 6);
  // CT-57: vmax 300 for motor 0 at address 1, amax from the shadow (default 128).
  auto vmax = s.WriteCommand(1, Id("$14.vmax"), 300);
  ASSERT_TRUE(vmax.ok()) << vmax.status();
  EXPECT_THAT(Bytes(*vmax), ElementsAre(0x01, 0x14, 0x00, 0x80, 0x00, 0x2C, 0x01, 0x00, 0x00));
  // WriteCommand does not change the shadow; Absorb does.
  EXPECT_EQ(s.Get(Id("$14.vmax")), 511);
  s.Absorb(*vmax);
  EXPECT_EQ(s.Get(Opcode::kSetRamp, "vmax"), 300);
  // The next `$14` word carries the new vmax with the changed amax.
  auto amax = s.WriteCommand(7, Id("$14.amax"), 300);
  ASSERT_TRUE(amax.ok());
  EXPECT_THAT(Bytes(*amax), ElementsAre(0x07, 0x14, 0x00, 0x2C, 0x01, 0x2C, 0x01, 0x00, 0x00));
  // CT-44's `$11` word is the default set for motor 0.
  auto t0 = s.WriteCommand(1, Id("$11.t0"), 500);
  ASSERT_TRUE(t0.ok());
  EXPECT_THAT(Bytes(*t0), ElementsAre(0x01, 0x11, 0x00, 0x08, 0x02, 0x01, 0x00, 0xF4, 0x01));
  // Motor 3, `$13` with vstart 8: vmin 4 and div 2 from the shadow.
  ParameterShadow m3(3, 6);
  auto vstart = m3.WriteCommand(1, Id("$13.vstart"), 8);
  ASSERT_TRUE(vstart.ok());
  EXPECT_THAT(Bytes(*vstart), ElementsAre(0x01, 0x13, 0x03, 0x04, 0x00, 0x08, 0x00, 0x02, 0x00));
  // `$15` default motor type A0/0A (G-33), poslimit 6400 = 0x1900.
  auto poslimit = m3.WriteCommand(1, Id("$15.poslimit"), 6400);
  ASSERT_TRUE(poslimit.ok());
  EXPECT_THAT(Bytes(*poslimit), ElementsAre(0x01, 0x15, 0x03, 0x00, 0x19, 0x00, 0x00, 0xA0, 0x0A));
  // `$31` carries the motor as its channel (decision 1014).
  auto limit = m3.WriteCommand(1, Id("$31.min_left"), 100);
  ASSERT_TRUE(limit.ok());
  EXPECT_THAT(Bytes(*limit), ElementsAre(0x01, 0x31, 0x03, 0x64, 0x00, 0xFF, 0x03, 0x00, 0x00));
  // Controller-scoped words carry no motor.
  auto timeout = m3.WriteCommand(2, Id("$41.timeout"), 25);
  ASSERT_TRUE(timeout.ok());
  EXPECT_THAT(Bytes(*timeout), ElementsAre(0x02, 0x41, 0x19, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00));
  auto baud = m3.WriteCommand(1, Id("$40.divisor"), 11);
  ASSERT_TRUE(baud.ok());
  EXPECT_THAT(Bytes(*baud), ElementsAre(0x01, 0x40, 0x0B, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00));
  // CT-45's `$32` word.
  auto ready = m3.WriteCommand(1, Id("$32.ttlout1_ready"), 1);
  ASSERT_TRUE(ready.ok());
  EXPECT_THAT(Bytes(*ready), ElementsAre(0x01, 0x32, 0x01, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00));
  // Address 0 is no unit address (decision 1013).
  EXPECT_FALSE(m3.WriteCommand(0, Id("$14.vmax"), 300).ok());
}

// L505-512, CT-43: the peak current is one value per pair, written with motnr 0/2/4.
TEST(TrinamicParameterWords, PeakCurrentPerPair) {
  ParameterShadow m0(0, 6), m1(1, 6), m2(2, 6), m3(3, 6);
  auto word = m1.WriteCommand(1, Id("$10.value"), 255);
  ASSERT_TRUE(word.ok());
  EXPECT_THAT(Bytes(*word), ElementsAre(0x01, 0x10, 0x00, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00));
  for (ParameterShadow* s : {&m0, &m1, &m2, &m3}) s->Absorb(*word);
  EXPECT_EQ(m0.Get(Id("$10.value")), 255);
  EXPECT_EQ(m1.Get(Id("$10.value")), 255);
  EXPECT_EQ(m2.Get(Id("$10.value")), 128);
  EXPECT_EQ(m3.Get(Id("$10.value")), 128);
  // A word for motnr 1/3/5 is ignored by the PACK (L507) and therefore by every shadow.
  auto odd = MakeCommand(1, Opcode::kPeakCurrent, {3, 16});
  ASSERT_TRUE(odd.ok());
  for (ParameterShadow* s : {&m0, &m1, &m2, &m3}) s->Absorb(*odd);
  EXPECT_EQ(m2.Get(Id("$10.value")), 128);
  EXPECT_EQ(m3.Get(Id("$10.value")), 128);
  auto even = MakeCommand(1, Opcode::kPeakCurrent, {2, 16});
  ASSERT_TRUE(even.ok());
  for (ParameterShadow* s : {&m0, &m1, &m2, &m3}) s->Absorb(*even);
  EXPECT_EQ(m0.Get(Id("$10.value")), 255);
  EXPECT_EQ(m2.Get(Id("$10.value")), 16);
  EXPECT_EQ(m3.Get(Id("$10.value")), 16);
  // Motor 3's apply words address the pair through motnr 2.
  EXPECT_EQ(m3.ApplyCommands(1, false).front(), *MakeCommand(1, Opcode::kPeakCurrent, {2, 16}));
  // QUADpack motor 5 never exists (G-17).
  EXPECT_FALSE(ParameterShadow(5, 4).WriteCommand(1, Id("$10.value"), 16).ok());
}

TEST(TrinamicParameterWords, AbsorbTakesWordsForThisMotorAndTheController) {
  ParameterShadow s(2, 6);
  // Another motor's word: no effect.
  s.Absorb(*MakeCommand(1, Opcode::kSetRamp, {1, 300, 200}));
  EXPECT_EQ(s.Get(Id("$14.vmax")), 511);
  EXPECT_EQ(s.Get(Id("$14.amax")), 128);
  // This motor's word: every field.
  s.Absorb(*MakeCommand(1, Opcode::kSetRamp, {2, 300, 200}));
  EXPECT_EQ(s.Get(Id("$14.amax")), 300);
  EXPECT_EQ(s.Get(Id("$14.vmax")), 200);
  s.Absorb(*MakeCommand(1, Opcode::kStartingVelocity, {2, 3, 9, 1}));
  EXPECT_EQ(s.Get(Id("$13.vmin")), 3);
  EXPECT_EQ(s.Get(Id("$13.vstart")), 9);
  EXPECT_EQ(s.div(), 1);
  s.Absorb(*MakeCommand(1, Opcode::kAnalogStopLimits, {2, 10, 900}));
  EXPECT_EQ(s.Get(Id("$31.min_left")), 10);
  EXPECT_EQ(s.Get(Id("$31.max_right")), 900);
  // Controller-scoped words apply whichever axis sent them.
  s.Absorb(*MakeCommand(1, Opcode::kVelocitySetting, {7}));
  EXPECT_EQ(s.clkdiv(), 7);
  s.Absorb(*MakeCommand(1, Opcode::kSetBaudRate, {33, 10}));
  EXPECT_EQ(s.Get(Id("$40.divisor")), 33);
  EXPECT_EQ(s.Get(Id("$40.switchover")), 10);
  s.Absorb(*MakeCommand(1, Opcode::kReadyOutput, {0x01, 0x02}));
  EXPECT_EQ(s.Get(Id("$33.active_mask")), 1);
  EXPECT_EQ(s.Get(Id("$33.reference_mask")), 2);
  // Out-of-range words are ignored by the PACK (G-06, decision 1031), so by the shadow too.
  Command bad{1, Opcode::kSetRamp, {2, 100, 600}};
  s.Absorb(bad);
  EXPECT_EQ(s.Get(Id("$14.vmax")), 200);
  // Words that are no parameter: no effect.
  const ParameterShadow before = s;
  s.Absorb(*MakeCommand(1, Opcode::kStartRamp, {2, 1000}));
  s.Absorb(*MakeCommand(1, Opcode::kWriteTable, {0, 1, 2, 3, 4}));
  s.Absorb(*MakeCommand(1, Opcode::kChangeAddress, {5}));
  for (const ParameterDefinition& d : ParameterCatalogue()) {
    EXPECT_EQ(s.Get(d.id), before.Get(d.id)) << d.name;
  }
}

TEST(TrinamicParameterWords, SetAndGetWithoutChecks) {
  ParameterShadow s(0, 6);
  s.Set(Id("$14.vmax"), 300);
  EXPECT_EQ(s.Get(Opcode::kSetRamp, "vmax"), 300);
  s.Set(0x1404, 7);  // not a parameter: ignored
  EXPECT_EQ(s.Get(0x1404), 0);
  EXPECT_EQ(s.Get(Opcode::kSetRamp, "motnr"), 0);
  EXPECT_EQ(s.Get(Opcode::kSetRamp, "nonsense"), 0);
}

TEST(TrinamicParameterWords, ApplyCommandsInCatalogueOrder) {
  ParameterShadow s(1, 6);
  s.Set(Id("$14.vmax"), 300);
  const std::vector<Command> axis = s.ApplyCommands(1, false);
  std::vector<Opcode> opcodes;
  for (const Command& c : axis) opcodes.push_back(c.opcode);
  EXPECT_THAT(opcodes,
              ElementsAre(Opcode::kPeakCurrent, Opcode::kCurrentControl, Opcode::kStartingVelocity,
                          Opcode::kSetRamp, Opcode::kMotorParameters, Opcode::kReferenceParameters,
                          Opcode::kNullOffset, Opcode::kPiParameters, Opcode::kAnalogStopLimits));
  std::vector<std::vector<uint8_t>> bytes;
  for (const Command& c : axis) bytes.push_back(Bytes(c));
  EXPECT_THAT(
      bytes,
      ElementsAreArray(std::vector<std::vector<uint8_t>>{
          {0x01, 0x10, 0x00, 0x80, 0x00, 0x00, 0x00, 0x00, 0x00},  // pair 0+1: motnr 0
          {0x01, 0x11, 0x01, 0x08, 0x02, 0x01, 0x00, 0xF4, 0x01},
          {0x01, 0x13, 0x01, 0x04, 0x00, 0x05, 0x00, 0x02, 0x00},
          {0x01, 0x14, 0x01, 0x80, 0x00, 0x2C, 0x01, 0x00, 0x00},
          {0x01, 0x15, 0x01, 0x00, 0x19, 0x00, 0x00, 0xA0, 0x0A},  // written explicitly (G-33)
          {0x01, 0x16, 0x01, 0x64, 0x00, 0xFF, 0x0F, 0x00, 0x00},
          {0x01, 0x18, 0x01, 0x00, 0x00, 0x00, 0x00, 0xF0, 0x00},
          {0x01, 0x19, 0x01, 0x08, 0x81, 0x00, 0x81, 0x00, 0x01},
          {0x01, 0x31, 0x01, 0x00, 0x00, 0xFF, 0x03, 0x00, 0x00},
      }));
  const std::vector<Command> all = s.ApplyCommands(3, true);
  opcodes.clear();
  for (const Command& c : all) {
    opcodes.push_back(c.opcode);
    EXPECT_EQ(c.address, 3);
    EXPECT_TRUE(ValidateCommand(c).ok()) << ValidateCommand(c);
  }
  EXPECT_THAT(opcodes,
              ElementsAre(Opcode::kPeakCurrent, Opcode::kCurrentControl, Opcode::kVelocitySetting,
                          Opcode::kStartingVelocity, Opcode::kSetRamp, Opcode::kMotorParameters,
                          Opcode::kReferenceParameters, Opcode::kNullOffset, Opcode::kPiParameters,
                          Opcode::kAnalogStopLimits, Opcode::kSetOutputs, Opcode::kReadyOutput,
                          Opcode::kSetBaudRate, Opcode::kSetPacketTimeout));
  EXPECT_THAT(Bytes(all[2]), ElementsAre(0x03, 0x12, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00));
  EXPECT_THAT(Bytes(all[10]), ElementsAre(0x03, 0x32, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00));
  EXPECT_THAT(Bytes(all[11]), ElementsAre(0x03, 0x33, 0x3F, 0x3F, 0x00, 0x00, 0x00, 0x00, 0x00));
  EXPECT_THAT(Bytes(all[12]), ElementsAre(0x03, 0x40, 0x41, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00));
  EXPECT_THAT(Bytes(all[13]), ElementsAre(0x03, 0x41, 0x32, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00));
}

// A shadow absorbing its own apply words is unchanged, and another shadow of the same motor
// absorbing them ends up equal (the re-apply after a reset reproduces the state).
TEST(TrinamicParameterWords, ApplyCommandsRoundTripThroughAbsorb) {
  ParameterShadow s(4, 6);
  Write(s, "$13.vstart", 12);
  Write(s, "$14.amax", 700);
  Write(s, "$15.motor_type_high", 0x2A);
  Write(s, "$18.nulloffset", -1234);
  Write(s, "$12.clkdiv", 3);
  Write(s, "$41.timeout", 25);
  ParameterShadow fresh(4, 6);
  for (const Command& c : s.ApplyCommands(1, true)) fresh.Absorb(c);
  for (const ParameterDefinition& d : ParameterCatalogue()) {
    EXPECT_EQ(fresh.Get(d.id), s.Get(d.id)) << d.name;
  }
  EXPECT_EQ(fresh.Get(Id("$18.nulloffset")), -1234);
}

// CT-57 against the simulated PACK: after a reset, the apply words bring the controller's
// registers to the shadow's values for every field.
TEST(TrinamicParameterWords, ApplyCommandsReproduceTheShadowInTheSimulator) {
  ParameterShadow s(3, 6);
  Write(s, "$10.value", 200);
  Write(s, "$11.i1", 3);
  Write(s, "$11.t0", 250);
  Write(s, "$14.vmax", 300);
  Write(s, "$13.vstart", 10);
  Write(s, "$13.vmin", 7);
  Write(s, "$13.div", 1);
  Write(s, "$14.amax", 600);
  Write(s, "$15.poslimit", 12800);
  Write(s, "$15.motor_type_low", 0x92);
  Write(s, "$15.motor_type_high", 0x23);
  Write(s, "$16.vrefmax", 250);
  Write(s, "$16.debounce_mask", 0x00FF);
  Write(s, "$16.stop_after_search", 1);
  Write(s, "$18.nulloffset", -500);
  Write(s, "$18.testnullrange", 100);
  Write(s, "$19.propdiv", 4);
  Write(s, "$19.intdiv", 200);
  Write(s, "$19.intclip", 300);
  Write(s, "$19.intinpclip", 9);
  Write(s, "$31.min_left", 20);
  Write(s, "$31.max_right", 1000);
  Write(s, "$12.clkdiv", 4);
  Write(s, "$32.ttlout1_ready", 1);
  Write(s, "$33.active_mask", 0x08);
  Write(s, "$33.reference_mask", 0x00);
  Write(s, "$40.switchover", 5);
  Write(s, "$41.timeout", 25);

  auto pack = sim::trinamic::Controller::Create({});
  ASSERT_TRUE(pack.ok()) << pack.status();
  for (const Command& c : s.ApplyCommands(1, true)) EXPECT_FALSE(pack->Handle(c).has_value());
  const sim::trinamic::MotorRegisters& r = pack->registers(3);
  const sim::trinamic::Globals& g = pack->globals();
  EXPECT_EQ(r.peak_current, 200);
  EXPECT_EQ(pack->registers(2).peak_current, 200);  // the pair partner
  EXPECT_EQ(r.current_index[1], 3);
  EXPECT_EQ(r.t0, 250);
  EXPECT_EQ(g.clkdiv, 4);
  EXPECT_EQ(r.vmin, 7);
  EXPECT_EQ(r.vstart, 10);
  EXPECT_EQ(r.div, 1);
  EXPECT_EQ(r.amax, 600);
  EXPECT_EQ(r.vmax, 300);
  EXPECT_EQ(r.poslimit, 12800);
  EXPECT_EQ(r.motor_type, 0x2392);
  EXPECT_EQ(r.vrefmax, 250);
  EXPECT_EQ(r.debounce_mask, 0x00FF);
  EXPECT_TRUE(r.stop_after_search);
  EXPECT_EQ(r.nulloffset, -500);
  EXPECT_EQ(r.testnullrange, 100);
  EXPECT_EQ(r.propdiv, 4);
  EXPECT_EQ(r.intdiv, 200);
  EXPECT_EQ(r.intclip, 300);
  EXPECT_EQ(r.intinpclip, 9);
  EXPECT_EQ(r.stop_min_left, 20);
  EXPECT_EQ(r.stop_max_right, 1000);
  EXPECT_EQ(g.outputs[0], 1);
  EXPECT_EQ(g.outputs[1], 1);
  EXPECT_EQ(g.outputs[2], 0);
  EXPECT_EQ(g.outputs[3], 1);
  EXPECT_EQ(g.ready_active_mask, 0x08);
  EXPECT_EQ(g.ready_reference_mask, 0x00);
  EXPECT_EQ(g.baud_divisor, 65);
  EXPECT_EQ(g.switchover, 5);
  EXPECT_EQ(g.packet_timeout, 25);
  // Other motors keep their defaults.
  EXPECT_EQ(pack->registers(4).vmax, 511);
}

}  // namespace
}  // namespace drivegw::trinamic
