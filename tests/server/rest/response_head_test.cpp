// AppendResponseHead (decision 1365) against Beast's serializer: for every response form the
// session sends whole, the head it writes plus the body must be the bytes Beast wrote for the
// response<string_body> the session built before.
#include "server/rest/response_head.h"

#include <gtest/gtest.h>

#include <boost/beast/http.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace drivegw::rest {
namespace {

namespace http = boost::beast::http;

// What Session::WriteWhole built and sent before decision 1365.
std::string BeastBytes(const HttpResponse& r, unsigned version, bool keep_alive) {
  http::response<http::string_body> res(static_cast<http::status>(r.status), version);
  res.set(http::field::server, "drivegw");
  res.set(http::field::content_type, r.content_type);
  for (const auto& [name, value] : r.headers) res.set(name, value);
  res.keep_alive(keep_alive);
  res.body() = r.body;
  res.prepare_payload();
  std::ostringstream os;
  os << res;
  return os.str();
}

using Headers = std::vector<std::pair<std::string, std::string>>;

TEST(AppendResponseHead, EveryFormTheSessionSends_BeastsBytes) {
  const int statuses[] = {200, 201, 400, 401, 403, 404, 405, 409,
                          412, 413, 429, 431, 500, 503, 599};
  const std::pair<std::string, std::string> types_bodies[] = {
      {"application/json", R"({"name":"drives/x1","state":"ENABLED"})"},
      {"text/plain; charset=utf-8", "ok\n"},
      {"application/json", ""},
      {"text/html", std::string(5000, 'x')}};
  const Headers header_sets[] = {
      {},
      {{"Allow", "GET, POST"}},
      {{"WWW-Authenticate", "Bearer realm=\"drivegw\""}},
      {{"Cache-Control", "no-cache"}, {"X-Content-Type-Options", "nosniff"}},
      {{"Content-Type", "text/css"}},       // replaces the earlier one, moves to the end
      {{"server", "other"}, {"X-A", "1"}},  // same name in another case replaces too
      {{"X-A", "1"}, {"X-B", "2"}, {"x-a", "3"}},
      {{"X-Padded", " \tvalue with spaces\t "}},
      {{"X-Empty", ""}},
      {{"Retry-After", "1"}, {"ETag", "\"v7\""}}};
  int checked = 0;
  for (int status : statuses) {
    for (const auto& [type, body] : types_bodies) {
      for (const Headers& headers : header_sets) {
        for (unsigned version : {10u, 11u}) {
          for (bool keep_alive : {true, false}) {
            HttpResponse r;
            r.status = status;
            r.content_type = type;
            r.body = body;
            r.headers = headers;
            std::string out = "kept|";
            ASSERT_TRUE(AppendResponseHead(r, version, keep_alive, out));
            ASSERT_EQ(out.substr(0, 5), "kept|");  // appends
            EXPECT_EQ(out.substr(5) + body, BeastBytes(r, version, keep_alive))
                << status << " " << type << " v" << version << " keep_alive " << keep_alive
                << " headers " << headers.size();
            ++checked;
          }
        }
      }
    }
  }
  EXPECT_EQ(checked, 15 * 4 * 10 * 2 * 2);
}

TEST(AppendResponseHead, BodilessStatusesAndFramingHeaders_LeftToBeast) {
  auto refused = [](int status, Headers headers) {
    HttpResponse r;
    r.status = status;
    r.headers = std::move(headers);
    std::string out = "kept";
    if (AppendResponseHead(r, 11, true, out)) return false;
    EXPECT_EQ(out, "kept");  // untouched
    return true;
  };
  EXPECT_TRUE(refused(101, {}));
  EXPECT_TRUE(refused(204, {}));
  EXPECT_TRUE(refused(304, {}));
  EXPECT_TRUE(refused(99, {}));
  EXPECT_TRUE(refused(1000, {}));
  EXPECT_TRUE(refused(200, {{"Connection", "upgrade"}}));
  EXPECT_TRUE(refused(200, {{"content-length", "3"}}));
  EXPECT_TRUE(refused(200, {{"Transfer-Encoding", "chunked"}}));
  EXPECT_FALSE(refused(200, {{"X-Connection", "close"}}));
}

}  // namespace
}  // namespace drivegw::rest
