// Latency and CPU of one benchmark row: each call's wall time (steady clock) and the whole
// process's CPU time and context switches (getrusage) around the timed calls, after a warm-up
// (issue 10 P1: a move's cost is CPU spread over many threads, docs/performance.md "CPU per move").
#pragma once

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <vector>

namespace drivegw::bench {

// getrusage(RUSAGE_SELF): every thread of the process, the gateway's and the simulators' included.
struct Usage {
  double cpu_s = 0, wall_s = 0;
  long voluntary_switches = 0, involuntary_switches = 0;

  static Usage Now() {
    rusage ru{};
    ::getrusage(RUSAGE_SELF, &ru);
    auto seconds = [](const timeval& tv) {
      return static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
    };
    return {
        seconds(ru.ru_utime) + seconds(ru.ru_stime),
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(),
        ru.ru_nvcsw, ru.ru_nivcsw};
  }
  Usage operator-(const Usage& o) const {
    return {cpu_s - o.cpu_s, wall_s - o.wall_s, voluntary_switches - o.voluntary_switches,
            involuntary_switches - o.involuntary_switches};
  }
  Usage& operator+=(const Usage& o) {
    cpu_s += o.cpu_s;
    wall_s += o.wall_s;
    voluntary_switches += o.voluntary_switches;
    involuntary_switches += o.involuntary_switches;
    return *this;
  }
};

// One row's samples, appended to over the interleaved rounds.
struct Row {
  std::vector<double> us;  // wall time per counted call
  Usage usage;             // summed over the timed windows
  long calls = 0;          // calls inside the timed windows (failed ones included)

  Row& operator+=(const Row& o) {
    us.insert(us.end(), o.us.begin(), o.us.end());
    usage += o.usage;
    calls += o.calls;
    return *this;
  }
  double CpuUsPerCall() const { return calls ? usage.cpu_s * 1e6 / static_cast<double>(calls) : 0; }
  double SwitchesPerCall() const {
    return calls ? static_cast<double>(usage.voluntary_switches + usage.involuntary_switches) /
                       static_cast<double>(calls)
                 : 0;
  }
};

struct Percentiles {
  double p50_us = 0, p99_us = 0;
};

inline Percentiles Summarize(std::vector<double> us) {
  if (us.empty()) return {};
  std::sort(us.begin(), us.end());
  auto at = [&](double q) {
    return us[static_cast<size_t>(q * static_cast<double>(us.size() - 1))];
  };
  return {at(0.50), at(0.99)};
}

constexpr int kWarmupCalls = 50;

// Runs `call(i)` for i in [0, kWarmupCalls + n): the first kWarmupCalls untimed, then n timed
// with the process's usage sampled around them. `call` returns false for a failed call, which is
// not timed (it still counts in the CPU window).
template <typename Call>
Row TimeCalls(int n, Call call) {
  Row row;
  for (int i = 0; i < kWarmupCalls; ++i) call(i);
  const Usage before = Usage::Now();
  for (int i = kWarmupCalls; i < kWarmupCalls + n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const bool ok = call(i);
    const auto t1 = std::chrono::steady_clock::now();
    if (ok) row.us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  row.usage = Usage::Now() - before;
  row.calls = n;
  return row;
}

}  // namespace drivegw::bench
