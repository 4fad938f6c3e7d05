// Soak (issue 11 "Soak", decision 1442): the demo gateway (every family: LinMot LinUDP x1/x2,
// LinMot DeviceNet d1, Trinamic SIXpack feeder-x/feeder-y, STOBER s1, each on its real transport:
// UDP, user-space CAN bus, pty, CANopen bus) has its simulated drives taken offline and back
// online, 1,000 cycles in total; the process's resident memory, open file descriptors and
// threads, sampled after a warm-up and at the end (everything back online), must stay flat.
// DRIVEGW_SOAK_CYCLES=<n> changes the total, DRIVEGW_SOAK_MINUTES=<m> runs for m minutes instead.
//
// Offline is the simulator going silent (the link is cut at the drive's end: LinUDP
// SetAnswering(false), DeviceNet SetDropPolls, Trinamic and STOBER SetSilent); the gateway must
// notice (OFFLINE in GetDrive) and recover (not OFFLINE) on its own each time.
#include <dirent.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <malloc.h>
#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
// Exported by the ASan runtime of both GCC and clang; declared here because GCC 12 does not
// install <sanitizer/allocator_interface.h> (only clang's resource directory has it).
extern "C" size_t __sanitizer_get_current_allocated_bytes();
#endif

#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "adapters/core/log.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/gateway.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/server.h"
#include "sim/stober/server.h"
#include "sim/trinamic/server.h"
#include "tests/reliability/gateway_process.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using drivegw::testing::Eventually;

struct Usage {
  int64_t rss_kb = 0;
  int threads = 0;
  int fds = 0;
  int64_t heap_in_use_kb = 0;  // malloc's bytes in use (mallinfo2): live objects, not arenas
  int64_t sqlite_kb = 0;       // of which SQLite's (page cache, schema, statements)
  std::multiset<std::string> thread_names;  // /proc/self/task/*/comm: who to blame on a change
};

Usage Sample() {
  Usage u;
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) u.rss_kb = std::stoll(line.substr(6));
    if (line.rfind("Threads:", 0) == 0) u.threads = std::stoi(line.substr(8));
  }
#if defined(__SANITIZE_ADDRESS__)
  // ASan owns malloc (mallinfo2 reads zero): its allocator's live bytes, quarantine excluded.
  u.heap_in_use_kb = static_cast<int64_t>(__sanitizer_get_current_allocated_bytes() / 1024);
#else
  const struct mallinfo2 mi = ::mallinfo2();
  u.heap_in_use_kb = static_cast<int64_t>((mi.uordblks + mi.hblkhd) / 1024);
#endif
  u.sqlite_kb = static_cast<int64_t>(sqlite3_memory_used() / 1024);
  if (DIR* d = ::opendir("/proc/self/task")) {
    while (dirent* e = ::readdir(d)) {
      if (e->d_name[0] == '.') continue;
      std::ifstream comm(std::string("/proc/self/task/") + e->d_name + "/comm");
      std::string name;
      std::getline(comm, name);
      u.thread_names.insert(name);
    }
    ::closedir(d);
  }
  if (DIR* d = ::opendir("/proc/self/fd")) {
    while (dirent* e = ::readdir(d)) u.fds += e->d_name[0] != '.' ? 1 : 0;
    ::closedir(d);
    --u.fds;  // the directory stream's own descriptor
  }
  return u;
}

std::ostream& operator<<(std::ostream& o, const Usage& u) {
  return o << "rss " << u.rss_kb << " kB (heap in use " << u.heap_in_use_kb << " kB, SQLite "
           << u.sqlite_kb << " kB), " << u.threads << " threads, " << u.fds << " fds";
}

// gRPC's own executor ("default-executor", grpc/src/core/lib/iomgr/executor.cc, names cut to 15
// characters) starts threads on demand up to max(1, 2 x cores) and keeps them.
std::multiset<std::string> WithoutGrpcExecutor(const Usage& u) {
  std::multiset<std::string> out = u.thread_names;
  out.erase("default-executo");
  return out;
}

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::atoi(v) : fallback;
}

// One simulator and the drives behind it: how to cut and restore its link.
struct Target {
  std::string label;
  std::vector<std::string> drives;
  std::function<void(bool)> set_online;
  int cycles = 0;
};

class SoakTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Every cycle logs two link events per drive: thousands of lines that say nothing new.
    log::SetLevel(log::Level::kError);
    char tmpl[] = "/tmp/drivegw-soak-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    data_dir_ = tmpl;
    std::random_device rd;
    const auto can_port = static_cast<uint16_t>(20000 + rd() % 20000);
    GatewayOptions o;
    o.config.listen.grpc = "127.0.0.1:0";
    o.config.listen.http = "127.0.0.1:0";
    o.config.data_dir = data_dir_;
    o.config.demo = true;
    o.demo_first_port = 0;  // ephemeral simulator ports: ctest runs in parallel
    o.demo_master_port = 0;
    o.demo_can_port = can_port;  // CAN buses of this test's own
    o.demo_canopen_port = static_cast<uint16_t>(can_port + 1);
    auto gw = Gateway::Start(o);
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
    stub_ = v1::DriveService::NewStub(grpc::CreateChannel(
        "127.0.0.1:" + std::to_string(gw_->grpc_port()), grpc::InsecureChannelCredentials()));
  }
  void TearDown() override {
    stub_.reset();
    gw_.reset();
    log::SetLevel(log::Level::kInfo);
    std::filesystem::remove_all(data_dir_);
  }

  bool Offline(const std::string& drive) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 10s);
    v1::GetDriveRequest req;
    req.set_name("drives/" + drive);
    v1::Drive d;
    if (!stub_->GetDrive(&ctx, req, &d).ok()) return false;
    return d.status().state() == v1::OFFLINE;
  }
  bool AllOnline(const std::vector<Target>& targets) {
    for (const auto& t : targets) {
      for (const auto& d : t.drives) {
        if (Offline(d)) return false;
      }
    }
    return true;
  }

  // Cycles every target on its own thread until `total` cycles were done in all (or until
  // `until`); a cycle = cut, OFFLINE seen on every drive of the target, restore, online again.
  void RunCycles(std::vector<Target>& targets, int total,
                 std::chrono::steady_clock::time_point until) {
    std::atomic<int> done{0};
    std::vector<std::thread> threads;
    for (auto& t : targets) {
      threads.emplace_back([&, tp = &t] {
        while (done.load() < total && std::chrono::steady_clock::now() < until) {
          tp->set_online(false);
          const bool down = Eventually(
              [&] {
                for (const auto& d : tp->drives) {
                  if (!Offline(d)) return false;
                }
                return true;
              },
              60s);
          tp->set_online(true);
          const bool up = Eventually(
              [&] {
                for (const auto& d : tp->drives) {
                  if (Offline(d)) return false;
                }
                return true;
              },
              60s);
          EXPECT_TRUE(down) << tp->label << " never went OFFLINE (cycle " << tp->cycles << ")";
          EXPECT_TRUE(up) << tp->label << " never came back (cycle " << tp->cycles << ")";
          if (!down || !up) return;
          ++tp->cycles;
          ++done;
        }
      });
    }
    for (auto& th : threads) th.join();
  }

  std::string data_dir_;
  std::unique_ptr<Gateway> gw_;
  std::unique_ptr<v1::DriveService::Stub> stub_;
};

TEST_F(SoakTest, OfflineOnlineCycles_EveryFamily_RssFdsThreadsFlat) {
  auto* x1 = gw_->demo_simulator("x1");
  auto* x2 = gw_->demo_simulator("x2");
  auto* d1 = gw_->demo_devicenet_simulator("d1");
  auto* pack = gw_->demo_trinamic_simulator();
  auto* s1 = gw_->demo_stober_simulator();
  ASSERT_NE(x1, nullptr);
  ASSERT_NE(x2, nullptr);
  ASSERT_NE(d1, nullptr);
  ASSERT_NE(pack, nullptr);
  ASSERT_NE(s1, nullptr);
  std::vector<Target> targets = {
      {"linudp x1", {"x1"}, [x1](bool on) { x1->SetAnswering(on); }},
      {"linudp x2", {"x2"}, [x2](bool on) { x2->SetAnswering(on); }},
      {"devicenet d1", {"d1"}, [d1](bool on) { d1->SetDropPolls(!on); }},
      {"trinamic pack", {"feeder-x", "feeder-y"}, [pack](bool on) { pack->SetSilent(!on); }},
      {"stober s1", {"s1"}, [s1](bool on) { s1->SetSilent(!on); }},
  };
  ASSERT_TRUE(Eventually([&] { return AllOnline(targets); }, 60s)) << "demo drives not online";
  // DRIVEGW_SOAK_ONLY=<substring>[,<substring>...] cycles only the simulators whose label
  // contains one of them ("linudp", "devicenet", "trinamic", "stober"): to find which family a
  // growth belongs to.
  if (const char* only = std::getenv("DRIVEGW_SOAK_ONLY"); only != nullptr && *only != '\0') {
    std::vector<Target> kept;
    for (auto& t : targets) {
      for (absl::string_view part : absl::StrSplit(only, ',')) {
        if (!part.empty() && absl::StrContains(t.label, part)) {
          kept.push_back(t);
          break;
        }
      }
    }
    ASSERT_FALSE(kept.empty()) << "DRIVEGW_SOAK_ONLY=" << only << " matches no simulator";
    targets = std::move(kept);
  }

  const int total = EnvInt("DRIVEGW_SOAK_CYCLES", 1000);
  const int minutes = EnvInt("DRIVEGW_SOAK_MINUTES", 0);
  // Warm-up: every code path of a cycle has run a few times (allocator arenas, gRPC channel,
  // per-drive buffers), then the first sample.
  const int warmup = std::max(25, total / 10);
  const auto start = std::chrono::steady_clock::now();
  RunCycles(targets, warmup, std::chrono::steady_clock::time_point::max());
  ASSERT_FALSE(HasFailure());
  ASSERT_TRUE(Eventually([&] { return AllOnline(targets); }, 60s));
  const Usage warm = Sample();

  const auto until = minutes > 0 ? std::chrono::steady_clock::now() + std::chrono::minutes(minutes)
                                 : std::chrono::steady_clock::time_point::max();
  RunCycles(targets, minutes > 0 ? std::numeric_limits<int>::max() : total - warmup, until);
  ASSERT_FALSE(HasFailure());
  ASSERT_TRUE(Eventually([&] { return AllOnline(targets); }, 60s));
  // Threads and descriptors of a reconnect (a probe, a back-off timer) may still be winding
  // down right after the last drive came back: wait for them, then compare.
  Usage end = Sample();
  Eventually(
      [&] {
        end = Sample();
        return WithoutGrpcExecutor(end) == WithoutGrpcExecutor(warm) && end.fds <= warm.fds;
      },
      30s);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  int cycles = 0;
  std::ostringstream per;
  for (const auto& t : targets) {
    cycles += t.cycles;
    per << " " << t.label << "=" << t.cycles;
  }
  std::cout << "soak: " << cycles << " cycles in " << seconds << " s;" << per.str() << "\n"
            << "soak: after warm-up " << warm << "\n"
            << "soak: at the end    " << end << "\n";
  if (minutes == 0) {
    EXPECT_GE(cycles, total);
  }
  for (const auto& t : targets) EXPECT_GE(t.cycles, 3) << t.label << " barely cycled";
  // Decision 1442: equal threads and descriptors; resident memory within 8 MiB of the warm
  // sample (allocator arenas and gRPC's slab caches settle within that; a leak of even 1 kB
  // per cycle would exceed it over a long run, and 8 kB per cycle over the CI run).
  std::string names_warm, names_end;
  for (const auto& n : warm.thread_names) names_warm += " " + n;
  for (const auto& n : end.thread_names) names_end += " " + n;
  // gRPC's executor's count follows the load the gRPC client of this test put on it, not the
  // cycles. Every other thread must be there exactly as after the warm-up.
  const auto grpc_executor_max =
      static_cast<size_t>(std::max(1u, 2 * std::thread::hardware_concurrency()));
  EXPECT_EQ(WithoutGrpcExecutor(end), WithoutGrpcExecutor(warm))
      << "warm:" << names_warm << "\nend: " << names_end;
  EXPECT_LE(end.thread_names.count("default-executo"), grpc_executor_max) << names_end;
  EXPECT_EQ(end.fds, warm.fds);
  // Decision 1442: malloc's bytes in use outside SQLite within 1 MiB (live objects: a leak of
  // 1 kB per cycle exceeds it within the CI run); SQLite's own memory is its page cache, which
  // grows with the audit log up to cache_size (2000 KiB per connection, SQLite's default); RSS
  // within 8 MiB (arenas and fragmentation on top of both).
  EXPECT_LT((end.heap_in_use_kb - end.sqlite_kb) - (warm.heap_in_use_kb - warm.sqlite_kb), 1024)
      << "warm " << warm << "; end " << end;
  EXPECT_LT(end.sqlite_kb, 4 * 2000 + 1024) << "SQLite above its page caches";
#if defined(__SANITIZE_ADDRESS__)
  // Under ASan RSS holds the quarantine of freed blocks (up to 256 MiB) and shadow memory, so it
  // grows by design; the live-byte bound above and LeakSanitizer at exit judge leaks there.
  std::cout << "soak: RSS not bounded under ASan (quarantine); warm " << warm << "; end " << end
            << "\n";
#else
  EXPECT_LT(end.rss_kb - warm.rss_kb, 8 * 1024) << "warm " << warm << "; end " << end;
#endif
}

}  // namespace
}  // namespace drivegw::server
