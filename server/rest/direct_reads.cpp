// DriveService's read-only unary methods for the REST router without the gRPC hop (decision
// 1331): the caller's credentials as the in-process call would carry them, CallAuth, the core,
// ToGrpcStatus and the RPC metrics series, in the order the gRPC path runs them.
#include "server/rest/direct_reads.h"

#include <chrono>
#include <memory>
#include <string_view>
#include <utility>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/status_mapping.h"
#include "server/ops/rpc_metrics.h"

namespace drivegw::rest {
namespace {

namespace pb = google::protobuf;
using server::CallContext;

// What CallAuth::Credentials reads from the router's in-process call (router.cpp MakeContext:
// x-drivegw-source, x-drivegw-transport, authorization, idempotency-key, x-drivegw-lease,
// x-drivegw-client-cn-bin; call_auth.cpp ContextFrom and peer_identity.cpp ClientCommonName
// trust them because the call is in process, and so is this one).
server::CallCredentials Credentials(const HttpRequest& request, const std::string& method) {
  server::CallCredentials c;
  c.method = method;
  c.base.transport = "rest";
  c.base.source_address = request.peer.empty() ? "unknown" : request.peer;
  c.base.idempotency_key = request.idempotency_key;
  c.base.lease_id = request.lease_id;
  c.authorization = request.authorization;
  if (!request.client_cn.empty()) c.certificate_cn = request.client_cn;
  return c;
}

// One method: Inline()'s steps (call_auth.h) and the RPC metrics interceptor's record
// (rpc_metrics.cpp) around `call(request, context)`.
template <typename Req, typename Resp, typename Call>
std::pair<std::string, DirectUnary> Direct(std::string_view method, const server::CallAuth& auth,
                                           const ops::RpcMetrics& metrics, Call call) {
  const std::string_view service = v1::DriveService::service_full_name();
  std::string full = server::FullMethod(service, method);
  auto series = std::make_shared<const ops::RpcMetrics::Method>(metrics, service, method, "rest");
  DirectUnary handler = [full, series, &auth, &metrics, call = std::move(call)](
                            const HttpRequest& http, const pb::Message& in,
                            pb::Message* out) -> grpc::Status {
    const auto start = std::chrono::steady_clock::now();
    // The router builds both from this method's descriptors with the generated factory.
    const auto* req = dynamic_cast<const Req*>(&in);
    auto* resp = dynamic_cast<Resp*>(out);
    if (req == nullptr || resp == nullptr) {
      return grpc::Status(grpc::StatusCode::INTERNAL, full + ": unexpected message types");
    }
    // The interceptor's per-drive series: a top-level `name` naming a configured drive.
    const std::pair<const std::string, std::string>* drive = nullptr;
    if constexpr (requires { req->name(); }) drive = metrics.FindDrive(req->name());
    absl::StatusOr<CallContext> cc = auth.Check(Credentials(http, full));
    absl::Status status = cc.status();
    if (cc.ok()) {
      // Written into the router's message (on its arena, decision 1363), no copy of a result.
      status = call(*req, *cc, resp);
      if (!status.ok()) resp->Clear();  // an error answers no message, like the gRPC path
    }
    grpc::Status finished = server::ToGrpcStatus(status);
    series->Record(drive, finished.error_code(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    return finished;
  };
  return {std::move(full), std::move(handler)};
}

}  // namespace

std::map<std::string, DirectUnary> DriveServiceDirectReads(server::DriveServiceCore& core,
                                                           const server::CallAuth& auth,
                                                           const ops::RpcMetrics& metrics) {
  std::map<std::string, DirectUnary> out;
  out.insert(Direct<v1::ListDrivesRequest, v1::ListDrivesResponse>(
      "ListDrives", auth, metrics,
      [&core](const v1::ListDrivesRequest& r, const CallContext& c, v1::ListDrivesResponse* resp) {
        return core.ListDrives(r, c, resp);
      }));
  out.insert(Direct<v1::GetDriveRequest, v1::Drive>(
      "GetDrive", auth, metrics,
      [&core](const v1::GetDriveRequest& r, const CallContext& c, v1::Drive* resp) {
        return core.GetDrive(r, c, resp);
      }));
  out.insert(Direct<v1::GetCommandRequest, v1::CommandHandle>(
      "GetCommand", auth, metrics,
      [&core](const v1::GetCommandRequest& r, const CallContext& c, v1::CommandHandle* resp) {
        absl::StatusOr<v1::CommandHandle> handle = core.GetCommand(r, c);
        if (handle.ok()) resp->CopyFrom(*handle);  // small; the arena cannot take a heap message
        return handle.status();
      }));
  return out;
}

}  // namespace drivegw::rest
