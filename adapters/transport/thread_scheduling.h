// Real-time scheduling of a cyclic I/O thread: SCHED_FIFO priority, CPU affinity and timer slack
// (issue 10, P2; docs/decisions/1311-linudp-io-thread-scheduling.md).
#pragma once

#include <pthread.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace drivegw::transport {

// What a configuration asks for one I/O thread. The default changes nothing: the thread keeps
// the policy, priority and CPUs it inherited from the thread that started it.
struct ThreadScheduling {
  static constexpr int kMaxFifoPriority = 99;  // sched(7): SCHED_FIFO priorities 1..99
  static constexpr int kMaxCpu = 1023;         // CPU_SETSIZE - 1

  int fifo_priority = 0;  // 0: inherited policy; 1..99: SCHED_FIFO at this priority
  std::vector<int> cpus;  // empty: inherited affinity; else the thread runs only on these CPUs

  bool operator==(const ThreadScheduling&) const = default;
  // "io_priority=50 io_cpus=[1,3]" (the config keys, for messages and logs).
  std::string ToString() const;
};

// InvalidArgument naming `where` (e.g. "drive 'x1'.linudp") and the key for a priority outside
// 0..99 or a CPU outside 0..1023 or given twice.
absl::Status ValidateThreadScheduling(const ThreadScheduling& s, absl::string_view where);

// Applies `s` to the running thread `thread`. Never falls back silently: PermissionDenied when
// the process may not use SCHED_FIFO (no CAP_SYS_NICE and RLIMIT_RTPRIO below the priority; the
// message says how to grant it in Docker and Kubernetes), InvalidArgument when no CPU of `cpus`
// is online. A default `s` is OK without a system call.
absl::Status ApplyThreadScheduling(pthread_t thread, const ThreadScheduling& s,
                                   absl::string_view where);

// The calling thread's timer slack to 1 ns (PR_SET_TIMERSLACK, prctl(2)): a thread at the normal
// policy otherwise lets the kernel defer each timed wake-up by up to 50 us to batch it with
// others. SCHED_FIFO threads get no slack anyway. Best effort: prctl cannot fail for this value.
void MinimiseTimerSlack();

// CPU time the calling thread has used (CLOCK_THREAD_CPUTIME_ID). Under KVM with steal-time
// accounting it does not advance while the hypervisor runs something else, so wall time minus
// this over a busy stretch is the time the thread was held off the CPU.
std::chrono::nanoseconds ThreadCpuTime();

// Voluntary context switches of the calling thread so far (getrusage RUSAGE_THREAD ru_nvcsw):
// it advances when the thread blocks (a lock, a full socket), not when it is preempted.
uint64_t ThreadVoluntarySwitches();

}  // namespace drivegw::transport
