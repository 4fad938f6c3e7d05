// Field-violation and error-info payloads on absl::Status.
#include "server/core/errors.h"

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "google/rpc/error_details.pb.h"

namespace drivegw::server {

absl::Status FieldError(std::string_view field, std::string_view description,
                        absl::StatusCode code) {
  return FieldErrors({FieldViolation{std::string(field), std::string(description)}}, code);
}

absl::Status FieldErrors(const std::vector<FieldViolation>& violations, absl::StatusCode code) {
  google::rpc::BadRequest br;
  std::vector<std::string> parts;
  for (const auto& v : violations) {
    auto* fv = br.add_field_violations();
    fv->set_field(v.field);
    fv->set_description(v.description);
    parts.push_back(absl::StrCat(v.field, ": ", v.description));
  }
  absl::Status s(code, absl::StrJoin(parts, "; "));
  s.SetPayload(absl::string_view(kBadRequestUrl.data(), kBadRequestUrl.size()),
               absl::Cord(br.SerializeAsString()));
  return s;
}

absl::Status WithErrorInfo(absl::Status status, std::string_view reason,
                           const std::vector<std::pair<std::string, std::string>>& metadata) {
  google::rpc::ErrorInfo info;
  info.set_reason(std::string(reason));
  info.set_domain("drivegw");
  for (const auto& [k, v] : metadata) (*info.mutable_metadata())[k] = v;
  status.SetPayload(absl::string_view(kErrorInfoUrl.data(), kErrorInfoUrl.size()),
                    absl::Cord(info.SerializeAsString()));
  return status;
}

}  // namespace drivegw::server
