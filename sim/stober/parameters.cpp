// Parameter ids, CANopen addressing and the catalogue (stober-motion.md §0.2, §5, §7.2, §10.1).
#include "sim/stober/parameters.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <limits>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::stober {
namespace {

// Group numbers of the SD6 CANopen manual (§7.2 [X]): A 0, C 2, D 3, E 4, F 5, G 6, I 8, J 9,
// K 10, M 12.
std::optional<int> GroupNumber(char group) {
  switch (group) {
    case 'A': return 0;
    case 'C': return 2;
    case 'D': return 3;
    case 'E': return 4;
    case 'F': return 5;
    case 'G': return 6;
    case 'I': return 8;
    case 'J': return 9;
    case 'K': return 10;
    case 'M': return 12;
    default: return std::nullopt;
  }
}

std::optional<char> GroupLetter(int number) {
  static constexpr std::array<char, 13> kLetters = {'A', 0, 'C', 'D', 'E', 'F', 'G',
                                                    0,   'I', 'J', 'K', 0, 'M'};
  if (number < 0 || number >= static_cast<int>(kLetters.size()) || kLetters[number] == 0) {
    return std::nullopt;
  }
  return kLetters[number];
}

// Group A parameters beyond line 511 reach the bus only as CiA 402 objects (§7.2: 6840h ↔ A515
// for axis B, hence 6040h ↔ A515 for axis A; the others are the standard CiA 402 indices of the
// same objects).
struct Cia402Object {
  int line;
  uint16_t index;
  uint8_t sub_index;
};
constexpr std::array<Cia402Object, 21> kCia402Objects = {{
    {515, 0x6040, 0},  // control word
    {516, 0x6041, 0},  // status word
    {541, 0x6060, 0},  // modes of operation
    {542, 0x6061, 0},  // modes of operation display
    {545, 0x6064, 0},  // position actual value (§7.2 6864h ↔ A545)
    {558, 0x6071, 0},  // target torque
    {561, 0x6087, 0},  // torque slope
    {567, 0x607A, 0},  // target position
    {569, 0x607C, 0},  // home offset (§7.2 687Ch ↔ A569)
    {574, 0x6081, 0},  // profile velocity
    {576, 0x6083, 0},  // profile acceleration
    {577, 0x6084, 0},  // profile deceleration
    {586, 0x6098, 0},  // homing method
    {587, 0x6099, 1},  // homing speeds [0] fast → sub 1
    {588, 0x609A, 0},  // homing acceleration
    {590, 0x60A4, 1},  // profile jerk
    {592, 0x60B1, 0},  // velocity offset (added to A638, §5.1)
    {593, 0x60B2, 0},  // torque offset (added to A558 in CST)
    {601, 0x60C1, 1},  // interpolation data record (IP set position)
    {621, 0x60F2, 0},  // positioning option code (§7.2 60F2h ↔ A621)
    {638, 0x60FF, 0},  // target velocity (§7.2 60FFh ↔ A638)
}};

constexpr double kBig = 1e9;  // value range of unbounded user-unit quantities (G-01)
constexpr double kInf = std::numeric_limits<double>::infinity();

using enum ParamType;
constexpr Access RO = Access::kReadOnly;
constexpr Access RW = Access::kReadWrite;

std::vector<ParamInfo> MakeCatalogue() {
  std::vector<ParamInfo> c = {
      // Group A: drive controller / CiA 402 objects (§5.1).
      {P("A150"), "cycle time motion core", kReal, "ms", 0.125, 32, 1, RW, "F-LIN"},
      {P("A291"), "controller cycle time", kReal, "ms", 0.125, 1000, 1, RW, "F-CYC"},
      {P("A340"), "velocity override (CiA 402 source)", kReal, "%", 0, 1000, 100, RW, "F-LIN"},
      {P("A515"), "control word", kInt, "", 0, 65535, 0, RW, "P"},
      {P("A516"), "status word", kInt, "", 0, 65535, 0, RO, "P"},
      {P("A541"), "modes of operation", kInt, "", -128, 127, 0, RW, "manual"},
      {P("A542"), "modes of operation display", kInt, "", -128, 127, 0, RO, "manual"},
      {P("A545"), "position actual value", kReal, "u", -kInf, kInf, 0, RO, "P"},
      {P("A558"), "target torque/force", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("A561"), "torque/force slope", kReal, "%/s", 0, kBig, 0, RW, "P"},
      {P("A567"), "target position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A569"), "reference position (home offset)", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A574"), "profile velocity", kReal, "u/s", -kBig, kBig, 500, RW, "F-LIN default move"},
      {P("A576"), "profile acceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("A577"), "profile deceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("A586"), "homing method", kInt, "", -4, 37, 0, RW, "manual (0 inactive)"},
      {P("A587[0]"), "homing speed fast", kReal, "u/s", 0, kBig, 100, RW, "P"},
      {P("A587[1]"), "homing speed slow", kReal, "u/s", 0, kBig, 10, RW, "P"},
      {P("A588"), "homing acceleration", kReal, "u/s²", 0, kBig, 1000, RW, "P"},
      {P("A590"), "profile jerk", kReal, "u/s³", 0, kBig, 50000, RW, "F-LIN default move"},
      {P("A592"), "velocity component (cyclic)", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      {P("A593"), "torque/force component (CST)", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("A601"), "set position IP mode", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A621"), "positioning option code", kInt, "", 0, 65535, 0, RW, "P"},
      {P("A638"), "target velocity", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      // Groups C, E, F (§5.2).
      {P("C40"), "velocity window", kReal, "u/s", 0, kBig, 5, RW, "F-LIN"},
      {P("E07"), "calculated set velocity", kReal, "u/s", -kInf, kInf, 0, RO, "P"},
      {P("E65"), "maximum torque/force positive", kReal, "%", 0, 1000, 300, RW, "P (G-34)"},
      {P("E66"), "maximum torque/force negative", kReal, "%", 0, 1000, 300, RW, "P (G-34)"},
      {P("E90"), "actual torque/force", kReal, "%", -kInf, kInf, 0, RO, "P"},
      {P("F00"), "brake control", kInt, "", 0, 1, 1, RW, "F-LIN"},
      // Group I: configuration and limits (§5.3).
      {P("I00"), "travel range", kInt, "", 0, 1, 0, RW, "F-LIN"},
      {P("I01"), "revolution length", kReal, "u", 1e-6, kBig, 360, RW, "F-END"},
      {P("I04"), "permitted direction", kInt, "", 0, 2, 0, RW, "P (G-21)"},
      {P("I10"), "maximum velocity", kReal, "u/s", 0, kBig, 1000, RW, "F-LIN"},
      {P("I11"), "maximum acceleration", kReal, "u/s²", 0, kBig, 10000, RW, "F-LIN"},
      {P("I16"), "maximum jerk", kReal, "u/s³", 0, kBig, 100000, RW, "F-LIN"},
      {P("I22"), "position window", kReal, "u", 0, kBig, 1, RW, "F-LIN"},
      {P("I25"), "velocity feedforward", kReal, "%", 0, 100, 100, RW, "P"},
      {P("I28"), "homing torque/force limit", kReal, "%", 0, 1000, 50, RW, "P"},
      {P("I29"), "time homing torque/force limit", kReal, "ms", 0, 60000, 100, RW, "P"},
      {P("I30"), "referencing type", kInt, "", 0, 5, 0, RW, "P"},
      {P("I31"), "referencing direction", kInt, "", 0, 1, 0, RW, "P (0 positive, 1 negative)"},
      {P("I32"), "referencing speed fast", kReal, "u/s", 0, kBig, 100, RW, "P"},
      {P("I33"), "referencing speed slow", kReal, "u/s", 0, kBig, 10, RW, "P"},
      {P("I34"), "reference position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I35"), "referencing with zero pulse", kInt, "", 0, 1, 0, RW, "P"},
      {P("I37"), "index search distance", kReal, "u", 0, kBig, 360, RW, "P"},
      {P("I39"), "referencing acceleration", kReal, "u/s²", 0, kBig, 1000, RW, "P"},
      {P("I42"), "brake wait time", kReal, "ms", 0, 60000, 0, RW, "P"},
      {P("I43"), "move to reference position", kInt, "", 0, 1, 0, RW, "P"},
      {P("I44"), "reference jerk", kReal, "u/s³", 0, kBig, 10000, RW, "P"},
      {P("I50"), "software limit switch positive", kReal, "u", -kBig, kBig, 10000, RW, "F-LIN"},
      {P("I51"), "software limit switch negative", kReal, "u", -kBig, kBig, -10000, RW, "F-LIN"},
      // Status (§5.3 status and limit flags).
      {P("I80"), "actual position", kReal, "u", -kInf, kInf, 0, RO, "P (G-27)"},
      {P("I82"), "active motion ID", kInt, "", -kBig, kBig, 0, RO, "P"},
      {P("I83"), "state motion command", kInt, "", 0, 2, 0, RO, "P (G-08)"},
      {P("I85"), "motion profile done", kBool, "", 0, 1, 0, RO, "P"},
      {P("I86"), "in reference", kBool, "", 0, 1, 1, RO, "F-LIN"},
      {P("I87"), "position window time", kReal, "ms", 0, 60000, 10, RW, "F-LIN"},
      {P("I88"), "actual velocity", kReal, "u/s", -kInf, kInf, 0, RO, "P"},
      {P("I89"), "PLCopen state", kInt, "", 0, 11, 2, RO, "F-LIN"},
      {P("I90"), "PLCopen ErrorStop cause", kInt, "", 0, 255, 0, RO, "P (G-06)"},
      {P("I91"), "error", kBool, "", 0, 1, 0, RO, "P"},
      {P("I92"), "done", kBool, "", 0, 1, 0, RO, "P"},
      {P("I96"), "calculated set position", kReal, "u", -kInf, kInf, 0, RO, "P"},
      {P("I100"), "source Execute", kInt, "", 0, 255, 0, RW, "P"},
      {P("I101"), "source positive limit switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I102"), "source negative limit switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I103"), "source reference switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I113"), "MC_MoveVelocity mode (1 cyclical takeover)", kInt, "", 0, 1, 0, RW, "manual"},
      {P("I119"), "disable v-set at command change (1 only at start)", kInt, "", 0, 1, 0, RW,
       "manual"},
      {P("I180"), "actual position in window", kBool, "", 0, 1, 0, RO, "P"},
      {P("I183"), "speed reached", kBool, "", 0, 1, 0, RO, "P"},
      {P("I190"), "velocity limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I191"), "acceleration/jerk limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I192"), "cyclical position limiting active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I193"), "cyclical velocity limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I194"), "cyclical torque/force limit active", kBool, "", 0, 1, 0, RO, "P (G-27)"},
      {P("I195"), "cyclical acceleration limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I199"), "set and actual velocity zero", kBool, "", 0, 1, 1, RO, "P (G-37)"},
      {P("I216"), "cyclic acceleration (MoveSpeed)", kReal, "u/s²", 0, kBig, 0, RW, "P (G-27)"},
      {P("I217"), "cyclic deceleration (MoveSpeed)", kReal, "u/s²", 0, kBig, 0, RW, "P (G-27)"},
      {P("I230"), "velocity override", kReal, "%", 0, 1000, 100, RW, "F-LIN"},
      // Motion-core inputs (§5.3 command interface).
      {P("I400"), "motion ID", kInt, "", -kBig, kBig, 0, RW, "P"},
      {P("I401"), "command", kInt, "", 0, 11, 0, RW, "manual (0 DoNothing)"},
      {P("I402"), "execute", kBool, "", 0, 1, 0, RW, "P"},
      {P("I403"), "position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I404"), "velocity", kReal, "u/s", -kBig, kBig, 500, RW, "F-LIN default move"},
      {P("I405"), "acceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("I406"), "deceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("I407"), "jerk", kReal, "u/s³", 0, kBig, 50000, RW, "F-LIN default move"},
      {P("I409"), "command mode", kInt, "", 0, 0, 0, RW, "P (G-09: command mode only)"},
      {P("I410"), "engage brake at the end", kBool, "", 0, 1, 0, RW, "F-LIN"},
      {P("I411"), "movement direction", kInt, "", 0, 3, 0, RW, "manual"},
      {P("I421"), "cyclic position reference value", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I423"), "extrapolation time", kReal, "ms", 0, 60000, 5, RW, "F-CYC"},
      {P("I425"), "feedforward source / interpolation type", kInt, "", 0, 2, 0, RW, "P"},
      {P("I426"), "cyclic reference speed", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      {P("I428"), "cyclic reference torque/force", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("I429"), "end velocity", kReal, "u/s", 0, 0, 0, RW, "P (G-09, decision 302 §7)"},
      {P("I430"), "torque/force ramp up", kReal, "%/s", 0, kBig, 0, RW, "P (0 = step)"},
      {P("I431"), "torque/force ramp down", kReal, "%/s", 0, kBig, 0, RW, "P (0 = step)"},
      {P("I441"), "signal positive limit switch", kBool, "", 0, 1, 0, RO, "P"},
      {P("I442"), "signal negative limit switch", kBool, "", 0, 1, 0, RO, "P"},
  };
  std::sort(c.begin(), c.end(), [](const ParamInfo& a, const ParamInfo& b) { return a.id < b.id; });
  return c;
}

}  // namespace

absl::StatusOr<ParamId> ParseParamId(std::string_view text) {
  auto bad = [&](std::string_view why) {
    return absl::InvalidArgumentError(
        absl::StrCat("parameter id \"", std::string(text), "\": ", std::string(why)));
  };
  if (text.size() < 2) return bad("expected a group letter and a line, e.g. I92");
  char group = text[0];
  if (group >= 'a' && group <= 'z') group = static_cast<char>(group - 'a' + 'A');
  if (!GroupNumber(group)) return bad("group must be one of A C D E F G I J K M");
  size_t i = 1;
  int line = 0;
  size_t digits = 0;
  while (i < text.size() && text[i] >= '0' && text[i] <= '9' && digits < 6) {
    line = line * 10 + (text[i] - '0');
    ++i;
    ++digits;
  }
  if (digits == 0) return bad("missing line number");
  int element = 0;
  if (i < text.size()) {
    if (text[i] != '[' || text.back() != ']') return bad("expected [element] after the line");
    std::string_view inner = text.substr(i + 1, text.size() - i - 2);
    if (inner.empty() || inner.size() > 3) return bad("element must be 0..255");
    for (char ch : inner) {
      if (ch < '0' || ch > '9') return bad("element must be a number");
      element = element * 10 + (ch - '0');
    }
    if (element > 255) return bad("element must be 0..255");
  }
  if (line > 4095) return bad("line must be 0..4095");
  return ParamId{group, line, element};
}

std::string ToString(ParamId id) {
  std::string s = absl::StrCat(std::string(1, id.group), id.line);
  if (id.element != 0) absl::StrAppend(&s, "[", id.element, "]");
  return s;
}

ParamId P(std::string_view text) {
  absl::StatusOr<ParamId> id = ParseParamId(text);
  if (!id.ok()) std::abort();  // a malformed literal in our own code
  return *id;
}

absl::StatusOr<CanOpenAddress> ToCanOpen(ParamId id) {
  std::optional<int> group = GroupNumber(id.group);
  if (!group) return absl::InvalidArgumentError(absl::StrCat("unknown group in ", ToString(id)));
  if (id.element < 0 || id.element > 255) {
    return absl::OutOfRangeError(absl::StrCat(ToString(id), ": element must be 0..255"));
  }
  if (id.line <= 511) {
    return CanOpenAddress{static_cast<uint16_t>(0x2000 + *group * 0x200 + id.line),
                          static_cast<uint8_t>(id.element)};
  }
  if (id.group == 'A') {
    for (const Cia402Object& o : kCia402Objects) {
      if (o.line == id.line) {
        return CanOpenAddress{o.index, static_cast<uint8_t>(o.sub_index + id.element)};
      }
    }
  }
  return absl::OutOfRangeError(absl::StrCat(
      ToString(id), ": line > 511 has no 2000h+group×200h+line object (stober-motion.md §7.2)",
      id.group == 'A' ? " and no CiA 402 object is mapped for it" : ""));
}

absl::StatusOr<ParamId> FromCanOpen(CanOpenAddress address) {
  for (const Cia402Object& o : kCia402Objects) {
    if (o.index != address.index) continue;
    if (address.sub_index < o.sub_index) break;
    return ParamId{'A', o.line, address.sub_index - o.sub_index};
  }
  if (address.index >= 0x2000 && address.index < 0x2000 + 13 * 0x200) {
    int offset = address.index - 0x2000;
    if (std::optional<char> letter = GroupLetter(offset / 0x200)) {
      return ParamId{*letter, offset % 0x200, address.sub_index};
    }
  }
  return absl::NotFoundError(absl::StrCat("CANopen object ", absl::Hex(address.index), "h sub ",
                                          address.sub_index, " is no STOBER parameter"));
}

const std::vector<ParamInfo>& Catalogue() {
  static const std::vector<ParamInfo> kCatalogue = MakeCatalogue();
  return kCatalogue;
}

const ParamInfo* FindParam(ParamId id) {
  const std::vector<ParamInfo>& c = Catalogue();
  auto it = std::lower_bound(c.begin(), c.end(), id,
                             [](const ParamInfo& p, const ParamId& v) { return p.id < v; });
  if (it == c.end() || it->id != id) return nullptr;
  return &*it;
}

}  // namespace drivegw::sim::stober
