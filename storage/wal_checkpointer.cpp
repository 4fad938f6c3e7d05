// WalCheckpointer: the commit hook signals, the thread runs PASSIVE checkpoints (decision 1352).
#include "storage/wal_checkpointer.h"

#include <sqlite3.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"

namespace drivegw::storage {

absl::StatusOr<std::unique_ptr<WalCheckpointer>> WalCheckpointer::Start(const std::string& path) {
  sqlite3* own = nullptr;
  // No CREATE: the gateway's connection made the file and switched it to WAL already.
  const int rc =
      sqlite3_open_v2(path.c_str(), &own, SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    absl::Status s = absl::FailedPreconditionError(
        absl::StrCat("storage: checkpoint connection: ", sqlite3_errstr(rc), " (path=", path, ")"));
    sqlite3_close_v2(own);
    return s;
  }
  // The thread's own commits (none) must not checkpoint; it only runs explicit checkpoints.
  sqlite3_wal_autocheckpoint(own, 0);
  std::unique_ptr<WalCheckpointer> c(new WalCheckpointer(own));
  c->thread_ = std::thread([p = c.get()] { p->Run(); });
  return c;
}

WalCheckpointer::WalCheckpointer(sqlite3* own) : own_(own) {}

WalCheckpointer::~WalCheckpointer() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
  sqlite3_close_v2(own_);
}

void WalCheckpointer::Attach(sqlite3* db) {
  sqlite3_wal_hook(db, &WalCheckpointer::OnCommit, this);
}

void WalCheckpointer::Detach(sqlite3* db) {
  // Back to SQLite's default hook and threshold.
  sqlite3_wal_autocheckpoint(db, kSignalFrames);
}

int WalCheckpointer::OnCommit(void* self, sqlite3* db, const char* schema, int frames) {
  // Runs on the committing thread after COMMIT wrote the WAL, with the transaction's locks
  // released: only a signal here, so no commit waits for a checkpoint's fsyncs.
  auto* c = static_cast<WalCheckpointer*>(self);
  if (frames < kSignalFrames) return SQLITE_OK;
  if (frames >= kInlineFrames) {
    // The thread fell behind (or a checkpoint never caught up with the writers): do what
    // SQLite's default hook does, so the WAL stays bounded.
    sqlite3_wal_checkpoint_v2(db, schema, SQLITE_CHECKPOINT_PASSIVE, nullptr, nullptr);
    std::lock_guard lock(c->mu_);
    ++c->inline_;
    return SQLITE_OK;
  }
  {
    std::lock_guard lock(c->mu_);
    c->requested_ = true;
  }
  c->wake_.notify_one();
  return SQLITE_OK;
}

void WalCheckpointer::Run() {
  std::unique_lock lock(mu_);
  while (true) {
    wake_.wait(lock, [&] { return requested_ || stopping_; });
    if (stopping_) return;
    requested_ = false;
    lock.unlock();
    // PASSIVE never waits for readers or writers: it copies what it can and fsyncs; a writer
    // that later finds every frame copied restarts the WAL from its beginning.
    int log_frames = 0, copied = 0;
    const int rc =
        sqlite3_wal_checkpoint_v2(own_, nullptr, SQLITE_CHECKPOINT_PASSIVE, &log_frames, &copied);
    if (rc != SQLITE_OK && rc != SQLITE_BUSY) {
      log::Warn("storage.checkpoint",
                log::Fields().Add("error", sqlite3_errmsg(own_)).Add("code", rc));
    }
    lock.lock();
    ++background_;
  }
}

int64_t WalCheckpointer::background_checkpoints() const {
  std::lock_guard lock(mu_);
  return background_;
}

int64_t WalCheckpointer::inline_checkpoints() const {
  std::lock_guard lock(mu_);
  return inline_;
}

}  // namespace drivegw::storage
