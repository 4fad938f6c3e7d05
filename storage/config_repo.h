// Snapshots of the gateway configuration (YAML text) as it was loaded or changed.
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

struct Snapshot {
  int64_t id = 0;
  std::chrono::system_clock::time_point created_at;  // UTC, millisecond resolution
  std::string source;                                // e.g. "file:/etc/drivegw.yaml", "demo"
  std::string yaml;
  int drive_count = 0;
};

class ConfigRepo {
 public:
  static constexpr int kMaxListLimit = 1000;

  // Keeps `db`, which must outlive this object and stay migrated to the latest schema.
  explicit ConfigRepo(Db& db) : db_(&db) {}

  // Returns the new snapshot's id. created_at is the current UTC time.
  absl::StatusOr<int64_t> SaveSnapshot(std::string_view source, std::string_view yaml,
                                       int drive_count);
  // The most recent snapshot, or nullopt when none was saved.
  absl::StatusOr<std::optional<Snapshot>> Latest();
  // Newest first; limit 1..kMaxListLimit.
  absl::StatusOr<std::vector<Snapshot>> List(int limit = 20);

 private:
  Db* db_;
};

}  // namespace drivegw::storage
