// The plumbing the two versioned-set services (parameter sets, curve sets) share: set names
// ("parameterSets/{set}", "curveSets/{set}"), List paging, the stale-etag detail, the audit
// before/after JSON and the version and conditional-delete calls. Each service keeps what is its
// own (validation, conversion, drive calls); the repos share one interface shape, not a base.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "google/protobuf/message.h"
#include "server/core/errors.h"

namespace drivegw::server {

// "<prefix><set>", e.g. "curveSets/demo".
std::string SetResource(absl::string_view prefix, const std::string& set);

// "curveSets/demo" or "demo" -> "demo"; InvalidArgument naming `field` otherwise. `what` names
// the kind of set in the message ("curve set", "parameter set").
absl::StatusOr<std::string> SetIdFromName(const std::string& field, const std::string& name,
                                          absl::string_view prefix, const char* what);

// A stale etag (FailedPrecondition from the repo) gets a google.rpc.PreconditionFailure
// {type "ETAG", subject `set_resource`}: the REST front end answers it 412 instead of 400 (RFC
// 9110 §13.1.1 If-Match; decision 011), gRPC clients see FAILED_PRECONDITION with the detail.
// Other statuses pass unchanged.
absl::Status EtagDetail(absl::Status s, const std::string& set_resource);

// {"before": ..., "after": ...} for the audit entry (either may be absent).
std::string BeforeAfterJson(const google::protobuf::Message* before,
                            const google::protobuf::Message* after);

// One List call's page: `limit` rows for the caller (page_size, 100 when 0), the repo asked for
// one more (`query_limit`, capped at `max_limit`) to tell whether a next page exists.
struct SetPage {
  int limit = 0;
  int query_limit = 0;
  std::optional<std::string> after_name;
};
// InvalidArgument naming page_size (outside 0..max_limit) or page_token (SetPageToken).
absl::StatusOr<SetPage> SetPageOf(int page_size, const std::string& page_token, int max_limit);

// Hands the first `page.limit` rows to `emit`; returns the next page token (the last emitted
// row's name, `name_of`) when the repo returned more, "" otherwise.
template <typename Row, typename Emit, typename NameOf>
std::string EmitPage(const std::vector<Row>& rows, const SetPage& page, Emit emit, NameOf name_of) {
  for (size_t i = 0; i < rows.size() && static_cast<int>(i) < page.limit; ++i) emit(rows[i]);
  if (static_cast<int>(rows.size()) <= page.limit) return "";
  return name_of(rows[static_cast<size_t>(page.limit) - 1]);
}

// ListVersions of the set `name` (already parsed), each version converted by
// `to_proto(name, version)` into the response's `versions`.
template <typename Response, typename Repo, typename ToProto>
absl::StatusOr<Response> ListSetVersions(Repo& repo, const absl::StatusOr<std::string>& name,
                                         ToProto to_proto) {
  if (!name.ok()) return name.status();
  auto versions = repo.ListVersions(*name);
  if (!versions.ok()) return versions.status();
  Response out;
  for (const auto& v : *versions) *out.add_versions() = to_proto(*name, v);
  return out;
}

// One stored version (>= 1) of the set `name`, converted by `to_proto(name, version)`.
template <typename Repo, typename ToProto>
auto GetSetVersion(Repo& repo, const absl::StatusOr<std::string>& name, int version,
                   ToProto to_proto)
    -> absl::StatusOr<decltype(to_proto(*name, *repo.GetVersion(*name, version)))> {
  if (!name.ok()) return name.status();
  if (version < 1) return FieldError("version", absl::StrCat(version, " is below 1"));
  auto v = repo.GetVersion(*name, version);
  if (!v.ok()) return v.status();
  return to_proto(*name, *v);
}

// The conditional delete of the set `name` (already parsed): the etag is required, a stale one
// gets EtagDetail. `audit_json` becomes the set as it was (BeforeAfterJson, `to_proto(set)`)
// when it could be read, and is left alone otherwise (the caller's request JSON).
template <typename Repo, typename ToProto>
absl::Status DeleteSet(Repo& repo, const absl::StatusOr<std::string>& name, const std::string& etag,
                       absl::string_view prefix, ToProto to_proto, std::string& audit_json) {
  absl::Status s = name.status();
  if (s.ok() && etag.empty()) s = FieldError("etag", "is required (deletes are conditional)");
  if (!s.ok()) return s;
  if (auto before = repo.Get(*name); before.ok()) {
    const auto b = to_proto(*before);
    audit_json = BeforeAfterJson(&b, nullptr);
  }
  return EtagDetail(repo.Delete(*name, etag), SetResource(prefix, *name));
}

}  // namespace drivegw::server
