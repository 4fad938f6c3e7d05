// RAII SQLite connection (WAL, FULLMUTEX) and prepared statements; every error is an absl::Status.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

struct sqlite3;
struct sqlite3_stmt;

namespace drivegw::storage {

// A prepared statement. Not thread-safe on its own: hold Db::Lock() from the first Bind to the
// Reset, because SQLite's serialized mode only protects each API call, not the sequence.
class Statement {
 public:
  Statement() = default;
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  // Parameter indexes are 1-based, as in sqlite3_bind_*.
  absl::Status Bind(int index, int value);
  absl::Status Bind(int index, int64_t value);
  absl::Status Bind(int index, double value);
  absl::Status Bind(int index, std::string_view text);  // copied (SQLITE_TRANSIENT)
  absl::Status Bind(int index, std::nullptr_t);
  absl::Status BindNull(int index);

  // true: a row is available through the Column getters; false: the statement is done.
  absl::StatusOr<bool> Step();
  // Steps until done, for statements that return no rows (INSERT, UPDATE, DDL).
  absl::Status Run();
  // Resets for re-execution and clears the bindings.
  absl::Status Reset();

  // Column indexes are 0-based, as in sqlite3_column_*.
  int ColumnCount() const;
  bool ColumnIsNull(int column) const;
  int ColumnInt(int column) const;
  int64_t ColumnInt64(int column) const;
  double ColumnDouble(int column) const;
  std::string ColumnText(int column) const;  // "" for NULL

  bool valid() const { return stmt_ != nullptr; }
  const std::string& sql() const { return sql_; }

 private:
  friend class Db;
  Statement(sqlite3* db, sqlite3_stmt* stmt, std::string sql) noexcept
      : db_(db), stmt_(stmt), sql_(std::move(sql)) {}
  absl::Status BindResult(int rc, int index) const;

  sqlite3* db_ = nullptr;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

// How much a commit survives (decision 1443). kProcessCrash = PRAGMA synchronous=NORMAL: a
// commit survives `kill -9` of the process (the WAL is written before COMMIT returns) but the WAL
// is fsynced only at checkpoints, so a power loss or kernel crash can lose the newest commits.
// kPowerLoss = synchronous=FULL: one fdatasync of the WAL per transaction (group commit shares
// it across a batch), so an acknowledged commit survives a power cut too.
enum class Durability { kProcessCrash, kPowerLoss };

// One connection, opened READWRITE|CREATE|FULLMUTEX with journal_mode=WAL (verified),
// synchronous per Durability (NORMAL by default), busy_timeout=5000, foreign_keys=ON. Move-only;
// objects that keep a Db& (ConfigRepo, AuditLog) need it to stay put and outlive them.
class Db {
 public:
  using Mutex = std::recursive_mutex;

  // Page size a NEW database file is created with (decision 1486); an existing file keeps its
  // own: SQLite fixes it with the first table, and in WAL mode only a VACUUM outside WAL could
  // change it, which Open never runs.
  static constexpr int kNewDatabasePageSize = 2048;

  // The parent directory must exist (the caller creates data_dir). `new_page_size` (512..65536,
  // a power of two) applies only if the file is still empty; benchmarks vary it.
  static absl::StatusOr<Db> Open(const std::string& path,
                                 Durability durability = Durability::kProcessCrash,
                                 int new_page_size = kNewDatabasePageSize);

  Db(Db&& other) noexcept;
  Db& operator=(Db&& other) noexcept;
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
  ~Db();

  // Runs one or more ';'-separated statements that return no rows we need.
  absl::Status Exec(std::string_view sql);
  absl::StatusOr<Statement> Prepare(std::string_view sql);

  // Runs `body` between BEGIN IMMEDIATE and COMMIT while holding Lock(); rolls back when `body`
  // returns an error (which is then returned) or when COMMIT fails.
  absl::Status Transaction(const std::function<absl::Status()>& body);

  // Serializes multi-call sequences on this connection (statement bind..reset, transactions,
  // insert + last_insert_rowid). Recursive, so Exec/Prepare may run under it.
  std::unique_lock<Mutex> Lock() const;

  // Valid while Lock() is held right after the INSERT.
  int64_t LastInsertRowId() const;
  // PRAGMA journal_mode as SQLite reports it ("wal" after a successful Open).
  absl::StatusOr<std::string> JournalMode();
  // PRAGMA page_size: the file's page size (kNewDatabasePageSize for a file Open created).
  absl::StatusOr<int> PageSize();

  const std::string& path() const;
  sqlite3* handle() const;

 private:
  struct Impl;
  explicit Db(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace drivegw::storage
