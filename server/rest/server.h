// REST server: HTTP/1.1 (or HTTPS) listener and sessions (Boost.Beast, kept inside server.cpp)
// in front of the router, which transcodes to the gRPC service over an in-process channel.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/rest/router.h"
#include "server/rest/static_assets.h"
#include "server/rest/tls_context.h"
#include "server/rest/ws_stats.h"

namespace grpc {
class Channel;
}

namespace drivegw::rest {

// Request bodies above this get 413 (RestOptions::body_limit's default). JSON is larger than the
// protobuf message it transcodes to, so every body accepted here passes the in-process gRPC hop
// (kGrpcMaxMessageBytes in server/gateway.h; decision 1492).
inline constexpr size_t kDefaultBodyLimit = 1 << 20;

struct RestOptions {
  std::string listen_address = "0.0.0.0";
  uint16_t port = 8080;                    // 0: ephemeral, read back with RestServer::port()
  std::shared_ptr<grpc::Channel> channel;  // the gRPC server's InProcessChannel (required)
  std::string openapi_json;                // served at GET /openapi.json
  std::vector<std::string> more_services;  // RouterOptions::more_services
  std::string static_dir;                  // served at GET / ... (empty: none)
  // The dashboard served at GET / and /assets/<file> when static_dir is empty (decision 505);
  // tests put a fixture set here.
  const WebAssetSet* web_assets = &EmbeddedWebAssets();
  size_t body_limit = kDefaultBodyLimit;  // larger request bodies get 413
  // Deadline for a whole request once the connection is idle, and for every write.
  std::chrono::seconds read_timeout{30};
  int threads = 2;
  // HTTPS (TLS 1.2+) when set, plain HTTP otherwise. A verified client certificate's subject
  // CN goes to the in-process call as HttpRequest::client_cn (decision 023).
  std::optional<RestTls> tls;
  // Deadline of the TLS handshake once the connection is accepted.
  std::chrono::seconds handshake_timeout{10};
  // Kernel send buffer of a WebSocket connection (SO_SNDBUF; 0: the system's autotuning, up to
  // MBs). With it, what a stalled browser costs is this plus one snapshot per drive (decision 504).
  int ws_send_buffer = 64 * 1024;
  // RouterOptions::fixed_routes (GET /metrics, /readyz; decision 021).
  FixedRoutes fixed_routes;
  // RouterOptions::direct_unary: read-only unary methods served without the gRPC hop
  // (decision 1331).
  std::map<std::string, DirectUnary> direct_unary;
};

class RestServer {
 public:
  // Binds, listens and starts the I/O threads. Errors: InvalidArgument (bad address, no
  // channel, bad HttpRule), Unavailable (bind/listen failed).
  static absl::StatusOr<std::unique_ptr<RestServer>> Start(RestOptions options);
  ~RestServer();  // Stop()s
  RestServer(const RestServer&) = delete;
  RestServer& operator=(const RestServer&) = delete;

  uint16_t port() const;
  // Counters of the WebSocket status stream (GET /v1/drives:ws; decision 504).
  const WsStats& ws_stats() const;
  // Stops accepting, cancels streams and calls in flight, closes connections and joins the
  // threads. Idempotent; not to be called from a handler thread. Call it before shutting
  // down the gRPC server behind `channel` (docs/decisions/501-rest-transcoding.md, item 9).
  void Stop();

  struct Impl;

 private:
  explicit RestServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace drivegw::rest
