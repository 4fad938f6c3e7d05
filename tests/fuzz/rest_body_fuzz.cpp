// Fuzz target for the REST transcoder from HTTP request to request proto (server/rest/router.cpp
// Router::Handle / HandleApi): path variables, query parameters, If-Match and the JSON body
// (JsonStringToMessage, SplitJsonError, body-field wrapping). Every unary route is served by a
// direct handler (RouterOptions::direct_unary, decision 1331), so the router runs inline and no
// gRPC call is made; streaming routes are never targeted.
//
// Input: byte 0 chooses the request; the rest is "<query>\n<body>" (no '\n': all query).
//   bit 7 clear: the route (byte 0 & 0x3F, modulo the unary routes) rendered with "x1" for
//                every variable segment, that route's HTTP method;
//   bit 7 set:   the query part is the whole raw target (path and query), the method is
//                GET/POST/PATCH/DELETE by bits 0-1 (skipped when the path fits a streaming route);
//   bit 6:       an If-Match header.
// Invariants: no crash; never a 500 (the router's "our bug" answers); every response body is
// valid UTF-8 JSON; a direct handler only sees a message of its route's input type.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "drivegw/v1/audit.pb.h"
#include "drivegw/v1/auth.pb.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "drivegw/v1/drive.pb.h"
#include "drivegw/v1/leases.pb.h"
#include "drivegw/v1/ops.pb.h"
#include "drivegw/v1/parameter_sets.pb.h"
#include "server/rest/router.h"

namespace {

using drivegw::rest::HttpRequest;
using drivegw::rest::HttpResponse;
using drivegw::rest::PathTemplate;
using drivegw::rest::Route;
using drivegw::rest::Router;
using drivegw::rest::RouterOptions;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

void CheckOk(const absl::Status& s) {
  if (!s.ok()) {
    std::fprintf(stderr, "rest_body_fuzz: %s\n", s.ToString().c_str());
    __builtin_trap();
  }
}

void CheckResponse(const HttpResponse& r) {
  Check(r.status != 500);
  if (r.content_type == "application/json") Check(nlohmann::json::accept(r.body));
}

class Sink final : public drivegw::rest::ResponseSink {
 public:
  void OnResponse(HttpResponse response) noexcept override { CheckResponse(response); }
  // Only unary routes are targeted: a stream here is a routing bug.
  void OnStreamStarted(std::shared_ptr<drivegw::rest::StreamCall>) noexcept override {
    __builtin_trap();
  }
  void OnStreamMessage(std::string) noexcept override { __builtin_trap(); }
  void OnStreamEnd(HttpResponse) noexcept override { __builtin_trap(); }
};

RouterOptions BaseOptions() {
  // A static library's generated descriptors register only when their object is linked: one
  // message of each API file pulls its whole file (and service) into the generated pool.
  (void)drivegw::v1::AuditEvent::descriptor();
  (void)drivegw::v1::Token::descriptor();
  (void)drivegw::v1::PositionTimeCurve::descriptor();
  (void)drivegw::v1::Axis::descriptor();
  (void)drivegw::v1::Lease::descriptor();
  (void)drivegw::v1::SetWireTraceRequest::descriptor();
  (void)drivegw::v1::ParameterDefinition::descriptor();
  RouterOptions o;
  // Never connected: every route the fuzzer reaches is direct (see the file comment).
  o.channel = grpc::CreateChannel("unix:/nonexistent/drivegw-fuzz.sock",
                                  grpc::InsecureChannelCredentials());
  // The services the gateway serves over REST (server/gateway.cpp).
  o.more_services = {"drivegw.v1.ParameterSetService", "drivegw.v1.CurveSetService",
                     "drivegw.v1.TokenService",        "drivegw.v1.AuditService",
                     "drivegw.v1.LeaseService",        "drivegw.v1.OpsService"};
  return o;
}

std::string Render(const PathTemplate& t) {
  std::string out;
  for (const auto& s : t.segments()) {
    out += '/';
    switch (s.kind) {
      case PathTemplate::SegmentKind::kLiteral:
        out += s.literal;
        break;
      case PathTemplate::SegmentKind::kSingle:
        out += "x1";
        break;
      case PathTemplate::SegmentKind::kMulti:
        out += "x1/y2";
        break;
    }
  }
  if (!t.verb().empty()) out += ":" + t.verb();
  return out;
}

struct Fixture {
  std::unique_ptr<Router> router;
  std::vector<const Route*> unary;
  std::vector<const Route*> streaming;
};

Fixture MakeFixture() {
  Fixture fx;
  auto probe = Router::Create(BaseOptions());
  CheckOk(probe.status());
  RouterOptions o = BaseOptions();
  for (const Route& r : (*probe)->routes()) {
    if (r.server_streaming) continue;
    const google::protobuf::Descriptor* input = r.method->input_type();
    o.direct_unary[r.grpc_path] = [input](const HttpRequest&, const google::protobuf::Message& in,
                                          google::protobuf::Message*) {
      Check(in.GetDescriptor() == input);
      (void)in.ByteSizeLong();
      return grpc::Status::OK;
    };
  }
  auto router = Router::Create(std::move(o));
  CheckOk(router.status());
  fx.router = *std::move(router);
  for (const Route& r : fx.router->routes()) {
    (r.server_streaming ? fx.streaming : fx.unary).push_back(&r);
  }
  Check(!fx.unary.empty());
  return fx;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static Fixture fx = MakeFixture();
  const uint8_t mode = data[0];
  const std::string_view rest(reinterpret_cast<const char*>(data + 1), size - 1);
  const size_t nl = rest.find('\n');
  const std::string_view query = rest.substr(0, nl);
  const std::string_view body = nl == std::string_view::npos ? "" : rest.substr(nl + 1);

  HttpRequest request;
  request.peer = "127.0.0.1:1";
  request.body = std::string(body);
  if (mode & 0x40) request.if_match = "\"e1\"";
  if (mode & 0x80) {
    static constexpr const char* kMethods[] = {"GET", "POST", "PATCH", "DELETE"};
    request.method = kMethods[mode & 3];
    request.target = std::string(query);
    const std::string_view path = query.substr(0, query.find('?'));
    for (const Route* r : fx.streaming) {
      if (r->path.Fits(path)) return 0;
    }
  } else {
    const Route& route = *fx.unary[(mode & 0x3F) % fx.unary.size()];
    request.method = route.http_method;
    request.target = Render(route.path);
    if (!query.empty()) request.target += "?" + std::string(query);
  }
  fx.router->Handle(std::move(request), std::make_shared<Sink>());
  return 0;
}
