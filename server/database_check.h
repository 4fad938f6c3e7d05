// Opening the gateway's SQLite file with a start-up integrity check (decision 1495).
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "storage/db.h"

namespace drivegw::server {

// Db::Open(path), then PRAGMA quick_check (O(size of the file), no index-to-table cross-check).
// A file SQLite finds damaged — Open failing with DATA_LOSS (not a database, a malformed image)
// or quick_check answering anything but "ok" — is DATA_LOSS naming data_dir, the file, SQLite's
// first findings and what to do, so damaged pages behind a valid header stop the start instead
// of failing the first audited command later. Other Open errors are returned as they are.
absl::StatusOr<storage::Db> OpenCheckedDatabase(const std::string& path,
                                                 storage::Durability durability);

}  // namespace drivegw::server
