// google.api.http path templates: a small recursive-descent parser and a segment matcher.
#include "server/rest/path_template.h"

#include <algorithm>
#include <set>

#include "absl/container/inlined_vector.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace drivegw::rest {
namespace {

// abseil 20220623 is built without std::string_view (ABSL_OPTION_USE_STD_STRING_VIEW 0).
absl::string_view Av(std::string_view s) { return absl::string_view(s.data(), s.size()); }

bool IsIdentStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsIdentChar(char c) { return IsIdentStart(c) || (c >= '0' && c <= '9'); }
// RFC 3986 unreserved plus the sub-delims that cannot start template syntax.
bool IsLiteralChar(char c) {
  return IsIdentChar(c) || c == '-' || c == '.' || c == '~' || c == '!' || c == '$' || c == '&' ||
         c == '\'' || c == '(' || c == ')' || c == '+' || c == ',' || c == ';' || c == '@' ||
         c == '%';
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// PercentDecode(in) == literal, without building the decoded string; false on a bad escape.
bool DecodedEquals(std::string_view in, std::string_view literal) {
  size_t j = 0;
  for (size_t i = 0; i < in.size(); ++i, ++j) {
    char c = in[i];
    if (c == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = HexValue(in[i + 1]);
      const int lo = HexValue(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      c = static_cast<char>(hi * 16 + lo);
      i += 2;
    }
    if (j >= literal.size() || literal[j] != c) return false;
  }
  return j == literal.size();
}

// True when PercentDecode(in) succeeds (every '%' starts a complete escape).
bool WellEncoded(std::string_view in) {
  for (size_t i = in.find('%'); i != std::string_view::npos; i = in.find('%', i + 3)) {
    if (i + 2 >= in.size() || HexValue(in[i + 1]) < 0 || HexValue(in[i + 2]) < 0) return false;
  }
  return true;
}

// Position of the ':' that starts a path's verb: the last ':' of its last segment (an encoded
// %3A is data); nullopt when that segment has none.
std::optional<size_t> VerbColon(std::string_view path) {
  const size_t slash = path.rfind('/');
  const size_t colon = path.rfind(':');
  if (colon == std::string_view::npos || (slash != std::string_view::npos && colon < slash)) {
    return std::nullopt;
  }
  return colon;
}

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  absl::Status Run(std::vector<PathTemplate::Segment>& segments,
                   std::vector<PathTemplate::Variable>& variables, std::string& verb) {
    if (!Consume('/')) return Error("must start with '/'");
    if (auto s = ParseSegments(segments, variables, /*in_variable=*/false); !s.ok()) return s;
    if (Consume(':')) {
      const size_t start = pos_;
      while (pos_ < text_.size() && IsLiteralChar(text_[pos_])) ++pos_;
      if (pos_ == start) return Error("empty verb");
      verb.assign(text_.substr(start, pos_ - start));
    }
    if (pos_ != text_.size())
      return Error(absl::StrCat("unexpected '", Av(text_.substr(pos_, 1)), "'"));
    for (size_t i = 0; i + 1 < segments.size(); ++i) {
      if (segments[i].kind == PathTemplate::SegmentKind::kMulti) {
        return absl::InvalidArgumentError(
            absl::StrCat("path template \"", Av(text_), "\": '**' must be the last segment"));
      }
    }
    std::set<std::string> seen;
    for (const auto& v : variables) {
      if (!seen.insert(v.field_path).second) {
        return absl::InvalidArgumentError(absl::StrCat("path template \"", Av(text_), "\": field ",
                                                       v.field_path, " bound twice"));
      }
    }
    return absl::OkStatus();
  }

 private:
  absl::Status ParseSegments(std::vector<PathTemplate::Segment>& segments,
                             std::vector<PathTemplate::Variable>& variables, bool in_variable) {
    do {
      if (auto s = ParseSegment(segments, variables, in_variable); !s.ok()) return s;
    } while (Consume('/'));
    return absl::OkStatus();
  }

  absl::Status ParseSegment(std::vector<PathTemplate::Segment>& segments,
                            std::vector<PathTemplate::Variable>& variables, bool in_variable) {
    using Kind = PathTemplate::SegmentKind;
    if (Consume('*')) {
      segments.push_back({Consume('*') ? Kind::kMulti : Kind::kSingle, {}});
      return absl::OkStatus();
    }
    if (Peek('{')) {
      if (in_variable) return Error("nested variable");
      return ParseVariable(segments, variables);
    }
    const size_t start = pos_;
    while (pos_ < text_.size() && IsLiteralChar(text_[pos_])) ++pos_;
    if (pos_ == start) return Error("empty segment");
    auto literal = PercentDecode(text_.substr(start, pos_ - start));
    if (!literal) return Error("malformed percent-encoding");
    segments.push_back({Kind::kLiteral, std::move(*literal)});
    return absl::OkStatus();
  }

  absl::Status ParseVariable(std::vector<PathTemplate::Segment>& segments,
                             std::vector<PathTemplate::Variable>& variables) {
    Consume('{');
    PathTemplate::Variable var;
    do {
      const size_t start = pos_;
      if (pos_ >= text_.size() || !IsIdentStart(text_[pos_])) return Error("expected field name");
      while (pos_ < text_.size() && IsIdentChar(text_[pos_])) ++pos_;
      if (!var.field_path.empty()) var.field_path += '.';
      var.field_path.append(text_.substr(start, pos_ - start));
    } while (Consume('.'));
    var.first_segment = segments.size();
    if (Consume('=')) {
      if (auto s = ParseSegments(segments, variables, /*in_variable=*/true); !s.ok()) return s;
    } else {
      segments.push_back({PathTemplate::SegmentKind::kSingle, {}});
    }
    if (!Consume('}')) return Error("expected '}'");
    var.end_segment = segments.size();
    variables.push_back(std::move(var));
    return absl::OkStatus();
  }

  bool Peek(char c) const { return pos_ < text_.size() && text_[pos_] == c; }
  bool Consume(char c) {
    if (!Peek(c)) return false;
    ++pos_;
    return true;
  }
  absl::Status Error(std::string_view what) const {
    return absl::InvalidArgumentError(
        absl::StrCat("path template \"", Av(text_), "\": ", Av(what), " at offset ", pos_));
  }

  std::string_view text_;
  size_t pos_ = 0;
};

}  // namespace

bool IsPercentEncoded(std::string_view in) { return WellEncoded(in); }

std::string_view PathVerb(std::string_view path) {
  const std::optional<size_t> colon = VerbColon(path);
  return colon ? path.substr(*colon + 1) : std::string_view();
}

std::optional<std::string> PercentDecode(std::string_view in, bool keep_slash, bool plus_as_space) {
  std::string out;
  out.reserve(in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '+' && plus_as_space) {
      out += ' ';
    } else if (c != '%') {
      out += c;
    } else {
      if (i + 2 >= in.size()) return std::nullopt;
      const int hi = HexValue(in[i + 1]);
      const int lo = HexValue(in[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      const char decoded = static_cast<char>(hi * 16 + lo);
      if (keep_slash && decoded == '/') {
        out.append(in.substr(i, 3));
      } else {
        out += decoded;
      }
      i += 2;
    }
  }
  return out;
}

absl::StatusOr<PathTemplate> PathTemplate::Parse(std::string_view text) {
  PathTemplate t;
  t.text_.assign(text);
  Parser parser(text);
  if (auto s = parser.Run(t.segments_, t.variables_, t.verb_); !s.ok()) return s;
  return t;
}

int PathTemplate::Specificity() const {
  int score = verb_.empty() ? 0 : 1;
  for (const auto& s : segments_) score += s.kind == SegmentKind::kLiteral ? 2 : 0;
  return score;
}

// Accepts exactly the paths Match accepts (same steps, no allocation): routing ranks every
// route per request and binds only the winner's variables.
bool PathTemplate::Fits(std::string_view path) const {
  if (path.empty() || path.front() != '/' || segments_.empty()) return false;
  path.remove_prefix(1);
  if (!verb_.empty()) {
    const std::optional<size_t> colon = VerbColon(path);
    if (!colon || path.substr(*colon + 1) != verb_) return false;
    path = path.substr(0, *colon);
  }
  const size_t raw_count = static_cast<size_t>(std::count(path.begin(), path.end(), '/')) + 1;
  const bool multi_last = segments_.back().kind == SegmentKind::kMulti;
  if (multi_last ? raw_count < segments_.size() - 1 : raw_count != segments_.size()) return false;
  const size_t fixed = multi_last ? segments_.size() - 1 : segments_.size();
  // Match decodes (and so rejects bad escapes in) the raw segments a variable covers; a
  // trailing "**" covers every raw segment from its position on.
  auto in_variable = [&](size_t segment) {
    for (const Variable& var : variables_) {
      if (var.first_segment <= segment && segment < var.end_segment) return true;
    }
    return false;
  };
  size_t start = 0;
  for (size_t i = 0;; ++i) {
    const size_t slash = path.find('/', start);
    const std::string_view raw = path.substr(
        start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
    if (i < fixed) {
      if (raw.empty()) return false;
      if (segments_[i].kind == SegmentKind::kLiteral && !DecodedEquals(raw, segments_[i].literal)) {
        return false;
      }
    }
    if (in_variable(std::min(i, segments_.size() - 1)) && !WellEncoded(raw)) return false;
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  return true;
}

std::optional<std::vector<PathBinding>> PathTemplate::Match(std::string_view path) const {
  if (path.empty() || path.front() != '/') return std::nullopt;
  path.remove_prefix(1);
  // The verb is the suffix after the last ':' of the last segment (an encoded %3A is data).
  if (!verb_.empty()) {
    const std::optional<size_t> colon = VerbColon(path);
    if (!colon || path.substr(*colon + 1) != verb_) return std::nullopt;
    path = path.substr(0, *colon);
  }
  // Inline storage: the API's templates have at most a handful of segments (decision 1362).
  absl::InlinedVector<std::string_view, 8> raw;
  for (absl::string_view part : absl::StrSplit(Av(path), '/'))
    raw.emplace_back(part.data(), part.size());
  const bool multi_last = !segments_.empty() && segments_.back().kind == SegmentKind::kMulti;
  if (multi_last ? raw.size() < segments_.size() - 1 : raw.size() != segments_.size()) {
    return std::nullopt;
  }
  const size_t fixed = multi_last ? segments_.size() - 1 : segments_.size();
  for (size_t i = 0; i < fixed; ++i) {
    if (raw[i].empty()) return std::nullopt;  // "*" and literals need a non-empty segment
    if (segments_[i].kind == SegmentKind::kLiteral) {
      if (raw[i].find('%') == std::string_view::npos) {  // nothing to decode
        if (raw[i] != segments_[i].literal) return std::nullopt;
        continue;
      }
      auto decoded = PercentDecode(raw[i]);
      if (!decoded || *decoded != segments_[i].literal) return std::nullopt;
    }
  }
  std::vector<PathBinding> bindings;
  bindings.reserve(variables_.size());
  for (const Variable& var : variables_) {
    const bool multi = var.end_segment - var.first_segment > 1 ||
                       segments_[var.end_segment - 1].kind == SegmentKind::kMulti;
    const size_t end =
        var.end_segment == segments_.size() && multi_last ? raw.size() : var.end_segment;
    // The decoded segments joined by '/', appended in place (a segment without '%' as is).
    std::string value;
    for (size_t i = var.first_segment; i < end; ++i) {
      if (i > var.first_segment) value.push_back('/');
      if (raw[i].find('%') == std::string_view::npos) {
        value.append(raw[i]);
        continue;
      }
      auto decoded = PercentDecode(raw[i], /*keep_slash=*/multi);
      if (!decoded) return std::nullopt;
      value.append(*decoded);
    }
    bindings.push_back({var.field_path, std::move(value)});
  }
  return bindings;
}

}  // namespace drivegw::rest
