#pragma once

// How both LinMot parameter catalogues (LinUDP UPIDs, DeviceNet command IDs) read a numeric id the
// user typed: "0x14BE", "14BEh" (the manuals' notation) or decimal "5310". Header-only.

#include <charconv>
#include <cstdint>
#include <optional>
#include <string_view>
#include <system_error>

namespace drivegw::linmot {

// The number `text` spells, or nullopt when it is not a whole hexadecimal or decimal uint32.
inline std::optional<uint32_t> ParseParameterId(std::string_view text) {
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    text.remove_prefix(2);
    base = 16;
  } else if (text.size() > 1 && (text.back() == 'h' || text.back() == 'H')) {
    text.remove_suffix(1);
    base = 16;
  }
  uint32_t v = 0;
  if (text.empty()) return std::nullopt;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return v;
}

}  // namespace drivegw::linmot
