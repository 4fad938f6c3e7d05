// Parameter set files: a small JSON reader that keeps line numbers (so an error names the line the
// operator has to fix, decision 011) and the CSV reader/writers.
#include "server/core/parameter_set_io.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace drivegw::server {
namespace {

absl::Status LineError(int line, std::string_view field, std::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat("line ", line, ", field ", std::string(field), ": ", std::string(what)));
}

struct JsonMember;

// One JSON value with the line it starts on. Object members are a struct declared ahead and
// defined below, not std::pair<std::string, JsonValue>: clang 14 with libstdc++ 12 checks that
// pair is destructible while JsonValue is still incomplete and refuses the file (the clang-14
// build-fuzz/ tree, docs/reliability.md "Fuzzing"); gcc accepts both.
struct JsonValue {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject } kind = Kind::kNull;
  int line = 1;
  bool boolean = false;
  std::string text;  // number as written, or the string's content
  std::vector<JsonValue> items;
  std::vector<JsonMember> members;
};

struct JsonMember {
  std::string key;
  JsonValue value;
};

class JsonReader {
 public:
  explicit JsonReader(std::string_view s) : s_(s) {}

  absl::StatusOr<JsonValue> Document() {
    auto v = Value();
    if (!v.ok()) return v;
    Skip();
    if (pos_ != s_.size()) return Syntax("trailing characters after the document");
    return v;
  }

 private:
  absl::Status Syntax(std::string_view what) const {
    return absl::InvalidArgumentError(
        absl::StrCat("line ", line_, ": JSON syntax: ", std::string(what)));
  }
  void Skip() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }
  bool Eat(char c) {
    Skip();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  absl::StatusOr<std::string> String() {
    if (!Eat('"')) return Syntax("expected a string");
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      char c = s_[pos_++];
      if (c == '\n') return Syntax("newline in a string");
      if (c == '\\') {
        if (pos_ >= s_.size()) break;
        char e = s_[pos_++];
        switch (e) {
          case 'n':
            out += '\n';
            break;
          case 't':
            out += '\t';
            break;
          case 'r':
            out += '\r';
            break;
          case 'b':
            out += '\b';
            break;
          case 'f':
            out += '\f';
            break;
          case 'u': {
            unsigned v = 0;
            if (pos_ + 4 > s_.size() || !absl::SimpleHexAtoi(std::string(s_.substr(pos_, 4)), &v)) {
              return Syntax("bad \\u escape");
            }
            pos_ += 4;
            // Names and descriptions are ASCII in practice; others are kept as UTF-8 (BMP only).
            if (v < 0x80) {
              out += static_cast<char>(v);
            } else if (v < 0x800) {
              out += static_cast<char>(0xC0 | (v >> 6));
              out += static_cast<char>(0x80 | (v & 0x3F));
            } else {
              out += static_cast<char>(0xE0 | (v >> 12));
              out += static_cast<char>(0x80 | ((v >> 6) & 0x3F));
              out += static_cast<char>(0x80 | (v & 0x3F));
            }
            break;
          }
          default:
            out += e;
        }
      } else {
        out += c;
      }
    }
    if (pos_ >= s_.size()) return Syntax("unterminated string");
    ++pos_;
    return out;
  }
  absl::StatusOr<JsonValue> Value() {
    if (++depth_ > 32) return Syntax("nested too deeply");
    Skip();
    JsonValue v;
    v.line = line_;
    if (pos_ >= s_.size()) return Syntax("unexpected end of input");
    const char c = s_[pos_];
    if (c == '{') {
      ++pos_;
      v.kind = JsonValue::Kind::kObject;
      if (!Eat('}')) {
        do {
          auto key = String();
          if (!key.ok()) return key.status();
          if (!Eat(':')) return Syntax(absl::StrCat("expected ':' after \"", *key, "\""));
          auto member = Value();
          if (!member.ok()) return member.status();
          v.members.push_back(JsonMember{*std::move(key), *std::move(member)});
        } while (Eat(','));
        if (!Eat('}')) return Syntax("expected ',' or '}'");
      }
    } else if (c == '[') {
      ++pos_;
      v.kind = JsonValue::Kind::kArray;
      if (!Eat(']')) {
        do {
          auto item = Value();
          if (!item.ok()) return item.status();
          v.items.push_back(*std::move(item));
        } while (Eat(','));
        if (!Eat(']')) return Syntax("expected ',' or ']'");
      }
    } else if (c == '"') {
      v.kind = JsonValue::Kind::kString;
      auto s = String();
      if (!s.ok()) return s.status();
      v.text = *std::move(s);
    } else if (s_.substr(pos_, 4) == "true" || s_.substr(pos_, 5) == "false") {
      v.kind = JsonValue::Kind::kBool;
      v.boolean = s_[pos_] == 't';
      pos_ += v.boolean ? 4 : 5;
    } else if (s_.substr(pos_, 4) == "null") {
      pos_ += 4;
    } else if (c == '-' || std::isdigit(static_cast<unsigned char>(c))) {
      v.kind = JsonValue::Kind::kNumber;
      const size_t start = pos_;
      while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) ||
                                  s_[pos_] == '-' || s_[pos_] == '+' || s_[pos_] == '.')) {
        ++pos_;
      }
      v.text = std::string(s_.substr(start, pos_ - start));
    } else {
      return Syntax(absl::StrCat("unexpected character '", std::string(1, c), "'"));
    }
    --depth_;
    return v;
  }

  std::string_view s_;
  size_t pos_ = 0;
  int line_ = 1;
  int depth_ = 0;
};

const char* KindName(JsonValue::Kind k) {
  switch (k) {
    case JsonValue::Kind::kNull:
      return "null";
    case JsonValue::Kind::kBool:
      return "a boolean";
    case JsonValue::Kind::kNumber:
      return "a number";
    case JsonValue::Kind::kString:
      return "a string";
    case JsonValue::Kind::kArray:
      return "an array";
    case JsonValue::Kind::kObject:
      return "an object";
  }
  return "?";
}

absl::Status WrongKind(const JsonValue& v, std::string_view field, std::string_view want) {
  return LineError(v.line, field,
                   absl::StrCat("expected ", std::string(want), ", got ", KindName(v.kind)));
}

absl::StatusOr<std::string> AsString(const JsonValue& v, std::string_view field) {
  if (v.kind != JsonValue::Kind::kString) return WrongKind(v, field, "a string");
  return v.text;
}

// An integer value: a JSON number or a string holding one (hex "0x..." too: LinMot UPID values
// are often written in hex in the manual).
absl::StatusOr<int64_t> ParseInteger(absl::string_view text, int line, std::string_view field) {
  std::string t(absl::StripAsciiWhitespace(text));
  int64_t v = 0;
  bool ok = false;
  // Only hex digits after the prefix: SimpleHexAtoi also takes a sign and a second "0x", so
  // "0x-5" read as -5 and "-0x-8000000000000000" negated INT64_MIN (signed overflow; decision
  // 1404).
  auto hex_digits = [](absl::string_view d) {
    return !d.empty() && std::all_of(d.begin(), d.end(), [](char c) {
      return absl::ascii_isxdigit(static_cast<unsigned char>(c));
    });
  };
  if (absl::StartsWithIgnoreCase(t, "0x")) {
    ok = hex_digits(absl::string_view(t).substr(2)) && absl::SimpleHexAtoi(t.substr(2), &v);
  } else if (absl::StartsWithIgnoreCase(t, "-0x")) {
    // At most 0x7FFFFFFFFFFFFFFF after the sign: the negation cannot overflow.
    ok = hex_digits(absl::string_view(t).substr(3)) && absl::SimpleHexAtoi(t.substr(3), &v);
    v = -v;
  } else {
    ok = absl::SimpleAtoi(t, &v);
  }
  if (!ok || t.empty()) return LineError(line, field, absl::StrCat("'", t, "' is not an integer"));
  return v;
}

}  // namespace

absl::StatusOr<storage::ParameterSet> ParseParameterSetJson(std::string_view content) {
  JsonReader reader(content);
  auto doc = reader.Document();
  if (!doc.ok()) return doc.status();
  if (doc->kind != JsonValue::Kind::kObject) return WrongKind(*doc, "(document)", "an object");
  storage::ParameterSet set;
  bool have_parameters = false;
  for (const auto& [key, v] : doc->members) {
    if (key == "name" || key == "family" || key == "model" || key == "description") {
      auto s = AsString(v, key);
      if (!s.ok()) return s.status();
      (key == "name"     ? set.name
       : key == "family" ? set.family
       : key == "model"  ? set.model
                         : set.description) = *std::move(s);
    } else if (key == "target_stored") {
      if (v.kind != JsonValue::Kind::kBool) return WrongKind(v, key, "true or false");
      set.target_stored = v.boolean;
    } else if (key == "parameters") {
      if (v.kind != JsonValue::Kind::kArray) return WrongKind(v, key, "an array");
      have_parameters = true;
      for (size_t i = 0; i < v.items.size(); ++i) {
        const JsonValue& item = v.items[i];
        const std::string where = absl::StrCat("parameters[", i, "]");
        if (item.kind != JsonValue::Kind::kObject) return WrongKind(item, where, "an object");
        storage::ParameterValue pv;
        bool has_name = false;
        bool has_value = false;
        for (const auto& [k, f] : item.members) {
          if (k == "parameter") {
            if (f.kind == JsonValue::Kind::kString || f.kind == JsonValue::Kind::kNumber) {
              pv.parameter = f.text;
            } else {
              return WrongKind(f, "parameter", "a name or id");
            }
            has_name = !pv.parameter.empty();
          } else if (k == "value") {
            if (f.kind != JsonValue::Kind::kNumber && f.kind != JsonValue::Kind::kString) {
              return WrongKind(f, "value", "an integer");
            }
            auto n = ParseInteger(absl::string_view(f.text), f.line, "value");
            if (!n.ok()) return n.status();
            pv.value = *n;
            has_value = true;
          } else if (k != "id" && k != "title" && k != "unit") {
            // id/title/unit are informative (an export may carry them); anything else is a typo.
            return LineError(f.line, k, "unknown field (expected parameter, value)");
          }
        }
        if (!has_name) return LineError(item.line, "parameter", "is required");
        if (!has_value) return LineError(item.line, "value", "is required");
        set.values.push_back(std::move(pv));
      }
    } else if (key != "version" && key != "etag") {
      return LineError(v.line, key,
                       "unknown field (expected name, family, model, description, target_stored, "
                       "parameters)");
    }
  }
  if (!have_parameters) return LineError(doc->line, "parameters", "is required");
  return set;
}

absl::StatusOr<storage::ParameterSet> ParseParameterSetCsv(std::string_view content) {
  storage::ParameterSet set;
  bool header_seen = false;
  int line_no = 0;
  for (absl::string_view raw :
       absl::StrSplit(absl::string_view(content.data(), content.size()), '\n')) {
    ++line_no;
    absl::string_view line = absl::StripAsciiWhitespace(raw);  // also drops a CR of CRLF files
    if (line.empty() || line.front() == '#') continue;
    std::vector<absl::string_view> cells = absl::StrSplit(line, ',');
    for (auto& c : cells) c = absl::StripAsciiWhitespace(c);
    if (!header_seen) {
      if (cells.size() != 2 || !absl::EqualsIgnoreCase(cells[0], "parameter") ||
          !absl::EqualsIgnoreCase(cells[1], "value")) {
        return LineError(line_no, "header", "expected 'parameter,value'");
      }
      header_seen = true;
      continue;
    }
    if (cells.size() != 2) {
      return LineError(line_no, cells.size() < 2 ? "value" : "(row)",
                       absl::StrCat("expected 2 fields (parameter,value), got ", cells.size()));
    }
    if (cells[0].empty()) return LineError(line_no, "parameter", "is empty");
    auto v = ParseInteger(cells[1], line_no, "value");
    if (!v.ok()) return v.status();
    set.values.push_back(storage::ParameterValue{std::string(cells[0]), 0, *v});
  }
  if (!header_seen) return LineError(line_no, "header", "missing ('parameter,value')");
  return set;
}

namespace {

std::string JsonQuote(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += absl::StrCat("\\u00", absl::Hex(static_cast<unsigned char>(c), absl::kZeroPad2));
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace

std::string ParameterSetToJson(const storage::ParameterSet& set) {
  std::string out = absl::StrCat("{\n  \"name\": ", JsonQuote(set.name),
                                 ",\n  \"family\": ", JsonQuote(set.family),
                                 ",\n  \"model\": ", JsonQuote(set.model),
                                 ",\n  \"description\": ", JsonQuote(set.description),
                                 ",\n  \"target_stored\": ", set.target_stored ? "true" : "false",
                                 ",\n  \"version\": ", set.version, ",\n  \"parameters\": [");
  for (size_t i = 0; i < set.values.size(); ++i) {
    const auto& v = set.values[i];
    absl::StrAppend(&out, i == 0 ? "\n" : ",\n", "    {\"parameter\": ", JsonQuote(v.parameter),
                    ", \"value\": ", v.value, "}");
  }
  absl::StrAppend(&out, set.values.empty() ? "]\n}\n" : "\n  ]\n}\n");
  return out;
}

std::string ParameterSetToCsv(const storage::ParameterSet& set) {
  std::string out = absl::StrCat("# parameter set ", set.name, ", family ", set.family,
                                 ", version ", set.version, "\nparameter,value\n");
  for (const auto& v : set.values) absl::StrAppend(&out, v.parameter, ",", v.value, "\n");
  return out;
}

}  // namespace drivegw::server
