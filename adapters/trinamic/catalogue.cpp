// Trinamic catalogue: wraps parameters.h (ids opcode << 8 | P, names "$14.vmax"; decision 1071).
#include "adapters/trinamic/catalogue.h"

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/factory.h"
#include "adapters/trinamic/parameters.h"

namespace drivegw::trinamic {
namespace {

using Definition = ::drivegw::ParameterDefinition;

const char* TypeName(FieldType type) {
  switch (type) {
    case FieldType::kU8:
      return "u8";
    case FieldType::kI8:
      return "i8";
    case FieldType::kU16:
      return "u16";
    case FieldType::kI16:
      return "i16";
    case FieldType::kU32:
      return "u32";
    case FieldType::kI32:
      return "i32";
  }
  return "unknown";
}

// The codec's field of a parameter (type, multiple_of); nullptr if the table lacks it.
const FieldSpec* FieldFor(const ParameterDefinition& p) {
  auto spec = FindOpcode(static_cast<uint8_t>(p.opcode));
  if (!spec.ok()) return nullptr;
  for (const FieldSpec& f : (*spec)->fields) {
    if (f.name != nullptr && p.field == f.name) return &f;
  }
  return nullptr;
}

class TrinamicCatalogue final : public ::drivegw::ParameterCatalogue {
 public:
  TrinamicCatalogue() {
    for (const ParameterDefinition& p : drivegw::trinamic::ParameterCatalogue()) {
      Definition d;
      d.id = p.id;
      d.name = p.name;
      d.title = p.field;
      const FieldSpec* f = FieldFor(p);
      d.type = f != nullptr ? TypeName(f->type) : "unknown";
      d.unit = p.unit;
      d.min = p.min;
      d.max = p.max;
      d.default_value = p.default_value;
      d.writable = true;
      // G-24 (L325, L371, L899): the PACK stores nothing, so no ROM value to target.
      d.has_stored_value = false;
      d.description = absl::StrCat(
          p.description, p.scope == ParameterScope::kController ? " [controller-wide]" : "",
          p.rule == WriteRule::kAxisStopped  ? " [axis stopped]"
          : p.rule == WriteRule::kAllStopped ? " [all motors stopped]"
                                             : "");
      multiple_of_.push_back(f != nullptr ? f->multiple_of : 1);
      definitions_.push_back(std::move(d));
    }
  }

  std::string family() const override { return kFamilyName; }
  const std::vector<Definition>& Definitions() const override { return definitions_; }

  // "$14.vmax" (case-insensitive) or "0x1403"; no open address space: the PACK has no other
  // parameters (§4.2).
  absl::StatusOr<Definition> Find(std::string_view name_or_id) const override {
    auto p = FindParameter(name_or_id);
    if (!p.ok()) {
      return absl::NotFoundError(absl::StrCat("trinamic: ", p.status().message()));
    }
    for (const Definition& d : definitions_) {
      if (d.id == (*p)->id) return d;
    }
    return absl::NotFoundError(
        absl::StrCat("trinamic: \"", std::string(name_or_id), "\" is not in the catalogue"));
  }

  absl::Status Validate(const Definition& definition, int64_t value) const override {
    if (absl::Status s = ::drivegw::ParameterCatalogue::Validate(definition, value); !s.ok()) {
      return s;
    }
    for (size_t i = 0; i < definitions_.size(); ++i) {
      if (definitions_[i].id != definition.id || multiple_of_[i] <= 1) continue;
      if (value % multiple_of_[i] != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(definition.name, ": ", value, " is not a multiple of ",
                         static_cast<int>(multiple_of_[i]), " (L618-625)"));
      }
    }
    return absl::OkStatus();
  }

 private:
  std::vector<Definition> definitions_;
  std::vector<uint8_t> multiple_of_;  // per definition, from the codec's field table
};

}  // namespace

std::shared_ptr<const drivegw::ParameterCatalogue> MakeTrinamicCatalogue() {
  return std::make_shared<const TrinamicCatalogue>();
}

std::shared_ptr<const drivegw::ParameterCatalogue> TrinamicParameterCatalogue() {
  static const std::shared_ptr<const drivegw::ParameterCatalogue> catalogue =
      MakeTrinamicCatalogue();
  return catalogue;
}

}  // namespace drivegw::trinamic
