// Background WAL checkpoints for one database file: commits on the gateway's connection only
// signal; a thread with a connection of its own copies the WAL into the database (decision 1352).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/statusor.h"

struct sqlite3;

namespace drivegw::storage {

class WalCheckpointer {
 public:
  // SQLite's own auto-checkpoint threshold (wal_autocheckpoint default): the thread is asked
  // for a checkpoint after a commit leaves at least this many frames in the WAL.
  static constexpr int kSignalFrames = 1000;
  // If the thread falls this far behind, the committing connection checkpoints itself, as
  // SQLite's default hook would (bounds the WAL at ~16 MiB of 4 KiB pages).
  static constexpr int kInlineFrames = 4000;

  // Opens the second connection to `path` (which must exist, in WAL mode) and starts the thread.
  static absl::StatusOr<std::unique_ptr<WalCheckpointer>> Start(const std::string& path);
  ~WalCheckpointer();  // stops and joins the thread, closes its connection
  WalCheckpointer(const WalCheckpointer&) = delete;
  WalCheckpointer& operator=(const WalCheckpointer&) = delete;

  // Installs the commit hook on `db` (replacing SQLite's auto-checkpoint hook there). `db` must
  // be detached (Detach) before this object is destroyed.
  void Attach(sqlite3* db);
  static void Detach(sqlite3* db);

  // Checkpoints run by the thread, and inline by a committing connection (the fallback).
  int64_t background_checkpoints() const;
  int64_t inline_checkpoints() const;

 private:
  explicit WalCheckpointer(sqlite3* own);
  static int OnCommit(void* self, sqlite3* db, const char* schema, int frames);
  void Run();

  sqlite3* own_;  // the thread's connection
  mutable std::mutex mu_;
  std::condition_variable wake_;
  bool requested_ = false;  // guarded by mu_
  bool stopping_ = false;   // guarded by mu_
  int64_t background_ = 0;  // guarded by mu_
  int64_t inline_ = 0;      // guarded by mu_
  std::thread thread_;
};

}  // namespace drivegw::storage
