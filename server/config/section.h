// Schema-checked YAML mappings for the configuration parser: every problem becomes one line
// naming the key path, the value and the limit (docs/config.md). Internal to server/config.
#pragma once

#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace drivegw::config::internal {

inline constexpr size_t kMaxErrors = 20;

inline absl::string_view Av(std::string_view s) { return absl::string_view(s.data(), s.size()); }

// Edit distance, for "did you mean" on misspelt keys.
size_t Distance(std::string_view a, std::string_view b);

// "null", "a scalar", "a sequence", "a mapping".
const char* KindName(const YAML::Node& node);

// Collects every problem so one run of the gateway reports them all.
class Errors {
 public:
  // "<path>: <what> (line L, column C)"; the position only when `at` is defined.
  void Add(std::string_view path, std::string_view what, const YAML::Node& at);
  bool empty() const { return count_ == 0; }
  absl::Status ToStatus() const;

 private:
  std::vector<std::string> list_;
  size_t count_ = 0;
};

// A mapping whose keys are checked against the schema: unknown, duplicate and non-scalar keys
// are errors; Get() hands out the known ones.
class Section {
 public:
  Section(const YAML::Node& node, std::string path, std::initializer_list<std::string_view> keys,
          Errors& errors);

  // The value under `key`, or nullopt when absent.
  std::optional<YAML::Node> Get(std::string_view key) const;
  bool Has(std::string_view key) const { return values_.count(std::string(key)) != 0; }

  std::string Child(std::string_view key) const;
  std::string Label() const { return path_.empty() ? "(root)" : path_; }
  Errors& errors() const { return errors_; }

  // ---- typed readers: a missing key leaves `out` at its default ----

  // `required` adds "<path>: required" when absent.
  bool String(std::string_view key, std::string& out, bool required = false) const;
  bool Int(std::string_view key, int64_t min, int64_t max, int64_t& out) const;
  bool Double(std::string_view key, double& out, bool required) const;
  bool Bool(std::string_view key, bool& out) const;
  // Integer milliseconds 1..max.
  bool Millis(std::string_view key, int64_t max, std::chrono::milliseconds& out) const;

  // "'text'" for scalars, the node kind otherwise.
  static std::string Shown(const YAML::Node& node);

 private:
  std::string path_;
  Errors& errors_;
  std::map<std::string, YAML::Node> values_;
};

}  // namespace drivegw::config::internal
