// STOBER parameter ids ("I92", "A515", "A587[1]") and their CANopen addresses, shared by the
// gateway's STOBER drive and the simulated axis (stober-motion.md §0.2, §7.2; issue 5). Pure.
// Moved here from sim/stober/parameters.h (decision 1171) so that both sides address the drive
// with one rule; sim/stober re-exports these names.
#pragma once

#include <compare>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace drivegw::stober {

// A STOBER parameter: group letter, line, array element (§0.2: `A515`, `I401`, `A587[1]`).
struct ParamId {
  char group = 'I';
  int line = 0;
  int element = 0;

  friend bool operator==(const ParamId&, const ParamId&) = default;
  friend auto operator<=>(const ParamId&, const ParamId&) = default;
};

// "I92", "i92", "A587[1]"; group must be one of A C D E F G I J K M (§7.2 group numbers).
absl::StatusOr<ParamId> ParseParamId(std::string_view text);
// "I92"; the element is printed only when it is not 0 ("A587[1]").
std::string ToString(ParamId id);

// Shorthand for literals in code and tests: P("I92"). Aborts on a malformed literal.
ParamId P(std::string_view text);

// CANopen object address of a parameter (§7.2 [X], issue 5).
struct CanOpenAddress {
  uint16_t index = 0;
  uint8_t sub_index = 0;
  friend bool operator==(const CanOpenAddress&, const CanOpenAddress&) = default;
  friend auto operator<=>(const CanOpenAddress&, const CanOpenAddress&) = default;
};

// 2000h + group×200h + line, sub-index = element, for lines 0..511; group A lines > 511 are the
// CiA 402 objects (A515 ↔ 6040h, A516 ↔ 6041h, A541 ↔ 6060h, ...; §7.2 note): those map to the
// CiA 402 index. Any other line > 511 is OutOfRange naming the parameter.
absl::StatusOr<CanOpenAddress> ToCanOpen(ParamId id);
// Inverse of ToCanOpen; NotFound for an index that is neither 2000h..39FFh of a known group nor
// a mapped CiA 402 object.
absl::StatusOr<ParamId> FromCanOpen(CanOpenAddress address);

}  // namespace drivegw::stober
