// STOBER catalogue (decision 009): the object map as ParameterDefinitions, plus an open CANopen
// address space (any well-formed index/sub is Find-able as a raw object, decision 1201).
#include "adapters/stober/catalogue.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/stober/factory.h"
#include "adapters/stober/object_map.h"
#include "adapters/stober/param_id.h"

namespace drivegw::stober {
namespace {

uint32_t IdOf(CanOpenAddress a) { return static_cast<uint32_t>(a.index) << 8 | a.sub_index; }

std::string AddressText(CanOpenAddress a) {
  return absl::StrFormat("0x%04X:%02X", a.index, a.sub_index);
}

bool Contains(std::string_view text, std::string_view part) {
  return text.find(part) != std::string_view::npos;
}

// The quantity behind a fixed-point increment (decision 1172): the object map keeps one scale
// for user units and milliseconds, so the binding's name tells which (every ms object is a
// "... time"; velocities/speeds u/s, accelerations u/s², jerk u/s³; %/s for slopes and ramps).
std::string Unit(const ObjectBinding& b) {
  if (b.boolean || b.scale == 1) return "";
  const std::string_view n = b.name;
  if (b.scale == kPercentScale) {
    return Contains(n, "slope") || Contains(n, "ramp") ? "%/s (wire 0.1 %/s)" : "% (wire 0.1 %)";
  }
  if (Contains(n, "time")) return "ms (wire 0.001 ms)";
  if (Contains(n, "jerk")) return "u/s³ (wire 0.001 u/s³)";
  if (Contains(n, "acceleration") || Contains(n, "deceleration")) {
    return "u/s² (wire 0.001 u/s²)";
  }
  if (Contains(n, "velocity") || Contains(n, "speed")) return "u/s (wire 0.001 u/s)";
  return "u (wire 0.001 u)";
}

::drivegw::ParameterDefinition FromBinding(const ObjectBinding& b) {
  ::drivegw::ParameterDefinition d;
  d.id = IdOf(b.address);
  auto own = ToCanOpen(b.param);
  const bool alias = !own.ok() || *own != b.address;
  d.name = alias ? AddressText(b.address) : ToString(b.param);
  d.title = std::string(b.name);
  d.type = b.boolean ? "bool" : std::string(WireTypeName(b.type));
  d.unit = Unit(b);
  // StoberDrive::WriteParameter encodes the integer as a user value (raw = value / scale) and
  // ReadParameter rounds the decoded user value: the range is the wire range in whole user units.
  if (b.boolean) {
    d.min = 0;
    d.max = 1;
  } else {
    d.min = static_cast<int64_t>(std::ceil(static_cast<double>(WireTypeMin(b.type)) * b.scale));
    d.max = static_cast<int64_t>(std::floor(static_cast<double>(WireTypeMax(b.type)) * b.scale));
  }
  d.writable = !b.read_only;
  d.has_stored_value = false;  // 1010h store is not supported (decision 1201)
  d.description = absl::StrCat(
      alias ? absl::StrCat("CiA 402 alias of ", ToString(b.param), "; ") : std::string(),
      "CANopen ", AddressText(b.address), ", ", std::string(WireTypeName(b.type)),
      b.scale != 1 ? absl::StrCat(" x ", b.scale) : std::string(),
      " (stober-motion.md §7.2, decisions 1172/1173)");
  return d;
}

// A well-formed but unbound object: raw integer, the widths the drive writes (1/2/4 bytes,
// decision 1201).
::drivegw::ParameterDefinition Raw(CanOpenAddress a, std::string name) {
  ::drivegw::ParameterDefinition d;
  d.id = IdOf(a);
  d.name = std::move(name);
  d.title = "unbound object";
  d.type = "unknown";
  d.unit = "unknown";
  d.min = std::numeric_limits<int32_t>::min();
  d.max = std::numeric_limits<uint32_t>::max();
  d.writable = true;
  d.description = absl::StrCat("CANopen ", AddressText(a),
                               " is not in the object map; raw value (decision 1201)");
  return d;
}

std::optional<uint32_t> ParseHex(std::string_view s) {
  uint32_t v = 0;
  if (s.empty()) return std::nullopt;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

// "0x6083:00", "0x6083.0", "0x608300", "6083h:00", "6083h", decimal "6324992" -> address.
std::optional<CanOpenAddress> ParseAddress(std::string_view t) {
  bool hex = false;
  if (t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) {
    t.remove_prefix(2);
    hex = true;
  }
  const size_t sep = t.find_first_of(":.");
  if (sep != std::string_view::npos) {
    std::string_view index = t.substr(0, sep);
    if (!index.empty() && (index.back() == 'h' || index.back() == 'H')) index.remove_suffix(1);
    const auto i = ParseHex(index);
    const auto s = ParseHex(t.substr(sep + 1));
    if (!i || !s || *i > 0xFFFF || *s > 0xFF || index.empty()) return std::nullopt;
    return CanOpenAddress{static_cast<uint16_t>(*i), static_cast<uint8_t>(*s)};
  }
  if (!t.empty() && (t.back() == 'h' || t.back() == 'H')) {
    t.remove_suffix(1);
    hex = true;
    const auto i = ParseHex(t);
    if (!i || *i > 0xFFFF) return std::nullopt;
    return CanOpenAddress{static_cast<uint16_t>(*i), 0};
  }
  std::optional<uint32_t> id;
  if (hex) {
    id = ParseHex(t);
  } else {
    uint32_t v = 0;
    const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v, 10);
    if (!t.empty() && ec == std::errc() && p == t.data() + t.size()) id = v;
  }
  if (!id || *id > 0xFFFFFF) return std::nullopt;
  return CanOpenAddress{static_cast<uint16_t>(*id >> 8), static_cast<uint8_t>(*id & 0xFF)};
}

class StoberCatalogue final : public ParameterCatalogue {
 public:
  StoberCatalogue() {
    for (const ObjectBinding& b : ObjectMap()) definitions_.push_back(FromBinding(b));
  }

  std::string family() const override { return kFamilyName; }
  const std::vector<ParameterDefinition>& Definitions() const override { return definitions_; }

  absl::StatusOr<ParameterDefinition> Find(std::string_view text) const override {
    std::optional<CanOpenAddress> address = ParseAddress(text);
    std::string name;
    if (!address) {
      auto param = ParseParamId(text);
      if (param.ok()) {
        auto a = ToCanOpen(*param);
        if (a.ok()) {
          address = *a;
          name = ToString(*param);
        }
      }
    }
    if (!address) {
      return absl::NotFoundError(absl::StrCat(
          "stober: \"", std::string(text),
          "\" is neither a STOBER parameter (\"I10\", \"A587[1]\") nor a CANopen object "
          "(\"0x6083:00\", \"0x608300\")"));
    }
    const uint32_t id = IdOf(*address);
    for (const ParameterDefinition& d : definitions_) {
      if (d.id == id) return d;
    }
    return Raw(*address, name.empty() ? AddressText(*address) : name);
  }

 private:
  std::vector<ParameterDefinition> definitions_;
};

}  // namespace

std::shared_ptr<const ParameterCatalogue> MakeStoberCatalogue() {
  return std::make_shared<const StoberCatalogue>();
}

std::shared_ptr<const ParameterCatalogue> StoberParameterCatalogue() {
  static const std::shared_ptr<const ParameterCatalogue> catalogue = MakeStoberCatalogue();
  return catalogue;
}

}  // namespace drivegw::stober
