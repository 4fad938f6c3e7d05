// nlohmann/json (already a project dependency, top-level CMakeLists) reads and writes the JSON
// columns; parse errors never throw out of here, they become a Status.
#include "storage/parameter_set_json.h"

#include <limits>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"

namespace drivegw::storage {
namespace {

using nlohmann::json;

json ValuesArray(const std::vector<ParameterValue>& values) {
  json out = json::array();
  for (const ParameterValue& v : values) {
    out.push_back({{"parameter", v.parameter}, {"id", v.id}, {"value", v.value}});
  }
  return out;
}

// dump() throws type_error 316 on invalid UTF-8; that is a caller's bad text, not our fault.
absl::StatusOr<std::string> Dump(const json& j, std::string_view field) {
  try {
    return j.dump();
  } catch (const json::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(field), ": text is not valid UTF-8 (", e.what(), ")"));
  }
}

absl::Status Bad(std::string_view what, std::string_view why) {
  return absl::DataLossError(absl::StrCat("storage: stored JSON of ", std::string(what),
                                          " is malformed: ", std::string(why)));
}

absl::StatusOr<json> Parse(std::string_view text, std::string_view what) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Bad(what, "not JSON");
  if (!j.is_array()) return Bad(what, "not an array");
  return j;
}

bool GetString(const json& obj, const char* key, std::string& out) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_string()) return false;
  out = it->get<std::string>();
  return true;
}

absl::StatusOr<std::vector<ParameterValue>> ValuesFrom(const json& array, std::string_view what) {
  std::vector<ParameterValue> out;
  out.reserve(array.size());
  for (size_t i = 0; i < array.size(); ++i) {
    const json& e = array[i];
    const std::string at = absl::StrCat("values[", i, "]");
    if (!e.is_object()) return Bad(what, absl::StrCat(at, " is not an object"));
    ParameterValue v;
    if (!GetString(e, "parameter", v.parameter)) {
      return Bad(what, absl::StrCat(at, ".parameter is missing or not a string"));
    }
    const auto id = e.find("id");
    if (id == e.end() || !id->is_number_unsigned() ||
        id->get<uint64_t>() > std::numeric_limits<uint32_t>::max()) {
      return Bad(what, absl::StrCat(at, ".id is missing or not 0..4294967295"));
    }
    v.id = static_cast<uint32_t>(id->get<uint64_t>());
    const auto value = e.find("value");
    // nlohmann keeps non-negative integers as number_unsigned (uint64): above INT64_MAX is bad.
    if (value == e.end() || !value->is_number_integer() ||
        (value->is_number_unsigned() &&
         value->get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))) {
      return Bad(what, absl::StrCat(at, ".value is missing or not a 64-bit integer"));
    }
    v.value = value->get<int64_t>();
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace

absl::StatusOr<std::string> ValuesToJson(const std::vector<ParameterValue>& values) {
  return Dump(ValuesArray(values), "values");
}

absl::StatusOr<std::vector<ParameterValue>> ValuesFromJson(std::string_view text,
                                                           std::string_view what) {
  auto j = Parse(text, what);
  if (!j.ok()) return j.status();
  return ValuesFrom(*j, what);
}

absl::StatusOr<std::string> DrivesToJson(const std::vector<ApplyDriveResult>& drives) {
  json out = json::array();
  for (const ApplyDriveResult& d : drives) {
    out.push_back({{"drive", d.drive},
                   {"state", d.state},
                   {"pre_image", ValuesArray(d.pre_image)},
                   {"written", ValuesArray(d.written)},
                   {"failed_parameter", d.failed_parameter},
                   {"error", d.error}});
  }
  return Dump(out, "apply_operation.drives");
}

absl::StatusOr<std::vector<ApplyDriveResult>> DrivesFromJson(std::string_view text,
                                                             std::string_view what) {
  auto j = Parse(text, what);
  if (!j.ok()) return j.status();
  std::vector<ApplyDriveResult> out;
  for (size_t i = 0; i < j->size(); ++i) {
    const json& e = (*j)[i];
    const std::string at = absl::StrCat("drives[", i, "]");
    if (!e.is_object()) return Bad(what, absl::StrCat(at, " is not an object"));
    ApplyDriveResult d;
    if (!GetString(e, "drive", d.drive) || !GetString(e, "state", d.state) ||
        !GetString(e, "failed_parameter", d.failed_parameter) || !GetString(e, "error", d.error)) {
      return Bad(what, absl::StrCat(at, " lacks a string drive/state/failed_parameter/error"));
    }
    for (const char* key : {"pre_image", "written"}) {
      const auto it = e.find(key);
      if (it == e.end() || !it->is_array()) {
        return Bad(what, absl::StrCat(at, ".", key, " is missing or not an array"));
      }
      auto values = ValuesFrom(*it, absl::StrCat(std::string(what), " ", at, ".", key));
      if (!values.ok()) return values.status();
      (std::string_view(key) == "pre_image" ? d.pre_image : d.written) = std::move(*values);
    }
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace drivegw::storage
