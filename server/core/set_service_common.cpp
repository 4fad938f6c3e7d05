// Names, paging, etag detail and audit JSON shared by the parameter-set and curve-set services
// (set_service_common.h).
#include "server/core/set_service_common.h"

#include <algorithm>
#include <utility>

#include "absl/strings/cord.h"
#include "absl/strings/match.h"
#include "google/rpc/error_details.pb.h"
#include "server/core/audit.h"
#include "server/core/page_token.h"

namespace drivegw::server {

std::string SetResource(absl::string_view prefix, const std::string& set) {
  return absl::StrCat(std::string(prefix), set);
}

absl::StatusOr<std::string> SetIdFromName(const std::string& field, const std::string& name,
                                          absl::string_view prefix, const char* what) {
  const std::string pattern = absl::StrCat("(\"", std::string(prefix), "{set}\")");
  if (name.empty()) return FieldError(field, absl::StrCat("is required ", pattern));
  absl::string_view id = name;
  if (absl::StartsWith(id, prefix)) id.remove_prefix(prefix.size());
  if (id.empty() || absl::StrContains(id, '/')) {
    return FieldError(field, absl::StrCat("'", name, "' is not a ", what, " name ", pattern));
  }
  return std::string(id);
}

absl::Status EtagDetail(absl::Status s, const std::string& set_resource) {
  if (!absl::IsFailedPrecondition(s) || !absl::StrContains(s.message(), "etag")) return s;
  google::rpc::PreconditionFailure pf;
  auto* v = pf.add_violations();
  v->set_type("ETAG");
  v->set_subject(set_resource);
  v->set_description(std::string(s.message()));
  s.SetPayload("type.googleapis.com/google.rpc.PreconditionFailure",
               absl::Cord(pf.SerializeAsString()));
  return s;
}

std::string BeforeAfterJson(const google::protobuf::Message* before,
                            const google::protobuf::Message* after) {
  std::string out = "{";
  if (before != nullptr) absl::StrAppend(&out, "\"before\":", ToAuditJson(*before));
  if (after != nullptr) {
    absl::StrAppend(&out, before != nullptr ? "," : "", "\"after\":", ToAuditJson(*after));
  }
  return out + "}";
}

absl::StatusOr<SetPage> SetPageOf(int page_size, const std::string& page_token, int max_limit) {
  if (page_size < 0 || page_size > max_limit) {
    return FieldError("page_size", absl::StrCat(page_size, " is outside 0..", max_limit));
  }
  SetPage page;
  page.limit = page_size == 0 ? 100 : page_size;
  auto after = SetPageToken(page_token);
  if (!after.ok()) return after.status();
  page.after_name = *std::move(after);
  page.query_limit = std::min(page.limit + 1, max_limit);
  return page;
}

}  // namespace drivegw::server
