// ThreadScheduling: pthread_setschedparam / pthread_setaffinity_np / PR_SET_TIMERSLACK.
#include "adapters/transport/thread_scheduling.h"

#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace drivegw::transport {

std::string ThreadScheduling::ToString() const {
  return absl::StrCat("io_priority=", fifo_priority, " io_cpus=[", absl::StrJoin(cpus, ","), "]");
}

absl::Status ValidateThreadScheduling(const ThreadScheduling& s, absl::string_view where) {
  if (s.fifo_priority < 0 || s.fifo_priority > ThreadScheduling::kMaxFifoPriority) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".io_priority: ", s.fifo_priority, " is outside 0..",
                     ThreadScheduling::kMaxFifoPriority, " (0 = normal scheduling)"));
  }
  for (size_t i = 0; i < s.cpus.size(); ++i) {
    const int cpu = s.cpus[i];
    if (cpu < 0 || cpu > ThreadScheduling::kMaxCpu) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".io_cpus[", i, "]: ", cpu,
                                                     " is outside 0..", ThreadScheduling::kMaxCpu));
    }
    if (std::find(s.cpus.begin(), s.cpus.begin() + static_cast<std::ptrdiff_t>(i), cpu) !=
        s.cpus.begin() + static_cast<std::ptrdiff_t>(i)) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".io_cpus[", i, "]: CPU ", cpu, " is given twice"));
    }
  }
  return absl::OkStatus();
}

absl::Status ApplyThreadScheduling(pthread_t thread, const ThreadScheduling& s,
                                   absl::string_view where) {
  if (absl::Status v = ValidateThreadScheduling(s, where); !v.ok()) return v;
  if (!s.cpus.empty()) {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int cpu : s.cpus) CPU_SET(cpu, &set);
    if (const int err = pthread_setaffinity_np(thread, sizeof(set), &set); err != 0) {
      // EINVAL: none of the CPUs is online (or allowed by the cpuset cgroup).
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".io_cpus: [", absl::StrJoin(s.cpus, ","), "]: ", std::strerror(err),
                       " (no such CPU online?)"));
    }
  }
  if (s.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = s.fifo_priority;
    if (const int err = pthread_setschedparam(thread, SCHED_FIFO, &param); err != 0) {
      // sched(7): SCHED_FIFO needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least the priority.
      // The operator asked for real-time behaviour; running without it would hide the problem
      // until cycles are late, so the drive does not activate (decision 1311).
      const std::string text = absl::StrCat(
          where, ".io_priority: SCHED_FIFO priority ", s.fifo_priority,
          " refused: ", std::strerror(err),
          " (grant CAP_SYS_NICE: docker run --cap-add SYS_NICE, compose cap_add: [SYS_NICE], "
          "Kubernetes securityContext.capabilities.add: [SYS_NICE]; or raise RLIMIT_RTPRIO; "
          "or set io_priority 0)");
      return err == EPERM ? absl::PermissionDeniedError(text) : absl::InvalidArgumentError(text);
    }
  }
  return absl::OkStatus();
}

void MinimiseTimerSlack() {
  // prctl(2): a value of 0 would reset to the default slack; 1 ns is the smallest real setting.
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
}

std::chrono::nanoseconds ThreadCpuTime() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return std::chrono::seconds(t.tv_sec) + std::chrono::nanoseconds(t.tv_nsec);
}

uint64_t ThreadVoluntarySwitches() {
  rusage u{};
  ::getrusage(RUSAGE_THREAD, &u);
  return static_cast<uint64_t>(u.ru_nvcsw);
}

}  // namespace drivegw::transport
