// Parameter sets in SQLite: named, versioned collections of (parameter, value) for one drive
// family, with optimistic concurrency (etag), and the apply operations with their pre-images
// (issue 6). Every change creates a new immutable version; the set row points at the newest.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/db.h"

namespace drivegw::storage {

using Time = std::chrono::system_clock::time_point;  // UTC, millisecond resolution

struct ParameterValue {
  std::string parameter;  // the family's name ("$14.vmax", "0x14BE", "I10"), canonical form
  uint32_t id = 0;        // ParameterRef.id the name resolves to
  int64_t value = 0;
  friend bool operator==(const ParameterValue&, const ParameterValue&) = default;
};

struct ParameterSetVersion {
  int version = 0;                     // 1, 2, ...
  std::vector<ParameterValue> values;  // ordered as written; one entry per parameter
  std::string author;
  std::string comment;
  Time created_at{};
};

struct ParameterSet {
  std::string name;    // unique, 1..128 chars [A-Za-z0-9._-]
  std::string family;  // "linmot", "trinamic", ...
  std::string model;   // optional drive model ("" = any model of the family)
  std::string description;
  bool target_stored = false;  // LinMot: write the ROM (stored) values instead of RAM
  std::string author;          // of the newest version
  Time created_at{};
  Time updated_at{};
  int version = 0;                     // newest version number
  std::string etag;                    // changes with every update; opaque to clients
  std::vector<ParameterValue> values;  // of the newest version
};

struct ParameterSetQuery {
  static constexpr int kMaxLimit = 1000;
  std::optional<std::string> family;
  std::optional<std::string> after_name;  // page token: names sort ascending
  int limit = 100;                        // 1..kMaxLimit; 0 = 100
};

// One drive's part of an apply operation.
struct ApplyDriveResult {
  std::string drive;
  std::vector<ParameterValue> pre_image;  // values read before the first write
  std::vector<ParameterValue> written;    // values written and read back equal, in order
  // "PENDING", "APPLYING" (pre-image stored, writes under way), "APPLIED", "ROLLED_BACK",
  // "ROLLBACK_FAILED", "UNCHANGED", "INTERRUPTED" (the gateway stopped while APPLYING: some
  // values may be written, the pre-image restores all; decision 1441).
  std::string state;
  std::string failed_parameter;  // name, "" if none
  std::string error;             // why it failed ("read back 120, wrote 300"), "" if none
};

struct ApplyOperation {
  std::string id;  // "op-<n>"
  std::string set_name;
  int set_version = 0;
  bool dry_run = false;
  // "RUNNING", "SUCCEEDED", "FAILED" (rolled back), "FAILED_ROLLBACK", "INTERRUPTED" (found
  // RUNNING at start-up: the process ended during the apply, decision 1441).
  std::string state;
  std::vector<ApplyDriveResult> drives;
  bool target_stored = false;  // ROM (stored) values were written, not RAM; fixed at creation
  std::string restores;        // "op-<n>" when this writes back operation n's pre-image, else ""
  std::string principal;
  Time created_at{};
  Time updated_at{};
};

class ParameterSetRepo {
 public:
  explicit ParameterSetRepo(Db& db) : db_(&db) {}

  // New set with version 1. AlreadyExists when the name is taken; InvalidArgument naming the field
  // for a bad name/family or a parameter listed twice.
  absl::StatusOr<ParameterSet> Create(const ParameterSet& set, std::string_view comment = "");
  absl::StatusOr<ParameterSet> Get(std::string_view name);  // NotFound naming the set
  absl::StatusOr<std::vector<ParameterSet>> List(const ParameterSetQuery& query = {});
  // Replaces description/model/target_stored/values as a new version. `expected_etag` must match
  // the current etag, else FailedPrecondition "etag mismatch: set 'x' is at version 4" (HTTP 412);
  // an empty expected_etag is InvalidArgument (updates are always conditional).
  absl::StatusOr<ParameterSet> Update(const ParameterSet& set, std::string_view expected_etag,
                                      std::string_view comment = "");
  // Deletes the set and its versions (apply operations keep their copy). Same etag rule.
  absl::Status Delete(std::string_view name, std::string_view expected_etag);
  // Newest first.
  absl::StatusOr<std::vector<ParameterSetVersion>> ListVersions(std::string_view name);
  absl::StatusOr<ParameterSetVersion> GetVersion(std::string_view name, int version);

  // Apply operations (long-running): created RUNNING, updated as drives progress, never deleted.
  absl::StatusOr<ApplyOperation> CreateOperation(const ApplyOperation& op);  // assigns id, times
  absl::Status UpdateOperation(const ApplyOperation& op);                    // NotFound if absent
  absl::StatusOr<ApplyOperation> GetOperation(std::string_view id);
  absl::StatusOr<std::vector<ApplyOperation>> ListOperations(int limit = 100);  // newest first
  // Start-up, before any apply can start: every RUNNING operation becomes INTERRUPTED (its
  // APPLYING drives INTERRUPTED, with `reason` as their error) in one transaction; returns them
  // as stored (decision 1441).
  absl::StatusOr<std::vector<ApplyOperation>> InterruptRunning(std::string_view reason);

 private:
  Db* db_;
};

}  // namespace drivegw::storage
