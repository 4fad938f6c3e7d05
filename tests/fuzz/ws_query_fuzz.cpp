// Fuzz target for the WebSocket query parser (server/rest/ws_session.cpp WatchRequestFor): the
// input is the request target of GET /v1/drives:ws ("/v1/drives:ws?max_rate_hz=..&names=..&
// access_token=.."). Invariants: no crash; errors are InvalidArgument; what parses becomes a GET
// of /v1/drives:watch, and that request's own query, asked for again as a WebSocket target,
// gives the same request (the encoding is a fixed point: nothing is lost or double-decoded).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "server/rest/ws_session.h"

namespace {

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view target(reinterpret_cast<const char*>(data), size);
  auto request = drivegw::rest::WatchRequestFor(target);
  if (!request.ok()) {
    Check(request.status().code() == absl::StatusCode::kInvalidArgument);
    return 0;
  }
  Check(request->method == "GET");
  constexpr std::string_view kWatch = "/v1/drives:watch?";
  Check(std::string_view(request->target).substr(0, kWatch.size()) == kWatch);
  const std::string again_target =
      std::string(drivegw::rest::kWsPath) + "?" + request->target.substr(kWatch.size());
  auto again = drivegw::rest::WatchRequestFor(again_target);
  Check(again.ok());
  Check(again->target == request->target);
  // The token is not in the rebuilt query: only compare when there was none.
  if (request->authorization.empty()) Check(again->authorization.empty());
  return 0;
}
