// Parameter ids and CANopen addressing (stober-motion.md §0.2, §7.2; decision 1171).
#include "adapters/stober/param_id.h"

#include <array>
#include <cstdlib>
#include <optional>

#include "absl/strings/str_cat.h"

namespace drivegw::stober {
namespace {

// Group numbers of the SD6 CANopen manual (§7.2 [X]): A 0, C 2, D 3, E 4, F 5, G 6, I 8, J 9,
// K 10, M 12.
std::optional<int> GroupNumber(char group) {
  switch (group) {
    case 'A':
      return 0;
    case 'C':
      return 2;
    case 'D':
      return 3;
    case 'E':
      return 4;
    case 'F':
      return 5;
    case 'G':
      return 6;
    case 'I':
      return 8;
    case 'J':
      return 9;
    case 'K':
      return 10;
    case 'M':
      return 12;
    default:
      return std::nullopt;
  }
}

std::optional<char> GroupLetter(int number) {
  static constexpr std::array<char, 13> kLetters = {'A', 0,   'C', 'D', 'E', 'F', 'G',
                                                    0,   'I', 'J', 'K', 0,   'M'};
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

}  // namespace drivegw::stober
