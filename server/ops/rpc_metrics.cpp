// The RPC metrics interceptor (rpc_metrics.h).
#include "server/ops/rpc_metrics.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <grpcpp/server_context.h>

#include <chrono>
#include <utility>

#include "absl/strings/match.h"

namespace drivegw::ops {
namespace {

namespace gx = grpc::experimental;

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

constexpr char kRequestsName[] = "drivegw_rpc_requests_total";
constexpr char kRequestsHelp[] = "RPCs finished, by status code.";
constexpr char kDurationName[] = "drivegw_rpc_duration_seconds";
constexpr char kDurationHelp[] = "RPC latency from the call's start to its status.";
constexpr char kDriveRequestsName[] = "drivegw_drive_requests_total";
constexpr char kDriveRequestsHelp[] = "API calls on one drive, by method.";

Labels CallLabels(std::string_view service, std::string_view method, std::string_view transport) {
  return {{"service", std::string(service)},
          {"method", std::string(method)},
          {"transport", std::string(transport)}};
}

class RpcMetricsInterceptor final : public gx::Interceptor {
 public:
  RpcMetricsInterceptor(gx::ServerRpcInfo* info, const RpcMetrics& metrics)
      : info_(info), metrics_(metrics), start_(std::chrono::steady_clock::now()) {
    const std::string_view full = info->method() == nullptr ? "" : info->method();
    const size_t slash = full.rfind('/');
    if (slash != std::string_view::npos && slash > 0) {
      service_ = std::string(full.substr(1, slash - 1));
      method_ = std::string(full.substr(slash + 1));
    } else {
      method_ = std::string(full);
    }
    raw_ = metrics.IsRawMethod(full);
  }

  void Intercept(gx::InterceptorBatchMethods* m) override {
    if (m->QueryInterceptionHookPoint(gx::InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      ReadTransport(m);
    }
    // Only drivegw's own services are known to carry generated protobuf messages; others (the
    // health service) and drivegw's raw methods (RpcMetrics::IsRawMethod; WatchDrives, decision
    // 1341) receive ByteBuffers.
    if (m->QueryInterceptionHookPoint(gx::InterceptionHookPoints::POST_RECV_MESSAGE) &&
        drive_ == nullptr && absl::StartsWith(service_, "drivegw.") && !raw_) {
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
    drive_ = metrics_.FindDrive(msg->GetReflection()->GetString(*msg, field));
  }

  void Record(grpc::StatusCode code) {
    if (recorded_) return;
    recorded_ = true;
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    metrics_.Record(service_, method_, transport_, drive_, code, seconds);
  }

  gx::ServerRpcInfo* info_;
  const RpcMetrics& metrics_;
  const std::chrono::steady_clock::time_point start_;
  std::string service_;
  std::string method_;
  bool raw_ = false;  // a ByteBuffer method: its messages are no protobuf Message
  std::string transport_ = "grpc";
  const std::pair<const std::string, std::string>* drive_ = nullptr;
  bool recorded_ = false;
};

class Factory final : public gx::ServerInterceptorFactoryInterface {
 public:
  explicit Factory(const RpcMetrics& metrics) : metrics_(metrics) {}
  Factory(Registry& registry, std::map<std::string, std::string> families)
      : owned_(std::make_unique<RpcMetrics>(registry, std::move(families))), metrics_(*owned_) {}
  gx::Interceptor* CreateServerInterceptor(gx::ServerRpcInfo* info) override {
    return new RpcMetricsInterceptor(info, metrics_);  // gRPC owns and deletes interceptors
  }

 private:
  std::unique_ptr<RpcMetrics> owned_;
  const RpcMetrics& metrics_;
};

}  // namespace

RpcMetrics::RpcMetrics(Registry& registry, std::map<std::string, std::string> drive_families,
                       std::set<std::string, std::less<>> raw_methods)
    : registry_(registry),
      drive_families_(drive_families.begin(), drive_families.end()),
      raw_methods_(std::move(raw_methods)) {}

const std::pair<const std::string, std::string>* RpcMetrics::FindDrive(
    std::string_view name_field) const {
  if (absl::StartsWith(absl::string_view(name_field.data(), name_field.size()), "drives/")) {
    name_field.remove_prefix(7);
  }
  auto it = drive_families_.find(name_field);
  return it == drive_families_.end() ? nullptr : &*it;
}

void RpcMetrics::Record(std::string_view service, std::string_view method,
                        std::string_view transport,
                        const std::pair<const std::string, std::string>* drive,
                        grpc::StatusCode code, double seconds) const {
  const char* code_name = CodeName(code);
  Labels labels = CallLabels(service, method, transport);
  registry_.GetHistogram(kDurationName, kDurationHelp, LatencyBuckets(), labels).Observe(seconds);
  labels.emplace("code", code_name);
  registry_.GetCounter(kRequestsName, kRequestsHelp, labels).Inc();
  if (drive == nullptr) return;
  registry_
      .GetCounter(
          kDriveRequestsName, kDriveRequestsHelp,
          {{"drive", drive->first}, {"family", drive->second}, {"method", std::string(method)}})
      .Inc();
  if (code != grpc::StatusCode::OK) {
    registry_
        .GetCounter("drivegw_drive_request_errors_total",
                    "API calls on one drive that did not end OK, by method and code.",
                    {{"drive", drive->first},
                     {"family", drive->second},
                     {"method", std::string(method)},
                     {"code", code_name}})
        .Inc();
  }
}

RpcMetrics::Method::Method(const RpcMetrics& metrics, std::string_view service,
                           std::string_view method, std::string_view transport)
    : metrics_(metrics), service_(service), method_(method), transport_(transport) {
  for (const auto& [drive, family] : metrics.drive_families_) drive_requests_[drive];
}

void RpcMetrics::Method::Record(const std::pair<const std::string, std::string>* drive,
                                grpc::StatusCode code, double seconds) const {
  if (code != grpc::StatusCode::OK) {
    metrics_.Record(service_, method_, transport_, drive, code, seconds);
    return;
  }
  // A race between two first uses resolves the same series twice: harmless.
  Histogram* duration = duration_.load(std::memory_order_acquire);
  Counter* ok = ok_.load(std::memory_order_acquire);
  if (duration == nullptr || ok == nullptr) {
    Labels labels = CallLabels(service_, method_, transport_);
    duration =
        &metrics_.registry_.GetHistogram(kDurationName, kDurationHelp, LatencyBuckets(), labels);
    labels.emplace("code", CodeName(grpc::StatusCode::OK));
    ok = &metrics_.registry_.GetCounter(kRequestsName, kRequestsHelp, labels);
    duration_.store(duration, std::memory_order_release);
    ok_.store(ok, std::memory_order_release);
  }
  duration->Observe(seconds);
  ok->Inc();
  if (drive == nullptr) return;
  auto it = drive_requests_.find(drive->first);
  if (it == drive_requests_.end()) return;  // FindDrive's entries are all here
  Counter* requests = it->second.load(std::memory_order_acquire);
  if (requests == nullptr) {
    requests = &metrics_.registry_.GetCounter(
        kDriveRequestsName, kDriveRequestsHelp,
        {{"drive", drive->first}, {"family", drive->second}, {"method", method_}});
    it->second.store(requests, std::memory_order_release);
  }
  requests->Inc();
}

std::unique_ptr<gx::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    const RpcMetrics& metrics) {
  return std::make_unique<Factory>(metrics);
}

std::unique_ptr<gx::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    Registry& registry, std::map<std::string, std::string> drive_families) {
  return std::make_unique<Factory>(registry, std::move(drive_families));
}

}  // namespace drivegw::ops
