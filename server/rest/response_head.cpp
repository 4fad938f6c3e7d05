// AppendResponseHead: Beast's header serialization (boost/beast/http/impl/fields.hpp, writer;
// message.hpp prepare_payload; Boost 1.74) for the responses the session sends whole.
#include "server/rest/response_head.h"

#include <boost/beast/http/status.hpp>
#include <cstdint>
#include <string_view>
#include <utility>

#include "absl/container/inlined_vector.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace drivegw::rest {
namespace {

// Beast's new_element stores a value without leading and trailing spaces and tabs
// (http/detail/rfc7230.ipp trim).
std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

bool FramingHeader(std::string_view name) {
  const absl::string_view n(name.data(), name.size());
  return absl::EqualsIgnoreCase(n, "connection") || absl::EqualsIgnoreCase(n, "content-length") ||
         absl::EqualsIgnoreCase(n, "transfer-encoding");
}

void AppendField(std::string& out, std::string_view name, std::string_view value) {
  out.append(name);
  out.append(": ");
  out.append(Trim(value));
  out.append("\r\n");
}

}  // namespace

bool AppendResponseHead(const HttpResponse& response, unsigned version, bool keep_alive,
                        std::string& out) {
  const int status = response.status;
  if (status < 200 || status > 999 || status == 204 || status == 304 || version > 99) return false;
  // The fields in Beast's order: basic_fields::set drops every earlier field of the same name
  // (case-insensitive) and appends, so a later set of a name moves it to the end.
  absl::InlinedVector<std::pair<std::string_view, std::string_view>, 8> fields;
  auto set = [&fields](std::string_view name, std::string_view value) {
    const absl::string_view n(name.data(), name.size());
    for (auto it = fields.begin(); it != fields.end();) {
      it = absl::EqualsIgnoreCase(absl::string_view(it->first.data(), it->first.size()), n)
               ? fields.erase(it)
               : it + 1;
    }
    fields.emplace_back(name, value);
  };
  set("Server", "drivegw");
  set("Content-Type", response.content_type);
  for (const auto& [name, value] : response.headers) {
    if (FramingHeader(name)) return false;
    set(name, value);
  }
  // Status line: "HTTP/1.1 200 OK"; the reason is obsolete_reason's (the session sets none).
  const auto reason =
      boost::beast::http::obsolete_reason(static_cast<boost::beast::http::status>(status));
  const char line[] = {'H',
                       'T',
                       'T',
                       'P',
                       '/',
                       static_cast<char>('0' + version / 10),
                       '.',
                       static_cast<char>('0' + version % 10),
                       ' ',
                       static_cast<char>('0' + status / 100),
                       static_cast<char>('0' + status / 10 % 10),
                       static_cast<char>('0' + status % 10),
                       ' '};
  out.append(line, sizeof(line));
  out.append(reason.data(), reason.size());
  out.append("\r\n");
  for (const auto& [name, value] : fields) AppendField(out, name, value);
  // keep_alive(): HTTP/1.1 is persistent unless "Connection: close"; HTTP/1.0 only with
  // "Connection: keep-alive" (fields.hpp keep_alive_impl on an absent Connection field).
  if (version >= 11 && !keep_alive) AppendField(out, "Connection", "close");
  if (version < 11 && keep_alive) AppendField(out, "Connection", "keep-alive");
  // prepare_payload(): a sized body gets Content-Length, set last.
  absl::StrAppend(&out, "Content-Length: ", response.body.size(), "\r\n\r\n");
  return true;
}

}  // namespace drivegw::rest
