// Per-RPC metrics (issue 7 "Operations"; decision 021): a gRPC server interceptor that counts
// every call by service, method, transport and status code and times it; calls naming a
// configured drive (the request's `name` field) also count per drive and family. REST calls
// are in-process gRPC calls, so they pass here too (transport="rest") — except the read-only
// unary methods REST serves directly (decision 1331), which record the same series through
// RpcMetrics::Method below.
#pragma once

#include <grpcpp/support/server_interceptor.h>
#include <grpcpp/support/status.h>

#include <atomic>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <string_view>

#include "server/ops/metrics.h"

namespace drivegw::ops {

// What a finished call records; one object shared by the interceptor and the REST direct path
// so both write exactly the same series. `registry` must outlive it.
class RpcMetrics {
 public:
  // `drive_families`: drive name -> family, for the per-drive series. `raw_methods`: the full
  // names ("/package.Service/Method") of methods a service registered as raw (ByteBuffer), whose
  // messages are no protobuf Message and are therefore never read for a drive name; the
  // service that marks them raw hands them over (DriveServiceGrpc::kRawMethods).
  RpcMetrics(Registry& registry, std::map<std::string, std::string> drive_families,
             std::set<std::string, std::less<>> raw_methods = {});

  bool IsRawMethod(std::string_view full_method) const {
    return raw_methods_.find(full_method) != raw_methods_.end();
  }

  // The configured drive a request's `name` field names ("drives/x1" or "x1"): its name and
  // family, or nullptr.
  const std::pair<const std::string, std::string>* FindDrive(std::string_view name_field) const;

  // Counts and times one finished call. `drive`: FindDrive's entry, or nullptr.
  void Record(std::string_view service, std::string_view method, std::string_view transport,
              const std::pair<const std::string, std::string>* drive, grpc::StatusCode code,
              double seconds) const;

  // The series of one (service, method, transport), looked up once on first use (so
  // /metrics shows them only once a call was made, as with the interceptor): recording a call
  // then takes no registry lock and no allocation on success (errors go through Record).
  class Method {
   public:
    Method(const RpcMetrics& metrics, std::string_view service, std::string_view method,
           std::string_view transport);
    Method(const Method&) = delete;
    Method& operator=(const Method&) = delete;
    void Record(const std::pair<const std::string, std::string>* drive, grpc::StatusCode code,
                double seconds) const;

   private:
    const RpcMetrics& metrics_;
    const std::string service_, method_, transport_;
    mutable std::atomic<Counter*> ok_{nullptr};
    mutable std::atomic<Histogram*> duration_{nullptr};
    // One entry per configured drive (fixed at construction), its series resolved on first use.
    mutable std::map<std::string, std::atomic<Counter*>, std::less<>> drive_requests_;
  };

 private:
  Registry& registry_;
  std::map<std::string, std::string, std::less<>> drive_families_;
  std::set<std::string, std::less<>> raw_methods_;
};

// The interceptor factory over `metrics` (which must outlive the server).
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    const RpcMetrics& metrics);

// As above with an RpcMetrics of its own.
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeRpcMetricsFactory(
    Registry& registry, std::map<std::string, std::string> drive_families);

}  // namespace drivegw::ops
