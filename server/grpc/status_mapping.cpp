// absl::Status -> grpc::Status with google.rpc.Status details.
#include "server/grpc/status_mapping.h"

#include <string>

#include "google/rpc/status.pb.h"

namespace drivegw::server {

grpc::Status ToGrpcStatus(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  // absl and gRPC share the canonical code numbering (google.rpc.Code).
  const auto code = static_cast<grpc::StatusCode>(static_cast<int>(s.code()));
  google::rpc::Status details;
  details.set_code(static_cast<int>(s.code()));
  details.set_message(std::string(s.message()));
  s.ForEachPayload([&](absl::string_view url, const absl::Cord& payload) {
    auto* any = details.add_details();
    any->set_type_url(std::string(url));
    any->set_value(std::string(payload));
  });
  return grpc::Status(code, std::string(s.message()), details.SerializeAsString());
}

}  // namespace drivegw::server
