// One-shot HTTP requests for the end-to-end tests, on the REST tests' raw-socket client
// (tests/server/rest/http_client.h; no Beast translation unit in the tests).
#pragma once

#include <string>

#include "tests/server/rest/http_client.h"

namespace drivegw::testing {

struct HttpResponse {
  int status = 0;  // 0: no connection or no complete response
  std::string body;
};

inline HttpResponse HttpRequest(int port, const std::string& method, const std::string& target,
                                const std::string& body = "") {
  rest::test_support::HttpClient client(static_cast<uint16_t>(port));
  if (!client.connected() || !client.SendRequest(method, target, body)) return {};
  auto r = client.Read();
  if (!r) return {};
  return {r->status, r->body};
}

}  // namespace drivegw::testing
