// Minimal blocking HTTP/1.1 client over a POSIX socket for end-to-end tests (no Beast: one
// Beast translation unit costs ~1 GB and 18 s to compile).
#pragma once

#include <string>

namespace drivegw::testing {

struct HttpResponse {
  int status = 0;
  std::string headers;
  std::string body;  // de-chunked
};

// Sends one request with "Connection: close" and reads the whole response. status 0 on a
// connection failure.
HttpResponse HttpRequest(int port, const std::string& method, const std::string& target,
                         const std::string& body = "");

}  // namespace drivegw::testing
