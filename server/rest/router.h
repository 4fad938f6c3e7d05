// Socketless REST router: HTTP request in, google.api.http transcoding to an in-process gRPC
// call, JSON response (or an NDJSON stream) out. No Beast here; unit tests call it directly.
#pragma once

#include <grpcpp/support/status.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "server/rest/path_template.h"

namespace google::protobuf {
class Arena;
class FieldDescriptor;
class Message;
class MethodDescriptor;
}  // namespace google::protobuf
namespace grpc {
class Channel;
}

namespace drivegw::rest {

class JsonCache;
struct WebAssetSet;

struct HttpRequest {
  std::string method;  // "GET", "POST", ... as sent
  std::string target;  // origin-form: "/v1/drives:watch?names=x1&max_rate_hz=10"
  std::string body;
  std::string peer;  // client "ip:port", forwarded as x-drivegw-source
  // If-Match header ("" if none): fills a request's top-level `etag` field when the body and
  // query left it empty (conditional updates, decision 011).
  std::string if_match;
  // Authorization and Idempotency-Key headers ("" if none), forwarded to the in-process gRPC call
  // as the metadata `authorization` and `idempotency-key` (issue 7: one enforcement point).
  std::string authorization;
  std::string idempotency_key;
  // Subject CN of the HTTPS client's verified certificate ("" if none), forwarded as the
  // binary metadata x-drivegw-client-cn-bin (a CN may be any UTF-8; trusted only on in-process
  // calls, decision 023).
  std::string client_cn;
  // X-Drivegw-Lease header ("" if none): the control lease id the caller presents, forwarded as
  // the metadata x-drivegw-lease (decision 019).
  std::string lease_id;
};

struct HttpResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra ones, e.g. Allow
};

// A JSON google.rpc.Status response ({code, message, details}) with `http_status`.
// `grpc_code` is the google.rpc.Code; `field`, when set, adds a google.rpc.BadRequest detail.
HttpResponse ErrorResponse(int http_status, int grpc_code, std::string message,
                           std::string field = {}, std::string field_description = {});
// `text` with every byte that does not start a well-formed UTF-8 sequence written as "\xNN":
// error messages quote client input and must stay UTF-8 for protobuf and JSON.
std::string ValidUtf8(std::string_view text);
// HTTP status for a google.rpc.Code (INVALID_ARGUMENT 400, NOT_FOUND 404, ..., else 500).
int HttpStatusForGrpcCode(int grpc_code);

// A server-streaming call in progress; the sink's owner drives it. Not thread-safe: call
// RequestNext and Cancel from one thread (or strand) at a time.
class StreamCall {
 public:
  virtual ~StreamCall() = default;
  // Asks for one more message: the sink then gets exactly one OnStreamMessage, or the call
  // ends (OnStreamEnd). Flow control: nothing is read from gRPC without it.
  virtual void RequestNext() noexcept = 0;
  // Cancels the gRPC call (client gone); OnStreamEnd follows. Idempotent.
  virtual void Cancel() noexcept = 0;
};

// Receives the answer to one request. The HTTP session implements it (tests record it).
// Calls may come inline from Router::Handle or on gRPC threads: implementations hand them
// to their own executor and return.
class ResponseSink {
 public:
  virtual ~ResponseSink() = default;
  // A whole response: unary calls, fixed routes, and every error found before a stream
  // started. Called once; it ends the exchange.
  virtual void OnResponse(HttpResponse response) noexcept = 0;
  // A server-streaming route was started (inline from Handle, before any other call). Call
  // stream->RequestNext() for the first message.
  virtual void OnStreamStarted(std::shared_ptr<StreamCall> stream) noexcept = 0;
  // One message as one line of JSON ending in '\n' (NDJSON).
  virtual void OnStreamMessage(std::string line) noexcept = 0;
  // The last call of a stream: `end.status` 200 when the gRPC call ended OK; otherwise the
  // mapped error (status and google.rpc.Status JSON body). Sent as a whole response if no
  // message was written yet, else as a last line {"error": <body>}.
  virtual void OnStreamEnd(HttpResponse end) noexcept = 0;
};

// A read-only unary method the router calls in process, inline on the calling (Beast) thread,
// instead of the in-process gRPC call (decision 1331). It receives the request message the
// router built and the HTTP request (for the caller's identity: peer, Authorization, client
// certificate CN), must enforce everything the gRPC method and its interceptors do
// (authentication, the method's role, RPC metrics), must not block, and returns the
// grpc::Status the gRPC call would have ended with (error_details included), `out` filled when
// OK. The router then maps both paths through the same code.
using DirectUnary =
    std::function<grpc::Status(const HttpRequest& request, const google::protobuf::Message& in,
                               google::protobuf::Message* out)>;

// Fixed GET routes by path; `std::less<>` so a request path is looked up without a copy.
using FixedRoutes = std::map<std::string, std::function<HttpResponse()>, std::less<>>;

struct RouterOptions {
  std::shared_ptr<grpc::Channel> channel;  // the gRPC server's InProcessChannel
  std::string service = "drivegw.v1.DriveService";
  // Further services served from the same channel (the gateway adds ParameterSetService,
  // decision 011).
  std::vector<std::string> more_services;
  std::string openapi_json;  // served at GET /openapi.json
  std::string static_dir;    // served at GET /... when set
  // The embedded dashboard (GET /, /assets/<file>; decision 505) when static_dir is empty;
  // null: none.
  const WebAssetSet* web_assets = nullptr;
  std::chrono::milliseconds call_timeout{30000};  // deadline of unary calls
  std::chrono::milliseconds health_timeout{1000};
  // Fixed GET routes answered inline without gRPC (issue 7: /metrics, /readyz; decision 021);
  // other methods on them get 405. Handlers must be quick and thread-safe.
  FixedRoutes fixed_routes;
  // Direct handlers by gRPC path ("/drivegw.v1.DriveService/GetDrive"); each must name a unary
  // route's method (Create fails otherwise). Empty: every call goes through gRPC.
  std::map<std::string, DirectUnary> direct_unary;
};

// One HTTP route derived from a google.api.http rule (binding).
struct Route {
  std::string http_method;  // "GET", "POST", "PUT", "DELETE", "PATCH" or a custom kind
  PathTemplate path;
  int specificity = 0;  // path.Specificity(), ranks overlapping templates
  // Segment counts ("/"s) of the request paths the template can match: a cheap filter before
  // PathTemplate::Fits.
  size_t min_segments = 0;
  size_t max_segments = 0;
  std::string body;           // "" (none), "*" or a request field name
  std::string response_body;  // "" or a response field name
  const google::protobuf::MethodDescriptor* method = nullptr;
  std::string grpc_path;  // "/drivegw.v1.DriveService/MoveAbsolute"
  bool server_streaming = false;
  DirectUnary direct;  // set: served by RouterOptions::direct_unary, not over gRPC
  // The input type's generated prototype, looked up once (decision 1364).
  const google::protobuf::Message* request_prototype = nullptr;
  // Direct routes: the output type's generated prototype, looked up once (decision 1363).
  const google::protobuf::Message* response_prototype = nullptr;
  // Per path variable, in path.variables() order (the order Match binds them): its request
  // field path resolved once in Create, and that path's proto field names joined by "."
  // (decision 1362: no descriptor lookup per request).
  std::vector<std::vector<const google::protobuf::FieldDescriptor*>> variable_fields;
  std::vector<std::string> variable_names;
  // Direct routes: their responses' printed JSON by message content (decision 1361).
  std::shared_ptr<JsonCache> json_cache;
};

class Router {
 public:
  // Reads every method's google.api.http rule (with additional_bindings) of options.service
  // from the generated descriptor pool. Errors name the method and the bad rule.
  static absl::StatusOr<std::unique_ptr<Router>> Create(RouterOptions options);
  ~Router();
  Router(const Router&) = delete;
  Router& operator=(const Router&) = delete;

  // Answers `request` through `sink` (see ResponseSink). Never throws, never blocks on gRPC.
  void Handle(HttpRequest request, std::shared_ptr<ResponseSink> sink) noexcept;

  // Cancels every gRPC call in flight and answers new requests 503; for shutdown.
  void CancelAll() noexcept;
  // Waits until no gRPC call started here is still running (their sinks have been called
  // for the last time). False on timeout.
  bool WaitIdle(std::chrono::milliseconds timeout) noexcept;

  const std::vector<Route>& routes() const { return routes_; }

  struct Inflight;  // calls in flight, shared with their completion callbacks

 private:
  Router(RouterOptions options, std::vector<Route> routes);
  void HandleApi(const Route& route, std::vector<PathBinding> bindings, std::string_view query,
                 HttpRequest& request, const std::shared_ptr<ResponseSink>& sink) noexcept;
  void HandleDirect(const Route& route, const google::protobuf::Message& in,
                    google::protobuf::Arena& arena, const HttpRequest& request,
                    const std::shared_ptr<ResponseSink>& sink);
  void HandleHealth(const std::shared_ptr<ResponseSink>& sink) noexcept;
  HttpResponse ServeStatic(std::string_view path) const;

  RouterOptions options_;
  std::vector<Route> routes_;
  // routes_ by descending specificity, ties in routes_ order: matching stops below the first fit.
  std::vector<const Route*> by_specificity_;
  std::shared_ptr<Inflight> inflight_;
};

}  // namespace drivegw::rest
