// Schema-checked YAML mappings: unknown keys with "did you mean", typed readers with limits.
#include "server/config/section.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace drivegw::config::internal {

size_t Distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

const char* KindName(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Scalar:
      return "a scalar";
    case YAML::NodeType::Sequence:
      return "a sequence";
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Undefined:
      break;
  }
  return "nothing";
}

void Errors::Add(std::string_view path, std::string_view what, const YAML::Node& at) {
  std::string line = absl::StrCat(Av(path), ": ", Av(what));
  if (at.IsDefined()) {
    const YAML::Mark mark = at.Mark();
    if (!mark.is_null()) {
      absl::StrAppend(&line, " (line ", mark.line + 1, ", column ", mark.column + 1, ")");
    }
  }
  if (list_.size() < kMaxErrors) list_.push_back(std::move(line));
  ++count_;
}

absl::Status Errors::ToStatus() const {
  std::string msg = absl::StrJoin(list_, "; ");
  if (count_ > list_.size()) absl::StrAppend(&msg, "; and ", count_ - list_.size(), " more");
  return absl::InvalidArgumentError(msg);
}

Section::Section(const YAML::Node& node, std::string path,
                 std::initializer_list<std::string_view> keys, Errors& errors)
    : path_(std::move(path)), errors_(errors) {
  if (node.IsNull()) return;  // "listen:" with nothing below: all defaults
  if (!node.IsMap()) {
    errors_.Add(Label(), absl::StrCat("expected a mapping, got ", KindName(node)), node);
    return;
  }
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) {
      errors_.Add(Label(), "keys must be plain names", kv.first);
      continue;
    }
    const std::string key = kv.first.Scalar();
    const std::string key_path = Child(key);
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      std::string what = "unknown key";
      for (std::string_view known : keys) {
        if (Distance(key, known) <= 2) {
          absl::StrAppend(&what, " (did you mean '", Av(known), "'?)");
          break;
        }
      }
      errors_.Add(key_path, what, kv.first);
      continue;
    }
    if (!values_.emplace(key, kv.second).second) {
      errors_.Add(key_path, "duplicate key", kv.first);
    }
  }
}

std::optional<YAML::Node> Section::Get(std::string_view key) const {
  auto it = values_.find(std::string(key));
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

std::string Section::Child(std::string_view key) const {
  return path_.empty() ? std::string(key) : absl::StrCat(path_, ".", Av(key));
}

bool Section::String(std::string_view key, std::string& out, bool required) const {
  auto node = Get(key);
  if (!node) {
    if (required) errors_.Add(Child(key), "required", YAML::Node());
    return false;
  }
  if (!node->IsScalar()) {
    errors_.Add(Child(key), absl::StrCat("expected a string, got ", KindName(*node)), *node);
    return false;
  }
  out = node->Scalar();
  return true;
}

bool Section::Int(std::string_view key, int64_t min, int64_t max, int64_t& out) const {
  auto node = Get(key);
  if (!node) return false;
  int64_t value = 0;
  if (!node->IsScalar() || !absl::SimpleAtoi(node->Scalar(), &value)) {
    errors_.Add(Child(key), absl::StrCat(Shown(*node), " is not an integer"), *node);
    return false;
  }
  if (value < min) {
    errors_.Add(Child(key), absl::StrCat(value, " is below ", min), *node);
    return false;
  }
  if (value > max) {
    errors_.Add(Child(key), absl::StrCat(value, " exceeds ", max), *node);
    return false;
  }
  out = value;
  return true;
}

bool Section::Double(std::string_view key, double& out, bool required) const {
  auto node = Get(key);
  if (!node) {
    if (required) errors_.Add(Child(key), "required", YAML::Node());
    return false;
  }
  double value = 0;
  if (!node->IsScalar() || !absl::SimpleAtod(node->Scalar(), &value) || !std::isfinite(value)) {
    errors_.Add(Child(key), absl::StrCat(Shown(*node), " is not a finite number"), *node);
    return false;
  }
  out = value;
  return true;
}

// YAML 1.2 core schema booleans only: "yes"/"on" are YAML 1.1 and read as strings elsewhere.
bool Section::Bool(std::string_view key, bool& out) const {
  auto node = Get(key);
  if (!node) return false;
  if (node->IsScalar()) {
    const std::string& text = node->Scalar();
    if (text == "true" || text == "True" || text == "TRUE") {
      out = true;
      return true;
    }
    if (text == "false" || text == "False" || text == "FALSE") {
      out = false;
      return true;
    }
  }
  errors_.Add(Child(key), absl::StrCat(Shown(*node), " is not true or false"), *node);
  return false;
}

bool Section::Millis(std::string_view key, int64_t max, std::chrono::milliseconds& out) const {
  int64_t ms = 0;
  if (!Int(key, 1, max, ms)) return false;
  out = std::chrono::milliseconds(ms);
  return true;
}

std::string Section::Shown(const YAML::Node& node) {
  if (node.IsScalar()) return absl::StrCat("'", node.Scalar(), "'");
  return KindName(node);
}

}  // namespace drivegw::config::internal
