// The live status WebSocket, GET /v1/drives:ws (issue 8, decision 504): the upgraded connection
// runs the router's in-process WatchDrives call and sends each drive's latest DriveStatus as a
// text frame, coalesced per drive so a slow browser never makes the gateway buffer unboundedly.
#pragma once

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>

#include "server/rest/router.h"
#include "server/rest/session_registry.h"
#include "server/rest/ws_stats.h"

namespace drivegw::rest {

inline constexpr std::string_view kWsPath = "/v1/drives:ws";
// Snapshots one session holds unsent at most: one per drive, so the bound is only reached by a
// gateway with more drives than this; newer drives' snapshots then wait for the next change.
inline constexpr size_t kWsMaxPendingDrives = 1024;

using WsRequest = boost::beast::http::request<boost::beast::http::string_body>;

struct WsContext {
  Router* router;
  SessionRegistry* sessions;
  WsStats* stats;
  std::chrono::seconds idle_timeout;  // no frame (data or pong) for this long closes
  int send_buffer;                    // SO_SNDBUF of the connection; 0: system default
  std::string peer;
  std::string client_cn;
};

// A GET of kWsPath asking for a WebSocket upgrade (RFC 6455 §4.1).
bool IsWsUpgrade(const WsRequest& request);

// Takes over the connection: completes the handshake and streams until either side closes.
void StartWsSession(boost::asio::ip::tcp::socket socket, WsRequest request, WsContext context);
void StartWsSession(boost::asio::ssl::stream<boost::asio::ip::tcp::socket> stream,
                    WsRequest request, WsContext context);

// The router request of a WebSocket target ("/v1/drives:ws?max_rate_hz=10&names=x1,x2&
// access_token=T"): GET /v1/drives:watch with names repeated, max_rate_hz (10 when absent) and
// the token as "Bearer T". Errors (bad percent-encoding) are InvalidArgument.
absl::StatusOr<HttpRequest> WatchRequestFor(std::string_view target);

}  // namespace drivegw::rest
