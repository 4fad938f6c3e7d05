// OpenCheckedDatabase: Db::Open plus PRAGMA quick_check at start-up (decision 1495).
#include "server/database_check.h"

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace drivegw::server {
namespace {

// At most this many findings are quoted; quick_check stops by itself after 100.
constexpr size_t kQuotedFindings = 3;

absl::Status Damaged(const std::string& path, const std::string& what) {
  return absl::DataLossError(
      absl::StrCat("data_dir: database '", path, "' ", what,
                   "; restore it from a backup, or move it away to start with an empty one"));
}

// "" when SQLite answers "ok", else the findings ("(and N more)" beyond kQuotedFindings).
absl::StatusOr<std::string> QuickCheck(storage::Db& db) {
  auto lock = db.Lock();
  absl::StatusOr<storage::Statement> stmt = db.Prepare("PRAGMA quick_check");
  if (!stmt.ok()) return stmt.status();
  std::vector<std::string> quoted;
  size_t total = 0;
  while (true) {
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    std::string text = stmt->ColumnText(0);
    if (text == "ok") continue;
    ++total;
    if (quoted.size() < kQuotedFindings) quoted.push_back(std::move(text));
  }
  std::string out;
  for (const std::string& f : quoted) absl::StrAppend(&out, out.empty() ? "" : "; ", f);
  if (total > quoted.size()) absl::StrAppend(&out, " (and ", total - quoted.size(), " more)");
  return out;
}

}  // namespace

absl::StatusOr<storage::Db> OpenCheckedDatabase(const std::string& path,
                                                 storage::Durability durability) {
  absl::StatusOr<storage::Db> db = storage::Db::Open(path, durability);
  if (!db.ok()) {
    // Open already reads the header and sets WAL, which reads the schema: damage there shows here.
    if (db.status().code() != absl::StatusCode::kDataLoss) return db.status();
    return Damaged(path, absl::StrCat("cannot be opened: ", db.status().message()));
  }
  absl::StatusOr<std::string> findings = QuickCheck(*db);
  if (!findings.ok()) {
    return Damaged(path, absl::StrCat("fails PRAGMA quick_check: ", findings.status().message()));
  }
  if (!findings->empty())
    return Damaged(path, absl::StrCat("fails PRAGMA quick_check: ", *findings));
  return db;
}

}  // namespace drivegw::server
