// Curve sets in SQLite (issue 6 "Curve sets"): named, versioned groups of curves with optimistic
// concurrency (etag), shaped like ParameterSetRepo (decision 411). Every change creates a new
// immutable version; the set row points at the newest. Curves are checked for shape and LinMot
// limits before they are stored (ValidateCurveSetShape); axis limits depend on the target drive
// and are checked when a curve is downloaded or run, not here.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/curve.h"
#include "storage/db.h"

namespace drivegw::storage {

using Time = std::chrono::system_clock::time_point;  // as parameter_set_repo.h: UTC, ms

struct StoredCurveSet {
  CurveSet set;        // name (unique, 1..128 chars [A-Za-z0-9._-]), description, newest curves
  std::string author;  // of the newest version
  Time created_at{};
  Time updated_at{};
  int version = 0;   // newest version number
  std::string etag;  // changes with every update; opaque to clients
};

struct CurveSetVersion {
  int version = 0;  // 1, 2, ...
  std::vector<Curve> curves;
  std::string author;
  std::string comment;
  Time created_at{};
};

struct CurveSetQuery {
  static constexpr int kMaxLimit = 1000;
  std::optional<std::string> after_name;  // page token: names sort ascending
  int limit = 100;                        // 1..kMaxLimit; 0 = 100
};

// The curves_json column: an array of objects, one per curve, in order (decision 411).
absl::StatusOr<std::string> CurvesToJson(const std::vector<Curve>& curves);
// `context` names the row in errors ("set 'x' version 3: curves[2].points: ...").
absl::StatusOr<std::vector<Curve>> CurvesFromJson(std::string_view json, std::string_view context);

class CurveSetRepo {
 public:
  explicit CurveSetRepo(Db& db) : db_(&db) {}

  // New set with version 1. AlreadyExists when the name is taken; InvalidArgument naming the
  // field for a bad name or an invalid curve (ValidateCurveSetShape).
  absl::StatusOr<StoredCurveSet> Create(const CurveSet& set, std::string_view author,
                                        std::string_view comment = "");
  absl::StatusOr<StoredCurveSet> Get(std::string_view name);  // NotFound naming the set
  absl::StatusOr<std::vector<StoredCurveSet>> List(const CurveSetQuery& query = {});
  // Replaces description and curves as a new version. `expected_etag` must match the current
  // etag, else FailedPrecondition "etag mismatch: curve set 'x' is at version 4" (HTTP 412); an
  // empty expected_etag is InvalidArgument (updates are always conditional).
  absl::StatusOr<StoredCurveSet> Update(const CurveSet& set, std::string_view expected_etag,
                                        std::string_view author, std::string_view comment = "");
  // Deletes the set and its versions. Same etag rule.
  absl::Status Delete(std::string_view name, std::string_view expected_etag);
  // Newest first.
  absl::StatusOr<std::vector<CurveSetVersion>> ListVersions(std::string_view name);
  absl::StatusOr<CurveSetVersion> GetVersion(std::string_view name, int version);

 private:
  Db* db_;
};

}  // namespace drivegw::storage
