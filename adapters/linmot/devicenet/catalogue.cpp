// LinMot DeviceNet catalogue (decision 009), driven by the command table (commands.h, §8.4).
#include "adapters/linmot/devicenet/catalogue.h"

#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/linmot/common/parameter_id.h"
#include "adapters/linmot/devicenet/commands.h"
#include "adapters/linmot/devicenet/factory.h"

namespace drivegw::linmot::devicenet {
namespace {

// The Set halves WriteParameter accepts (decision 985: 0x24-0x2D, 0x30-0x53, 0x56-0x5D,
// 0x62/0x63, 0x66/0x67, 0x6A/0x6B, 0x70-0x73; the same list as drive.cpp IsWritableParameter).
bool IsParameterSet(uint8_t id) {
  if (id >= 0x25 && id <= 0x2D) return id % 2 == 1;
  if (id >= 0x31 && id <= 0x53) return id % 2 == 1;
  if (id >= 0x57 && id <= 0x5D) return id % 2 == 1;
  return id == 0x63 || id == 0x67 || id == 0x6B || id == 0x71 || id == 0x73;
}

std::string IdText(uint32_t id) { return absl::StrFormat("0x%02X", id); }

ParameterDefinition FromSpec(const CommandSpec& set) {
  const ValueSpec& v = set.request;
  ParameterDefinition d;
  d.id = set.id;
  d.name = IdText(set.id);
  std::string title = set.name;
  if (title.rfind("Set ", 0) == 0) title.erase(0, 4);
  d.title = title;
  switch (v.type) {
    case ValueType::kInt16:
      d.type = "i16";
      d.min = v.min;
      d.max = v.max;
      break;
    case ValueType::kUInt16:
      d.type = "u16";
      d.min = v.min;
      d.max = v.max;
      break;
    default:
      d.type = "bits16";
      d.min = 0;
      d.max = 0xFFFF;
  }
  d.unit = v.unit;
  d.writable = true;
  d.has_stored_value = false;  // Set commands are volatile (§8.8, D-29)
  const CommandSpec* get = FindCommand(static_cast<uint8_t>(set.id - 1));
  d.description =
      absl::StrCat(set.name, " / ",
                   get != nullptr && get->documented ? get->name : std::string("no documented Get"),
                   " (linmot-devicenet.md §8.9, seed lines ", set.seed_lines, "; decision 906)");
  return d;
}

class LinMotDevicenetCatalogue final : public ParameterCatalogue {
 public:
  LinMotDevicenetCatalogue() {
    for (const CommandSpec& c : AllCommands()) {
      if (c.kind == CommandKind::kSet && IsParameterSet(c.id)) definitions_.push_back(FromSpec(c));
    }
  }
  std::string family() const override { return kFamilyName; }
  const std::vector<ParameterDefinition>& Definitions() const override { return definitions_; }

  absl::StatusOr<ParameterDefinition> Find(std::string_view text) const override {
    if (const std::optional<uint32_t> id = ParseParameterId(text)) {
      for (const ParameterDefinition& d : definitions_) {
        if (d.id == *id || d.id == *id + 1) return d;  // the Set ID or its Get half
      }
    } else {
      for (const ParameterDefinition& d : definitions_) {
        const CommandSpec* set = FindCommand(static_cast<uint8_t>(d.id));
        const CommandSpec* get = FindCommand(static_cast<uint8_t>(d.id - 1));
        if (NameEqualsIgnoreCase(text, set->key()) || NameEqualsIgnoreCase(text, set->name) ||
            (get != nullptr &&
             (NameEqualsIgnoreCase(text, get->key()) || NameEqualsIgnoreCase(text, get->name)))) {
          return d;
        }
      }
    }
    return absl::NotFoundError(absl::StrCat(
        "linmot-devicenet: \"", std::string(text),
        "\" is not a parameter pair of linmot-devicenet.md §8.9; use a Set/Get command ID "
        "(\"0x51\") or its name (\"set_filter_max_speed\")"));
  }

 private:
  std::vector<ParameterDefinition> definitions_;
};

}  // namespace

std::shared_ptr<const ParameterCatalogue> MakeLinMotDevicenetCatalogue() {
  return std::make_shared<const LinMotDevicenetCatalogue>();
}

std::shared_ptr<const ParameterCatalogue> LinMotDevicenetParameterCatalogue() {
  static const std::shared_ptr<const ParameterCatalogue> catalogue = MakeLinMotDevicenetCatalogue();
  return catalogue;
}

}  // namespace drivegw::linmot::devicenet
