// ThreadScheduling: validation, SCHED_FIFO and affinity on a real thread, and the refusal
// without CAP_SYS_NICE (decision 1311: an error naming the fix, never a silent fallback).
#include "adapters/transport/thread_scheduling.h"

#include <gtest/gtest.h>
#include <linux/capability.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <condition_variable>
#include <mutex>
#include <thread>

namespace drivegw::transport {
namespace {

// A thread that waits until released, so that it can be inspected while it runs.
class ParkedThread {
 public:
  ParkedThread()
      : thread_([this] {
          std::unique_lock lock(mu_);
          cv_.wait(lock, [this] { return released_; });
        }) {}
  ~ParkedThread() {
    {
      std::lock_guard lock(mu_);
      released_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  pthread_t handle() { return thread_.native_handle(); }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool released_ = false;
  std::thread thread_;
};

// True when this process may use SCHED_FIFO 1 (root or CAP_SYS_NICE or RLIMIT_RTPRIO >= 1).
bool MayUseFifo() {
  ParkedThread t;
  sched_param p{};
  p.sched_priority = 1;
  return pthread_setschedparam(t.handle(), SCHED_FIFO, &p) == 0;
}

TEST(ThreadScheduling, Validate_Default_Ok) {
  EXPECT_TRUE(ValidateThreadScheduling({}, "drive 'x1'.linudp").ok());
  EXPECT_TRUE(ValidateThreadScheduling({99, {0, 3}}, "drive 'x1'.linudp").ok());
}

TEST(ThreadScheduling, Validate_PriorityOutOfRange_NamesKey) {
  for (int priority : {-1, 100}) {
    const absl::Status s = ValidateThreadScheduling({priority, {}}, "drive 'x1'.linudp");
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find("drive 'x1'.linudp.io_priority"), std::string::npos) << s;
  }
}

TEST(ThreadScheduling, Validate_BadCpus_NamesIndex) {
  const absl::Status negative = ValidateThreadScheduling({0, {0, -1}}, "w");
  EXPECT_EQ(negative.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(negative.message().find("w.io_cpus[1]"), std::string::npos) << negative;
  const absl::Status twice = ValidateThreadScheduling({0, {1, 1}}, "w");
  EXPECT_EQ(twice.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(twice.message().find("given twice"), std::string::npos) << twice;
  EXPECT_EQ(ValidateThreadScheduling({0, {1024}}, "w").code(), absl::StatusCode::kInvalidArgument);
}

TEST(ThreadScheduling, ToString_NamesConfigKeys) {
  EXPECT_EQ((ThreadScheduling{50, {1, 3}}).ToString(), "io_priority=50 io_cpus=[1,3]");
}

TEST(ThreadScheduling, Apply_Default_LeavesThreadAlone) {
  ParkedThread t;
  int policy_before = -1;
  sched_param before{};
  ASSERT_EQ(pthread_getschedparam(t.handle(), &policy_before, &before), 0);
  EXPECT_TRUE(ApplyThreadScheduling(t.handle(), {}, "w").ok());
  int policy = -1;
  sched_param after{};
  ASSERT_EQ(pthread_getschedparam(t.handle(), &policy, &after), 0);
  EXPECT_EQ(policy, policy_before);
}

TEST(ThreadScheduling, Apply_Fifo_ThreadRunsFifo) {
  if (!MayUseFifo()) GTEST_SKIP() << "no CAP_SYS_NICE / RLIMIT_RTPRIO here";
  ParkedThread t;
  ASSERT_TRUE(ApplyThreadScheduling(t.handle(), {7, {}}, "w").ok());
  int policy = -1;
  sched_param p{};
  ASSERT_EQ(pthread_getschedparam(t.handle(), &policy, &p), 0);
  EXPECT_EQ(policy, SCHED_FIFO);
  EXPECT_EQ(p.sched_priority, 7);
}

TEST(ThreadScheduling, Apply_Cpus_ThreadPinned) {
  const int cpu = sched_getcpu();
  ASSERT_GE(cpu, 0);
  ParkedThread t;
  ASSERT_TRUE(ApplyThreadScheduling(t.handle(), {0, {cpu}}, "w").ok());
  cpu_set_t set;
  CPU_ZERO(&set);
  ASSERT_EQ(pthread_getaffinity_np(t.handle(), sizeof(set), &set), 0);
  EXPECT_EQ(CPU_COUNT(&set), 1);
  EXPECT_TRUE(CPU_ISSET(cpu, &set));
}

TEST(ThreadScheduling, Apply_NoSuchCpu_InvalidArgument) {
  ParkedThread t;
  const absl::Status s = ApplyThreadScheduling(t.handle(), {0, {1023}}, "drive 'x1'.linudp");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("drive 'x1'.linudp.io_cpus"), std::string::npos) << s;
}

// Decision 1312 tells a stall from the thread's own work and from blocking with these two.
TEST(ThreadScheduling, ThreadCpuTime_AdvancesWhileSpinningNotWhileSleeping) {
  const auto a = ThreadCpuTime();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto b = ThreadCpuTime();
  EXPECT_LT(b - a, std::chrono::milliseconds(5));
  // Spinning: it advances (waited for with a deadline; on a loaded host the spin gets a share).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (ThreadCpuTime() - b < std::chrono::milliseconds(2) &&
         std::chrono::steady_clock::now() < deadline) {
  }
  EXPECT_GE(ThreadCpuTime() - b, std::chrono::milliseconds(2));
}

TEST(ThreadScheduling, ThreadVoluntarySwitches_AdvanceWhenBlocking) {
  const uint64_t before = ThreadVoluntarySwitches();
  std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_GT(ThreadVoluntarySwitches(), before);
}

// In a child process: drops CAP_SYS_NICE and RLIMIT_RTPRIO (an unprivileged container), asks
// for SCHED_FIFO and returns 0 when that was refused with PermissionDenied naming key and fix.
int RefusedWithoutCapSysNice() {
  const rlimit none{0, 0};
  ::setrlimit(RLIMIT_RTPRIO, &none);
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2]{};
  if (::syscall(SYS_capget, &header, data) != 0) return 2;
  data[CAP_SYS_NICE / 32].effective &= ~(1u << (CAP_SYS_NICE % 32));
  data[CAP_SYS_NICE / 32].permitted &= ~(1u << (CAP_SYS_NICE % 32));
  if (::syscall(SYS_capset, &header, data) != 0) return 3;
  ParkedThread t;
  const absl::Status s = ApplyThreadScheduling(t.handle(), {10, {}}, "drive 'x1'.linudp");
  const bool hint = s.message().find("CAP_SYS_NICE") != std::string::npos &&
                    s.message().find("drive 'x1'.linudp.io_priority") != std::string::npos;
  return s.code() == absl::StatusCode::kPermissionDenied && hint ? 0 : 1;
}

// The refusal is an error naming the fix, the same for root and a normal user (the child drops
// the capability first).
TEST(ThreadSchedulingDeathTest, Apply_FifoWithoutCapSysNice_PermissionDeniedWithHint) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(::_exit(RefusedWithoutCapSysNice()), ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace drivegw::transport
