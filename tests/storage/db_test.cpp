// Db and Statement against a real SQLite file: pragmas, WAL files, binding, error messages.
#include "storage/db.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>

#include "storage/audit_log.h"
#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;
using testing::TempDir;

int64_t PragmaInt(Db& db, const char* sql) {
  auto stmt = db.Prepare(sql);
  EXPECT_TRUE(stmt.ok()) << stmt.status();
  auto row = stmt->Step();
  EXPECT_TRUE(row.ok() && *row);
  return stmt->ColumnInt64(0);
}

TEST(DbTest, Open_FileDatabase_JournalModeIsWalAndWalFileAppearsAfterWrite) {
  TempDir dir;
  const std::string path = dir.File("t.db");
  auto db = Db::Open(path);
  ASSERT_TRUE(db.ok()) << db.status();
  auto mode = db->JournalMode();
  ASSERT_TRUE(mode.ok()) << mode.status();
  EXPECT_EQ(*mode, "wal");
  ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER); INSERT INTO t VALUES (1)").ok());
  EXPECT_TRUE(std::filesystem::exists(path + "-wal"));
  EXPECT_TRUE(std::filesystem::exists(path + "-shm"));
}

TEST(DbTest, Open_Pragmas_SynchronousNormalBusyTimeoutForeignKeys) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_EQ(PragmaInt(*db, "PRAGMA synchronous"), 1);  // NORMAL
  EXPECT_EQ(PragmaInt(*db, "PRAGMA busy_timeout"), 5000);
  EXPECT_EQ(PragmaInt(*db, "PRAGMA foreign_keys"), 1);
}

TEST(DbTest, Open_PowerLossDurability_SynchronousFull) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"), Durability::kPowerLoss);
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_EQ(PragmaInt(*db, "PRAGMA synchronous"), 2);  // FULL
  EXPECT_EQ(PragmaInt(*db, "PRAGMA foreign_keys"), 1);
}

// A VFS shim, registered as the default while it lives, counting xSync on WAL files: the only
// way to see from the outside what reaches the disk per commit (the seam where a test may look).
class SyncCountingVfs {
 public:
  SyncCountingVfs() {
    base_ = sqlite3_vfs_find(nullptr);
    vfs_ = *base_;
    vfs_.zName = "sync_counting";
    vfs_.szOsFile = base_->szOsFile + static_cast<int>(sizeof(Header));
    vfs_.pAppData = this;
    vfs_.xOpen = &Open;
    io_ = {};
    sqlite3_vfs_register(&vfs_, 1);
  }
  ~SyncCountingVfs() {
    sqlite3_vfs_unregister(&vfs_);
    sqlite3_vfs_register(base_, 1);
  }
  SyncCountingVfs(const SyncCountingVfs&) = delete;
  SyncCountingVfs& operator=(const SyncCountingVfs&) = delete;
  int wal_syncs() const { return wal_syncs_.load(); }

 private:
  // Our file: the base file's state follows the header (szOsFile above).
  struct Header {
    sqlite3_file file;
    SyncCountingVfs* owner;
    bool wal;
  };
  static sqlite3_file* Base(sqlite3_file* f) {
    return reinterpret_cast<sqlite3_file*>(reinterpret_cast<Header*>(f) + 1);
  }
  static int Open(sqlite3_vfs* vfs, const char* name, sqlite3_file* f, int flags, int* out_flags) {
    auto* self = static_cast<SyncCountingVfs*>(vfs->pAppData);
    auto* h = reinterpret_cast<Header*>(f);
    h->owner = self;
    h->wal = (flags & SQLITE_OPEN_WAL) != 0;
    const int rc = self->base_->xOpen(self->base_, name, Base(f), flags, out_flags);
    if (rc != SQLITE_OK || Base(f)->pMethods == nullptr) {
      h->file.pMethods = nullptr;
      return rc;
    }
    // One method table per base table (the base uses a single one for every file here).
    if (self->io_.iVersion == 0) {
      self->io_ = *Base(f)->pMethods;
      self->io_.xClose = [](sqlite3_file* file) {
        return Base(file)->pMethods->xClose(Base(file));
      };
      self->io_.xRead = [](sqlite3_file* file, void* b, int n, sqlite3_int64 o) {
        return Base(file)->pMethods->xRead(Base(file), b, n, o);
      };
      self->io_.xWrite = [](sqlite3_file* file, const void* b, int n, sqlite3_int64 o) {
        return Base(file)->pMethods->xWrite(Base(file), b, n, o);
      };
      self->io_.xTruncate = [](sqlite3_file* file, sqlite3_int64 n) {
        return Base(file)->pMethods->xTruncate(Base(file), n);
      };
      self->io_.xSync = [](sqlite3_file* file, int fl) {
        auto* hd = reinterpret_cast<Header*>(file);
        if (hd->wal) ++hd->owner->wal_syncs_;
        return Base(file)->pMethods->xSync(Base(file), fl);
      };
      self->io_.xFileSize = [](sqlite3_file* file, sqlite3_int64* n) {
        return Base(file)->pMethods->xFileSize(Base(file), n);
      };
      self->io_.xLock = [](sqlite3_file* file, int l) {
        return Base(file)->pMethods->xLock(Base(file), l);
      };
      self->io_.xUnlock = [](sqlite3_file* file, int l) {
        return Base(file)->pMethods->xUnlock(Base(file), l);
      };
      self->io_.xCheckReservedLock = [](sqlite3_file* file, int* r) {
        return Base(file)->pMethods->xCheckReservedLock(Base(file), r);
      };
      self->io_.xFileControl = [](sqlite3_file* file, int op, void* a) {
        return Base(file)->pMethods->xFileControl(Base(file), op, a);
      };
      self->io_.xSectorSize = [](sqlite3_file* file) {
        return Base(file)->pMethods->xSectorSize(Base(file));
      };
      self->io_.xDeviceCharacteristics = [](sqlite3_file* file) {
        return Base(file)->pMethods->xDeviceCharacteristics(Base(file));
      };
      self->io_.xShmMap = [](sqlite3_file* file, int r, int sz, int e, void volatile** p) {
        return Base(file)->pMethods->xShmMap(Base(file), r, sz, e, p);
      };
      self->io_.xShmLock = [](sqlite3_file* file, int o, int n, int fl) {
        return Base(file)->pMethods->xShmLock(Base(file), o, n, fl);
      };
      self->io_.xShmBarrier = [](sqlite3_file* file) {
        Base(file)->pMethods->xShmBarrier(Base(file));
      };
      self->io_.xShmUnmap = [](sqlite3_file* file, int d) {
        return Base(file)->pMethods->xShmUnmap(Base(file), d);
      };
      self->io_.xFetch = [](sqlite3_file* file, sqlite3_int64 o, int n, void** p) {
        return Base(file)->pMethods->xFetch(Base(file), o, n, p);
      };
      self->io_.xUnfetch = [](sqlite3_file* file, sqlite3_int64 o, void* p) {
        return Base(file)->pMethods->xUnfetch(Base(file), o, p);
      };
    }
    h->file.pMethods = &self->io_;
    return rc;
  }

  sqlite3_vfs* base_ = nullptr;
  sqlite3_vfs vfs_{};
  sqlite3_io_methods io_{};
  std::atomic<int> wal_syncs_{0};
};

// What each durability buys, seen at the disk: FULL syncs the WAL once per transaction, NORMAL
// leaves it to the checkpoint (decision 1443). 20 single-row commits, far below the
// auto-checkpoint's 1000 pages, so NORMAL must not sync at all.
TEST(DbTest, Durability_FullSyncsTheWalPerCommit_NormalDoesNot) {
  for (const Durability d : {Durability::kProcessCrash, Durability::kPowerLoss}) {
    SyncCountingVfs vfs;
    TempDir dir;
    auto db = Db::Open(dir.File("t.db"), d);
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER)").ok());
    const int before = vfs.wal_syncs();
    constexpr int kCommits = 20;
    for (int i = 0; i < kCommits; ++i) ASSERT_TRUE(db->Exec("INSERT INTO t VALUES (1)").ok());
    const int syncs = vfs.wal_syncs() - before;
    if (d == Durability::kPowerLoss) {
      EXPECT_GE(syncs, kCommits) << "FULL must fdatasync the WAL at every commit";
    } else {
      EXPECT_EQ(syncs, 0) << "NORMAL syncs the WAL only at checkpoints";
    }
  }
}

TEST(DbTest, Open_InMemory_FailsBecauseWalNeedsAFile) {
  auto db = Db::Open(":memory:");
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(db.status().message(), HasSubstr("journal_mode is 'memory', want 'wal'"));
}

TEST(DbTest, Open_MissingParentDirectory_FailsNamingPath) {
  TempDir dir;
  const std::string path = dir.File("no/such/dir/t.db");
  auto db = Db::Open(path);
  ASSERT_FALSE(db.ok());
  EXPECT_THAT(db.status().message(), HasSubstr(path));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "no"));
}

TEST(DbTest, Open_NotADatabase_FailsWithDataLoss) {
  TempDir dir;
  const std::string path = dir.File("junk.db");
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    for (int i = 0; i < 256; ++i) std::fputs("this is not sqlite ", f);
    std::fclose(f);
  }
  auto db = Db::Open(path);
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), absl::StatusCode::kDataLoss) << db.status();
}

TEST(DbTest, Exec_BadSql_ErrorCarriesSqliteMessageAndFirstWords) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  absl::Status s = db->Exec("SELECT nope FROM missing_table WHERE 1 = 1");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.message(), HasSubstr("no such table: missing_table"));
  EXPECT_THAT(s.message(), HasSubstr("sql=\"SELECT nope FROM missing_table\""));
}

TEST(DbTest, Statement_BindEveryTypeAndReadBack_RoundTrips) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE(
      db->Exec("CREATE TABLE t (i INTEGER, l INTEGER, d REAL, s TEXT, n TEXT, e TEXT)").ok());
  auto insert = db->Prepare("INSERT INTO t VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  ASSERT_TRUE(insert.ok()) << insert.status();
  ASSERT_TRUE(insert->Bind(1, 42).ok());
  ASSERT_TRUE(insert->Bind(2, int64_t{1} << 40).ok());
  ASSERT_TRUE(insert->Bind(3, 2.5).ok());
  ASSERT_TRUE(insert->Bind(4, std::string_view("h\0i", 3)).ok());
  ASSERT_TRUE(insert->Bind(5, nullptr).ok());
  ASSERT_TRUE(insert->Bind(6, std::string_view()).ok());
  ASSERT_TRUE(insert->Run().ok());

  auto select = db->Prepare("SELECT i, l, d, s, n, e, e IS NULL FROM t");
  ASSERT_TRUE(select.ok());
  auto row = select->Step();
  ASSERT_TRUE(row.ok() && *row);
  EXPECT_EQ(select->ColumnCount(), 7);
  EXPECT_EQ(select->ColumnInt(0), 42);
  EXPECT_EQ(select->ColumnInt64(1), int64_t{1} << 40);
  EXPECT_DOUBLE_EQ(select->ColumnDouble(2), 2.5);
  EXPECT_EQ(select->ColumnText(3), std::string("h\0i", 3));
  EXPECT_TRUE(select->ColumnIsNull(4));
  EXPECT_EQ(select->ColumnText(4), "");
  EXPECT_FALSE(select->ColumnIsNull(5));  // an empty view binds '' rather than NULL
  EXPECT_EQ(select->ColumnInt(6), 0);
  row = select->Step();
  ASSERT_TRUE(row.ok());
  EXPECT_FALSE(*row);
}

TEST(DbTest, Statement_BindOutOfRangeIndex_ReportsIndex) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  auto stmt = db->Prepare("SELECT ?1");
  ASSERT_TRUE(stmt.ok());
  absl::Status s = stmt->Bind(7, 1);
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.message(), HasSubstr("binding parameter 7"));
}

TEST(DbTest, Statement_ResetClearsBindings_ReusableForNextRow) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER NOT NULL)").ok());
  auto insert = db->Prepare("INSERT INTO t VALUES (?1)");
  ASSERT_TRUE(insert.ok());
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(insert->Bind(1, i).ok());
    ASSERT_TRUE(insert->Run().ok());
    ASSERT_TRUE(insert->Reset().ok());
  }
  // Bindings were cleared, so x would be NULL: the NOT NULL constraint fires.
  absl::Status s = insert->Run();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << s;
  EXPECT_THAT(s.message(), HasSubstr("NOT NULL constraint failed"));
  EXPECT_THAT(s.message(), HasSubstr("sql=\"INSERT INTO t VALUES\""));
}

TEST(DbTest, Transaction_BodyFails_RollsBackAndReturnsBodyError) {
  TempDir dir;
  auto db = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER)").ok());
  absl::Status s = db->Transaction([&]() -> absl::Status {
    EXPECT_TRUE(db->Exec("INSERT INTO t VALUES (1)").ok());
    return absl::AbortedError("body says no");
  });
  EXPECT_EQ(s, absl::AbortedError("body says no"));
  EXPECT_EQ(PragmaInt(*db, "SELECT COUNT(*) FROM t"), 0);

  ASSERT_TRUE(db->Transaction([&] { return db->Exec("INSERT INTO t VALUES (2)"); }).ok());
  EXPECT_EQ(PragmaInt(*db, "SELECT COUNT(*) FROM t"), 1);
}

// The page size recorded in the file header (bytes 16-17, big-endian; 1 means 65536), read from
// the file itself rather than from SQLite (sqlite.org/fileformat2.html §1.3.2).
int HeaderPageSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char header[18] = {};
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  EXPECT_EQ(in.gcount(), 18) << path;
  const int size = header[16] << 8 | header[17];
  return size == 1 ? 65536 : size;
}

TEST(DbTest, Open_NewDatabase_GetsTheChosenPageSize) {
  TempDir dir;
  const std::string path = dir.File("t.db");
  {
    auto db = Db::Open(path);
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER); INSERT INTO t VALUES (1)").ok());
    ASSERT_EQ(db->Exec("PRAGMA wal_checkpoint(TRUNCATE)"), absl::OkStatus());
    auto size = db->PageSize();
    ASSERT_TRUE(size.ok()) << size.status();
    EXPECT_EQ(*size, Db::kNewDatabasePageSize);
    EXPECT_EQ(*db->JournalMode(), "wal");
  }
  EXPECT_EQ(HeaderPageSize(path), Db::kNewDatabasePageSize);
  // Not what SQLite gives a new file by itself, so this test fails if Open does not set it.
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(dir.File("raw.db").c_str(), &raw), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(raw, "PRAGMA page_size", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_NE(sqlite3_column_int(stmt, 0), Db::kNewDatabasePageSize);
  sqlite3_finalize(stmt);
  sqlite3_close(raw);

  // A size asked for explicitly (what audit_bench compares) applies the same way.
  const std::string other = dir.File("u.db");
  auto db = Db::Open(other, Durability::kProcessCrash, 1024);
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE(db->Exec("CREATE TABLE t (x INTEGER)").ok());
  EXPECT_EQ(*db->PageSize(), 1024);
}

// One audited MoveAbsolute by `principal` on a migrated database.
void AppendMove(Db& db, const char* principal) {
  AuditLog log(db);
  AuditEntry e;
  e.principal = principal;
  e.action = "MoveAbsolute";
  ASSERT_EQ(log.Append(e), absl::OkStatus());
  auto report = log.Verify();
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->ok);
}

TEST(DbTest, Open_ExistingDatabase_KeepsItsPageSizeAndItsRows) {
  TempDir dir;
  const std::string path = dir.File("t.db");
  // A gateway's database from before decision 1486: 4096-byte pages, migrated, audited.
  {
    auto db = Db::Open(path, Durability::kProcessCrash, 4096);
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_EQ(Migrate(*db), absl::OkStatus());
    AppendMove(*db, "before");
  }
  ASSERT_EQ(HeaderPageSize(path), 4096);
  for (int page_size : {Db::kNewDatabasePageSize, 1024}) {
    auto db = Db::Open(path, Durability::kProcessCrash, page_size);
    ASSERT_TRUE(db.ok()) << db.status();
    EXPECT_EQ(*db->PageSize(), 4096);
    ASSERT_EQ(Migrate(*db), absl::OkStatus());
    // It stays writable with its own pages, the chain continues, and no VACUUM ran behind the
    // operator's back (the header still says 4096).
    AppendMove(*db, "after");
  }
  EXPECT_EQ(HeaderPageSize(path), 4096);
  auto db = Db::Open(path);
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_EQ(PragmaInt(*db, "SELECT COUNT(*) FROM audit_log WHERE action = 'MoveAbsolute'"), 3);
}

TEST(DbTest, Move_TransfersConnection_MovedFromDestructsSafely) {
  TempDir dir;
  auto opened = Db::Open(dir.File("t.db"));
  ASSERT_TRUE(opened.ok());
  Db a = std::move(*opened);
  ASSERT_TRUE(a.Exec("CREATE TABLE t (x INTEGER)").ok());
  Db b = std::move(a);
  EXPECT_TRUE(b.Exec("INSERT INTO t VALUES (1)").ok());
  EXPECT_EQ(b.path(), dir.File("t.db"));
}

TEST(DbTest, StatementOutlivesDb_CloseIsDeferred) {
  TempDir dir;
  Statement stmt;
  {
    auto db = Db::Open(dir.File("t.db"));
    ASSERT_TRUE(db.ok());
    auto s = db->Prepare("SELECT 7");
    ASSERT_TRUE(s.ok());
    stmt = std::move(*s);
  }
  // sqlite3_close_v2 keeps the connection until the last statement is finalized.
  auto row = stmt.Step();
  ASSERT_TRUE(row.ok() && *row);
  EXPECT_EQ(stmt.ColumnInt(0), 7);
}

}  // namespace
}  // namespace drivegw::storage
