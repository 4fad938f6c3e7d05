// The audit chain survives kill -9 mid-write (issue 7 "Tests"): a child process appends in a
// loop on its own connection, is killed with SIGKILL, and the chain still verifies; appends
// then continue it.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "storage/audit_log.h"
#include "storage/migrations.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::storage {
namespace {

using testing::MakeEntry;
using testing::TempDir;

// The child: appends until killed. Large bodies make each transaction write several pages, so
// the kill lands inside one more often than not. Never returns.
[[noreturn]] void AppendForever(const std::string& path) {
  auto db = Db::Open(path);
  if (!db.ok()) _exit(2);
  AuditLog log(*db);
  const std::string padding(16 * 1024, 'p');
  for (int64_t i = 0;; ++i) {
    AuditEntry e = MakeEntry("x1", "MoveAbsolute");
    e.request_json = absl::StrCat("{\"i\":", i, ",\"padding\":\"", padding, "\"}");
    if (!log.Append(e).ok()) _exit(3);
  }
}

int64_t CountRows(const std::string& path) {
  auto db = Db::Open(path);
  if (!db.ok()) return -1;
  AuditLog log(*db);
  auto n = log.Count();
  return n.ok() ? *n : -1;
}

TEST(AuditKillTest, SigkillDuringAppends_ChainStaysIntactAndContinues) {
  TempDir dir;
  const std::string path = dir.File("audit.db");
  {
    auto db = Db::Open(path);
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE(Migrate(*db).ok());
  }  // closed before fork: the child opens its own connection
  int64_t expected_at_least = 0;
  for (int round = 0; round < 3; ++round) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0) << "fork failed";
    if (pid == 0) AppendForever(path);
    // Let the child get well into its loop (another process: no in-process signal to wait on,
    // so poll the row count with a deadline).
    const int64_t target = expected_at_least + 40 + 25 * round;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    int64_t n = 0;
    while ((n = CountRows(path)) < target && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_EQ(kill(pid, SIGKILL), 0);
    int wstatus = 0;
    ASSERT_EQ(waitpid(pid, &wstatus, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(wstatus)) << "child exited with " << WEXITSTATUS(wstatus);
    EXPECT_EQ(WTERMSIG(wstatus), SIGKILL);
    ASSERT_GE(n, target) << "the child appended too slowly (round " << round << ")";

    auto db = Db::Open(path);
    ASSERT_TRUE(db.ok()) << db.status();
    AuditLog log(*db);
    auto v = log.Verify();
    ASSERT_TRUE(v.ok()) << v.status();
    EXPECT_TRUE(v->ok) << "round " << round << ": " << v->broken->field << " at seq "
                       << v->broken->seq << ": " << v->broken->message;
    EXPECT_GE(v->verified_entries, target);
    // The parent continues the chain where the killed child left it.
    ASSERT_TRUE(log.Append(MakeEntry("x1", "Stop")).ok());
    auto again = log.Verify();
    ASSERT_TRUE(again.ok());
    EXPECT_TRUE(again->ok);
    EXPECT_EQ(again->last_seq, v->last_seq + 1);
    expected_at_least = again->verified_entries;
  }
}

}  // namespace
}  // namespace drivegw::storage
