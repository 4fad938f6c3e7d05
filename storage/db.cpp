// RAII SQLite connection and statements: open with WAL, map result codes to absl::Status.
#include "storage/db.h"

#include <sqlite3.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"

namespace drivegw::storage {
namespace {

// The first words of a statement, enough to tell which one failed without dumping a migration.
std::string SqlHead(std::string_view sql) {
  constexpr size_t kMaxWords = 4;
  constexpr size_t kMaxChars = 60;
  // Skip leading blanks and "-- comment" lines so a migration reports its first statement.
  while (!sql.empty()) {
    const char c = sql.front();
    if (c == ' ' || c == '\n' || c == '\t' || c == '\r') {
      sql.remove_prefix(1);
    } else if (sql.substr(0, 2) == "--") {
      const size_t eol = sql.find('\n');
      sql.remove_prefix(eol == std::string_view::npos ? sql.size() : eol);
    } else {
      break;
    }
  }
  std::string out;
  size_t words = 0;
  bool in_space = true;
  for (char c : sql) {
    const bool space = c == ' ' || c == '\n' || c == '\t' || c == '\r';
    if (space) {
      if (!in_space) {
        if (++words == kMaxWords) break;
        out.push_back(' ');
      }
    } else {
      out.push_back(c);
    }
    in_space = space;
    if (out.size() >= kMaxChars) {
      out += "...";
      break;
    }
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

absl::StatusCode CodeFor(int rc) {
  switch (rc & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return absl::StatusCode::kUnavailable;
    case SQLITE_CONSTRAINT:
      return absl::StatusCode::kFailedPrecondition;
    case SQLITE_CANTOPEN:
      return absl::StatusCode::kFailedPrecondition;
    case SQLITE_READONLY:
    case SQLITE_PERM:
    case SQLITE_AUTH:
      return absl::StatusCode::kPermissionDenied;
    case SQLITE_FULL:
    case SQLITE_NOMEM:
      return absl::StatusCode::kResourceExhausted;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return absl::StatusCode::kDataLoss;
    case SQLITE_IOERR:
      return absl::StatusCode::kUnavailable;
    default:
      return absl::StatusCode::kInternal;
  }
}

// "storage: <sqlite message> (sql="INSERT INTO audit_log ...", code=19)"
absl::Status Error(sqlite3* db, int rc, std::string_view sql) {
  const char* msg = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  const int extended = db != nullptr ? sqlite3_extended_errcode(db) : rc;
  return absl::Status(CodeFor(rc), absl::StrCat("storage: ", msg, " (sql=\"", SqlHead(sql),
                                                "\", code=", extended, ")"));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Statement

Statement::Statement(Statement&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)),
      stmt_(std::exchange(other.stmt_, nullptr)),
      sql_(std::move(other.sql_)) {}

Statement& Statement::operator=(Statement&& other) noexcept {
  if (this != &other) {
    if (stmt_ != nullptr) sqlite3_finalize(stmt_);
    db_ = std::exchange(other.db_, nullptr);
    stmt_ = std::exchange(other.stmt_, nullptr);
    sql_ = std::move(other.sql_);
  }
  return *this;
}

Statement::~Statement() {
  if (stmt_ != nullptr) sqlite3_finalize(stmt_);
}

absl::Status Statement::BindResult(int rc, int index) const {
  if (rc == SQLITE_OK) return absl::OkStatus();
  absl::Status s = Error(db_, rc, sql_);
  return absl::Status(s.code(), absl::StrCat(s.message(), " binding parameter ", index));
}

absl::Status Statement::Bind(int index, int value) {
  if (stmt_ == nullptr) return absl::InternalError("storage: Bind on an empty statement");
  return BindResult(sqlite3_bind_int(stmt_, index, value), index);
}

absl::Status Statement::Bind(int index, int64_t value) {
  if (stmt_ == nullptr) return absl::InternalError("storage: Bind on an empty statement");
  return BindResult(sqlite3_bind_int64(stmt_, index, value), index);
}

absl::Status Statement::Bind(int index, double value) {
  if (stmt_ == nullptr) return absl::InternalError("storage: Bind on an empty statement");
  return BindResult(sqlite3_bind_double(stmt_, index, value), index);
}

absl::Status Statement::Bind(int index, std::string_view text) {
  if (stmt_ == nullptr) return absl::InternalError("storage: Bind on an empty statement");
  // data() of an empty view may be null, which SQLite would store as NULL; "" stays text.
  const char* data = text.data() != nullptr ? text.data() : "";
  return BindResult(
      sqlite3_bind_text64(stmt_, index, data, text.size(), SQLITE_TRANSIENT, SQLITE_UTF8), index);
}

absl::Status Statement::Bind(int index, std::nullptr_t) { return BindNull(index); }

absl::Status Statement::BindNull(int index) {
  if (stmt_ == nullptr) return absl::InternalError("storage: Bind on an empty statement");
  return BindResult(sqlite3_bind_null(stmt_, index), index);
}

absl::StatusOr<bool> Statement::Step() {
  if (stmt_ == nullptr) return absl::InternalError("storage: Step on an empty statement");
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  absl::Status s = Error(db_, rc, sql_);
  // Leave the statement reusable; the error is already captured.
  sqlite3_reset(stmt_);
  return s;
}

absl::Status Statement::Run() {
  while (true) {
    DGW_ASSIGN_OR_RETURN(const bool row, Step());
    if (!row) return absl::OkStatus();
  }
}

absl::Status Statement::Reset() {
  if (stmt_ == nullptr) return absl::InternalError("storage: Reset on an empty statement");
  // sqlite3_reset repeats the last step's error, which Step already reported.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
  return absl::OkStatus();
}

int Statement::ColumnCount() const { return stmt_ ? sqlite3_column_count(stmt_) : 0; }

bool Statement::ColumnIsNull(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

int Statement::ColumnInt(int column) const { return sqlite3_column_int(stmt_, column); }

int64_t Statement::ColumnInt64(int column) const { return sqlite3_column_int64(stmt_, column); }

double Statement::ColumnDouble(int column) const { return sqlite3_column_double(stmt_, column); }

std::string Statement::ColumnText(int column) const {
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  if (text == nullptr) return {};
  return std::string(reinterpret_cast<const char*>(text),
                     static_cast<size_t>(sqlite3_column_bytes(stmt_, column)));
}

// ---------------------------------------------------------------------------------------------
// Db

struct Db::Impl {
  sqlite3* db = nullptr;
  std::string path;
  mutable Mutex mu;
  // BEGIN IMMEDIATE, COMMIT and ROLLBACK, prepared once (each on first use): every audited
  // command is one transaction, and sqlite3_exec parsed the text each time (8 % of an append's
  // profile, docs/performance.md P1 2026-12-07; audit_bench, 1 caller, interleaved:
  // 28.6-30.3 -> 27.9-28.3 µs CPU per entry).
  // Finalized after close_v2 below, which defers the close until then.
  Statement begin;
  Statement commit;
  Statement rollback;

  ~Impl() {
    // close_v2 defers the close until any statement still alive is finalized.
    if (db != nullptr) sqlite3_close_v2(db);
  }
};

Db::Db(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Db::Db(Db&& other) noexcept = default;
Db& Db::operator=(Db&& other) noexcept = default;
Db::~Db() = default;

absl::StatusOr<Db> Db::Open(const std::string& path, Durability durability, int new_page_size) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  const int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX;
  const int rc = sqlite3_open_v2(path.c_str(), &impl->db, flags, nullptr);
  if (rc != SQLITE_OK) {
    absl::Status s = Error(impl->db, rc, "open");
    return absl::Status(s.code(), absl::StrCat(s.message(), " (path=", path, ")"));
  }
  sqlite3_extended_result_codes(impl->db, 1);
  Db db(std::move(impl));
  // busy_timeout first: switching to WAL needs a lock another process may briefly hold.
  DGW_RETURN_IF_ERROR(db.Exec("PRAGMA busy_timeout=5000"));
  // Before journal_mode=WAL: switching an empty file to WAL writes its header, which fixes the
  // page size, and WAL mode refuses a change afterwards (sqlite.org/pragma.html#pragma_page_size).
  // For a file that already has a header SQLite ignores this: it keeps its page size.
  DGW_RETURN_IF_ERROR(db.Exec(absl::StrCat("PRAGMA page_size=", new_page_size)));
  DGW_ASSIGN_OR_RETURN(Statement wal, db.Prepare("PRAGMA journal_mode=WAL"));
  DGW_ASSIGN_OR_RETURN(const bool row, wal.Step());
  const std::string mode = row ? wal.ColumnText(0) : "";
  if (mode != "wal") {
    // toolchain.md §2: WAL needs a file database; ":memory:" reads back "memory".
    return absl::FailedPreconditionError(
        absl::StrCat("storage: journal_mode is '", mode, "', want 'wal' (path=", path, ")"));
  }
  DGW_RETURN_IF_ERROR(db.Exec(durability == Durability::kPowerLoss ? "PRAGMA synchronous=FULL"
                                                                   : "PRAGMA synchronous=NORMAL"));
  DGW_RETURN_IF_ERROR(db.Exec("PRAGMA foreign_keys=ON"));
  return db;
}

absl::Status Db::Exec(std::string_view sql) {
  auto lock = Lock();
  const std::string text(sql);
  char* err = nullptr;
  const int rc = sqlite3_exec(impl_->db, text.c_str(), nullptr, nullptr, &err);
  sqlite3_free(err);  // the same text is available from sqlite3_errmsg
  if (rc != SQLITE_OK) return Error(impl_->db, rc, sql);
  return absl::OkStatus();
}

absl::StatusOr<Statement> Db::Prepare(std::string_view sql) {
  sqlite3_stmt* stmt = nullptr;
  const char* data = sql.data() != nullptr ? sql.data() : "";
  const int rc = sqlite3_prepare_v3(impl_->db, data, static_cast<int>(sql.size()),
                                    SQLITE_PREPARE_PERSISTENT, &stmt, nullptr);
  if (rc != SQLITE_OK) return Error(impl_->db, rc, sql);
  if (stmt == nullptr) {
    return absl::InternalError(
        absl::StrCat("storage: empty statement (sql=\"", SqlHead(sql), "\")"));
  }
  return Statement(impl_->db, stmt, std::string(sql));
}

absl::Status Db::Transaction(const std::function<absl::Status()>& body) {
  auto lock = Lock();
  // Same statements and error texts as Exec gives, without parsing them per transaction.
  auto run = [this](Statement& slot, std::string_view sql) -> absl::Status {
    if (!slot.valid()) {
      DGW_ASSIGN_OR_RETURN(slot, Prepare(sql));
    }
    absl::Status s = slot.Run();
    slot.Reset().IgnoreError();
    return s;
  };
  DGW_RETURN_IF_ERROR(run(impl_->begin, "BEGIN IMMEDIATE"));
  absl::Status status = body();
  if (status.ok()) {
    status = run(impl_->commit, "COMMIT");
    if (status.ok()) return status;
  }
  // Rolling back after a failed COMMIT is right too: the transaction is still open then.
  if (!sqlite3_get_autocommit(impl_->db)) run(impl_->rollback, "ROLLBACK").IgnoreError();
  return status;
}

std::unique_lock<Db::Mutex> Db::Lock() const { return std::unique_lock<Mutex>(impl_->mu); }

int64_t Db::LastInsertRowId() const { return sqlite3_last_insert_rowid(impl_->db); }

absl::StatusOr<std::string> Db::JournalMode() {
  auto lock = Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, Prepare("PRAGMA journal_mode"));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return absl::InternalError("storage: PRAGMA journal_mode returned no row");
  return stmt.ColumnText(0);
}

absl::StatusOr<int> Db::PageSize() {
  auto lock = Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, Prepare("PRAGMA page_size"));
  DGW_ASSIGN_OR_RETURN(const bool row, stmt.Step());
  if (!row) return absl::InternalError("storage: PRAGMA page_size returned no row");
  return stmt.ColumnInt(0);
}

const std::string& Db::path() const { return impl_->path; }

sqlite3* Db::handle() const { return impl_->db; }

}  // namespace drivegw::storage
