// The RPC metrics interceptor (rpc_metrics.h).
#include "server/ops/rpc_metrics.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <grpcpp/server_context.h>

#include <chrono>

#include "absl/strings/match.h"

namespace drivegw::ops {
namespace {

namespace gx = grpc::experimental;

struct Shared {
  Registry& registry;
  std::map<std::string, std::string> drive_families;
};

const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    default:
      break;
  }
  return "UNKNOWN";
}

class RpcMetricsInterceptor final : public gx::Interceptor {
 public:
  RpcMetricsInterceptor(gx::ServerRpcInfo* info, const Shared& shared)
      : info_(info), shared_(shared), start_(std::chrono::steady_clock::now()) {
    const std::string_view full = info->method() == nullptr ? "" : info->method();
    const size_t slash = full.rfind('/');
    if (slash != std::string_view::npos && slash > 0) {
      service_ = std::string(full.substr(1, slash - 1));
      method_ = std::string(full.substr(slash + 1));
    } else {
      method_ = std::string(full);
    }
    raw_ = full == "/drivegw.v1.DriveService/WatchDrives";
  }

  void Intercept(gx::InterceptorBatchMethods* m) override {
    if (m->QueryInterceptionHookPoint(gx::InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      ReadTransport(m);
    }
    // Only drivegw's own services are known to carry generated protobuf messages; others (the
    // health service) and drivegw's raw methods receive ByteBuffers. WatchDrives is raw
    // (decision 1341) and its request has no `name` anyway (`names`).
    if (m->QueryInterceptionHookPoint(gx::InterceptionHookPoints::POST_RECV_MESSAGE) &&
        drive_.empty() && absl::StartsWith(service_, "drivegw.") && !raw_) {
      ReadDrive(static_cast<const google::protobuf::Message*>(m->GetRecvMessage()));
    }
    if (m->QueryInterceptionHookPoint(gx::InterceptionHookPoints::PRE_SEND_STATUS)) {
      Record(m->GetSendStatus().error_code());
    }
    m->Proceed();
  }

 private:
  // x-drivegw-transport is trusted on in-process calls only, as ContextFrom does.
  void ReadTransport(gx::InterceptorBatchMethods* m) {
    grpc::ServerContextBase* ctx = info_->server_context();
    const std::string peer = ctx == nullptr ? "" : ctx->peer();
    if (absl::StartsWith(peer, "ipv4:") || absl::StartsWith(peer, "ipv6:") ||
        absl::StartsWith(peer, "unix:")) {
      return;
    }
    auto* md = m->GetRecvInitialMetadata();
    if (md == nullptr) return;
    auto it = md->find("x-drivegw-transport");
    if (it != md->end()) transport_ = std::string(it->second.data(), it->second.size());
  }

  // A top-level string field `name` ("drives/x1" or "x1") naming a configured drive.
  void ReadDrive(const google::protobuf::Message* msg) {
    if (msg == nullptr) return;
    const auto* field = msg->GetDescriptor()->FindFieldByName("name");
    if (field == nullptr || field->is_repeated() ||
        field->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_STRING) {
      return;
    }
    std::string name = msg->GetReflection()->GetString(*msg, field);
    if (absl::StartsWith(name, "drives/")) name = name.substr(7);
    auto it = shared_.drive_families.find(name);
    if (it == shared_.drive_families.end()) return;
    drive_ = name;
    family_ = it->second;
  }

  void Record(grpc::StatusCode code) {
    if (recorded_) return;
    recorded_ = true;
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    Registry& r = shared_.registry;
    const char* code_name = CodeName(code);
    r.GetCounter("drivegw_rpc_requests_total", "RPCs finished, by status code.",
                 {{"service", service_},
                  {"method", method_},
                  {"transport", transport_},
                  {"code", code_name}})
        .Inc();
    r.GetHistogram("drivegw_rpc_duration_seconds",
                   "RPC latency from the call's start to its status.", LatencyBuckets(),
                   {{"service", service_}, {"method", method_}, {"transport", transport_}})
        .Observe(seconds);
    if (drive_.empty()) return;
    r.GetCounter("drivegw_drive_requests_total", "API calls on one drive, by method.",
                 {{"drive", drive_}, {"family", family_}, {"method", method_}})
        .Inc();
    if (code != grpc::StatusCode::OK) {
      r.GetCounter(
           "drivegw_drive_request_errors_total",
           "API calls on one drive that did not end OK, by method and code.",
           {{"drive", drive_}, {"family", family_}, {"method", method_}, {"code", code_name}})
          .Inc();
    }
  }

  gx::ServerRpcInfo* info_;
  const Shared& shared_;
  const std::chrono::steady_clock::time_point start_;
  std::string service_;
  std::string method_;
  bool raw_ = false;  // a ByteBuffer method: its messages are no protobuf Message
  std::string transport_ = "grpc";
  std::string drive_;
  std::string family_;
  bool recorded_ = false;
};

class Factory final : public gx::ServerInterceptorFactoryInterface {
 public:
  Factory(Registry& registry, std::map<std::string, std::string> families)
      : shared_{registry, std::move(families)} {}
  gx::Interceptor* CreateServerInterceptor(gx::ServerRpcInfo* info) override {
    return new RpcMetricsInterceptor(info, shared_);  // gRPC owns and deletes interceptors
  }

 private:
  Shared shared_;
};

}  // namespace

std::unique_ptr<gx::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    Registry& registry, std::map<std::string, std::string> drive_families) {
  return std::make_unique<Factory>(registry, std::move(drive_families));
}

}  // namespace drivegw::ops
