// google.api.http path templates: parse "/v1/{name=drives/*}:verb" and match request paths.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace drivegw::rest {

// One variable bound by a match: the request field path ("name", "axis.min_mm") and its
// percent-decoded value ("drives/x1").
struct PathBinding {
  std::string field_path;
  std::string value;
  bool operator==(const PathBinding&) const = default;
};

// A parsed HttpRule path template (proto/google/api/http.proto, "Path template syntax"):
//   Template = "/" Segments [ Verb ] ;   Segments = Segment { "/" Segment } ;
//   Segment  = "*" | "**" | LITERAL | Variable ;
//   Variable = "{" FieldPath [ "=" Segments ] "}" ;   Verb = ":" LITERAL ;
// "**" may only be the last segment. Values of single-segment variables are fully
// percent-decoded; multi-segment ones keep "%2F" as is (http.proto, reserved expansion).
class PathTemplate {
 public:
  enum class SegmentKind { kLiteral, kSingle /* * */, kMulti /* ** */ };
  struct Segment {
    SegmentKind kind = SegmentKind::kLiteral;
    std::string literal;
  };
  struct Variable {
    std::string field_path;
    size_t first_segment = 0;  // index into segments()
    size_t end_segment = 0;    // one past the last segment it covers
  };

  // Errors (InvalidArgument) name the template and the offset of the problem.
  static absl::StatusOr<PathTemplate> Parse(std::string_view text);

  // Matches a request path (no query string, still percent-encoded). Returns the bindings in
  // template order, or nullopt when the path does not fit.
  std::optional<std::vector<PathBinding>> Match(std::string_view path) const;

  // Match(path).has_value(), without allocating.
  bool Fits(std::string_view path) const;

  const std::string& text() const { return text_; }
  const std::vector<Segment>& segments() const { return segments_; }
  const std::vector<Variable>& variables() const { return variables_; }
  const std::string& verb() const { return verb_; }
  // Ranks overlapping templates: literal segments and the verb count, wildcards do not.
  int Specificity() const;

 private:
  std::string text_;
  std::vector<Segment> segments_;
  std::vector<Variable> variables_;
  std::string verb_;
};

// The verb a request path (no query string) carries for Fits and Match: what follows the last
// ':' of its last segment ("enable" in "/v1/drives/x1:enable"), empty when that segment has no
// ':'. A template with a verb fits only paths whose PathVerb equals it, so the router skips the
// other verbs' templates with one comparison (issue 10, P4; decision 1364).
std::string_view PathVerb(std::string_view path);

// True when every '%' in `in` starts a complete escape (PercentDecode(in) succeeds).
bool IsPercentEncoded(std::string_view in);

// Percent-decodes `in` ("%41" -> "A"). With keep_slash, "%2F"/"%2f" stay encoded. With
// plus_as_space ('+' -> ' '), for query strings. Returns nullopt on a malformed escape.
std::optional<std::string> PercentDecode(std::string_view in, bool keep_slash = false,
                                         bool plus_as_space = false);

}  // namespace drivegw::rest
