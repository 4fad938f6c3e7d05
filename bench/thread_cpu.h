// CPU seconds per thread name of this process (or another one), from /proc/<pid>/task/*/stat:
// which threads a benchmark's CPU went to (P5: gRPC's callback threads against the watch ticker
// and the rest, decision 1372). Threads that ended between two samples are missing from the later
// one, so a difference is only meaningful for threads that live through the window.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace drivegw::bench {

using ThreadCpu = std::map<std::string, double>;  // thread name -> CPU seconds, summed

inline ThreadCpu SampleThreadCpu(const std::string& pid = "self") {
  ThreadCpu out;
  const double tick = static_cast<double>(::sysconf(_SC_CLK_TCK));
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + pid + "/task", ec)) {
    std::ifstream f(task.path() / "stat");
    std::string line;
    if (!std::getline(f, line)) continue;
    // "tid (comm) state ppid ...": comm may hold spaces and parentheses, the last ')' ends it.
    const auto open = line.find('('), close = line.rfind(')');
    if (open == std::string::npos || close == std::string::npos || close < open) continue;
    std::istringstream rest(line.substr(close + 2));
    std::string field;
    double utime = 0, stime = 0;
    // Fields 3.. follow the comm; utime and stime are fields 14 and 15 (proc(5)).
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stod(field);
      if (i == 15) stime = std::stod(field);
    }
    out[line.substr(open + 1, close - open - 1)] += (utime + stime) / tick;
  }
  return out;
}

// after - before, per name (names only in `after` count from 0).
inline ThreadCpu Difference(const ThreadCpu& after, const ThreadCpu& before) {
  ThreadCpu d;
  for (const auto& [name, s] : after) {
    auto it = before.find(name);
    d[name] = s - (it == before.end() ? 0 : it->second);
  }
  return d;
}

}  // namespace drivegw::bench
