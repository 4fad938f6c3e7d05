// The parameter catalogue of one drive family: which parameters exist, how the family names them,
// their type, unit and range. Lives in code once per family (issue 6), is served by the API
// (ListParameterDefinitions) and is what parameter sets are validated against before anything is
// written to a drive. Values are integers as Drive::Read/WriteParameter carry them.
#pragma once

#include <cctype>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/command.h"

namespace drivegw {

struct ParameterDefinition {
  uint32_t id = 0;    // ParameterRef.id of the family
  std::string name;   // the family's own name: "0x14BE" (LinMot UPID), "$14.vmax" (Trinamic),
                      // "I10" (STOBER), "0x51" (DeviceNet command), ...
  std::string title;  // short human text: "maximal velocity"
  std::string type;   // wire type: "u8", "i16", "u32", "bool", "bits16", ...
  std::string unit;   // "mm/s", "0.001 u", "velocity register", "" if none
  int64_t min = 0;    // inclusive range of the integer value
  int64_t max = 0;
  std::optional<int64_t> default_value;
  bool writable = true;
  bool has_stored_value = false;  // RAM and ROM (LinMot): a set may target either
  std::string description;        // one line, cites the manual/reference line
};

class ParameterCatalogue {
 public:
  virtual ~ParameterCatalogue() = default;
  virtual std::string family() const = 0;  // "linmot", "trinamic", ...
  // Every documented parameter, in the family's natural order.
  virtual const std::vector<ParameterDefinition>& Definitions() const = 0;
  // By name or numeric id text ("$14.vmax", "0x1403", "I10", "0x305C00", "5308"). Families with an
  // open address space (LinMot UPIDs, CANopen objects) may return a synthesized definition for an
  // undocumented but well-formed address (type/unit "unknown", full range of the wire type).
  // NotFound naming the text and the family.
  virtual absl::StatusOr<ParameterDefinition> Find(std::string_view name_or_id) const = 0;
  // Range/type check of one value (cross-field rules too where the family has them and the
  // catalogue can know them); InvalidArgument naming the parameter and the limit.
  virtual absl::Status Validate(const ParameterDefinition& definition, int64_t value) const {
    if (value < definition.min || value > definition.max) {
      return absl::InvalidArgumentError(definition.name + ": " + std::to_string(value) +
                                        " is outside " + std::to_string(definition.min) + ".." +
                                        std::to_string(definition.max));
    }
    if (!definition.writable) {
      return absl::InvalidArgumentError(definition.name + ": read-only");
    }
    return absl::OkStatus();
  }
};

// Families match parameter names typed by a user without regard to ASCII case ("$14.VMAX" finds
// "$14.vmax", "SET_FILTER_MAX_SPEED" the DeviceNet command); other bytes must be equal.
inline bool NameEqualsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

// The catalogue of every family, built by the composition root (server/gateway.cpp) from each
// family's `<Family>ParameterCatalogue()` function.
using CatalogueList = std::vector<std::shared_ptr<const ParameterCatalogue>>;

}  // namespace drivegw
