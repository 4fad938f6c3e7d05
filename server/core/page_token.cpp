// SetPageToken: checks a ListParameterSets / ListCurveSets page token (decision 1494).
#include "server/core/page_token.h"

#include "absl/strings/str_cat.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

bool IsSetNameChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

}  // namespace

absl::StatusOr<std::optional<std::string>> SetPageToken(const std::string& token) {
  if (token.empty()) return std::nullopt;
  const std::string rule = absl::StrCat("a token is the last set name of a page: 1..",
                                        kMaxSetPageTokenBytes, " characters of [A-Za-z0-9._-]");
  if (token.size() > kMaxSetPageTokenBytes) {
    // Not echoed: a token this long was never handed out and would only bloat the error.
    return FieldError("page_token", absl::StrCat(token.size(), " bytes exceed ",
                                                 kMaxSetPageTokenBytes, " (", rule, ")"));
  }
  for (size_t i = 0; i < token.size(); ++i) {
    if (!IsSetNameChar(token[i])) {
      return FieldError("page_token",
                        absl::StrCat("'", token, "' is not a token this service handed out ",
                                     "(character at index ", i, "; ", rule, ")"));
    }
  }
  return token;
}

}  // namespace drivegw::server
