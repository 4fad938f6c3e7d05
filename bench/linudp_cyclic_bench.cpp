// Cyclic LinUDP exchange with N simulated drives at a 2 ms cycle (issue 10, P2).
//
// Gateway side: N LinMotUdpDrive objects built by the family factory exactly as the gateway builds
// them (linudp.cycle = 2 ms, one shared master socket bind_host:master_port, A-01), polling N
// simulated drives that run in SEPARATE processes (`drivegw-sim linmot --count ...`, started here
// with fork/exec) so that this process's CPU time is the gateway's alone.
// Baseline, same run, same simulator processes: a bare one-thread UDP request/response loop
// (non-blocking socket + ppoll, one sendto/recvfrom per telegram, same request and reply bytes,
// same N destinations, same 2 ms grid), no LinUDP stack.
//
// Late cycle (both sides, identical definition; linmot-linudp.md A-07 "at most one outstanding
// request per drive ... not before the cycle period", A-10 cycle per drive): every drive has a
// fixed grid of 2 ms periods; a period is MET when a request sent at or after the period's start
// got its valid reply before the period's end, otherwise it is LATE (reply too late, time-out, or
// no request left in that period because the loop was behind). The gateway counts this in its
// session (ExchangeCounters::cycles / late_cycles), the bare loop the same way here.
//
// Output: a table per N and @result lines (bench/report.h):
//   P2 max_drives_2ms          largest N with < 0.1 % late cycles           target >= 200
//   P2 cpu_per_telegram_ratio  gateway CPU / bare-loop CPU per exchange at N = 200 (or the
//                              largest N measured)                          target <= 2
// Run: build/bench/linudp_cyclic_bench [seconds per N = 5] [N list = 25,50,100,200,300,400] [rt]
// `rt` runs this process and the simulators under SCHED_FIFO (priority 10, inherited by every
// thread and by the fork/exec'ed simulators), as [RC] runs its 1.1 ms LinUDP loop
// (linmot-linudp.md 6.5), and gives the gateway's drives linudp.io_priority 10 (decision 1311):
// on this shared 2-core VM, with other builds at load 8-10, both the gateway and the bare loop
// otherwise wait for a CPU longer than the 2 ms cycle. Gateway and baseline get the same
// priority; the kernel's RT throttling (sched_rt_runtime_us) still leaves 5 % to everyone else.
// The run of record uses `rt` (bench/list.txt, decision 1311).
//
// Why a period was late (decision 1312), per N and side: "run%" are the late periods while the
// loop's own thread was running (not stalled > 500 us past its wake-up time; the session counts
// late_cycles_stalled, the bare loop the same way here), and a host probe (a thread that only
// wakes on the 2 ms grid, same priority) runs alongside every window with the hypervisor's steal
// time, so each row shows what the host alone lost at that moment.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/log.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/transport/thread_scheduling.h"
#include "bench/report.h"

#ifndef DGW_SIM_BIN
#define DGW_SIM_BIN "sim/drivegw-sim"
#endif

namespace {

namespace linudp = drivegw::linmot::linudp;
using namespace std::chrono_literals;
using SteadyClock = std::chrono::steady_clock;

constexpr auto kCycle = 2ms;
constexpr auto kReplyTimeout = 50ms;   // A-10 default
constexpr int kMaxDrivesPerSim = 256;  // drivegw-sim linmot --count limit
constexpr uint32_t kLoopback = 0x7F000001;
constexpr int kRtPriority = 10;  // `rt`: SCHED_FIFO priority of both sides and the simulators
// The session's threshold for a stall of its I/O thread (session.cpp, decision 1312).
constexpr auto kStallThreshold = 500us;

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + t.tv_usec * 1e-6; };
  return s(u.ru_utime) + s(u.ru_stime);
}

// utime + stime of another process (/proc/PID/stat fields 14, 15), seconds.
double ProcessCpuSeconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(f, line);
  const size_t close = line.rfind(')');  // the command name may contain spaces
  if (close == std::string::npos) return 0;
  std::istringstream rest(line.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::stod(field);
  }
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

double LoadAverage() {
  double l = 0;
  std::ifstream("/proc/loadavg") >> l;
  return l;
}

// True when UDP 127.0.0.1:port can be bound right now (checked, then released).
bool PortFree(uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(kLoopback);
  sa.sin_port = htons(port);
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
  ::close(fd);
  return ok;
}

// One drivegw-sim linmot process serving `count` drives on ports base, base+1, ...
class SimProcess {
 public:
  static std::unique_ptr<SimProcess> Start(uint16_t base, int count, uint16_t master_port) {
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) return nullptr;
    const std::string bin = std::getenv("DRIVEGW_SIM") ? std::getenv("DRIVEGW_SIM") : DGW_SIM_BIN;
    const std::string port = std::to_string(base), n = std::to_string(count),
                      master = std::to_string(master_port);
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::dup2(out[1], STDOUT_FILENO);
      ::dup2(out[1], STDERR_FILENO);
      ::setenv("DRIVEGW_LOG_LEVEL", "warn", 1);
      ::execl(bin.c_str(), bin.c_str(), "linmot", "--host", "127.0.0.1", "--port", port.c_str(),
              "--count", n.c_str(), "--master-port", master.c_str(), "--name", "b",
              static_cast<char*>(nullptr));
      std::perror(bin.c_str());
      ::_exit(127);
    }
    ::close(out[1]);
    auto p = std::unique_ptr<SimProcess>(new SimProcess(pid, out[0]));
    if (pid < 0 || !p->WaitListening(count)) return nullptr;
    return p;
  }
  ~SimProcess() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    ::close(fd_);
  }
  pid_t pid() const { return pid_; }

 private:
  SimProcess(pid_t pid, int fd) : pid_(pid), fd_(fd) {}
  // Reads the banner until every drive printed "listening on" (bind errors end the process).
  bool WaitListening(int count) {
    std::string buffer;
    int listening = 0;
    char chunk[4096];
    while (listening < count) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 10000) <= 0) break;
      const ssize_t got = ::read(fd_, chunk, sizeof(chunk));
      if (got <= 0) break;
      buffer.append(chunk, static_cast<size_t>(got));
      size_t nl;
      while ((nl = buffer.find('\n')) != std::string::npos) {
        const std::string line = buffer.substr(0, nl);
        if (line.starts_with("linmot ") && line.find(" listening on ") != std::string::npos) {
          ++listening;
        } else {
          last_line_ = line;
        }
        buffer.erase(0, nl + 1);
      }
    }
    if (listening < count) std::fprintf(stderr, "sim: %s\n", last_line_.c_str());
    return listening == count;
  }
  pid_t pid_;
  int fd_;
  std::string last_line_;
};

// The simulated drives of one N: ceil(N / 256) processes on consecutive ports.
struct SimFarm {
  uint16_t base = 0;
  uint16_t master_port = 0;
  std::vector<std::unique_ptr<SimProcess>> processes;
  double CpuSeconds() const {
    double s = 0;
    for (const auto& p : processes) s += ProcessCpuSeconds(p->pid());
    return s;
  }
};

std::optional<SimFarm> StartSims(int n, std::mt19937& rng) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    SimFarm farm;
    // Below the kernel's ephemeral range (32768+) so that other tests' sockets rarely collide.
    farm.base = static_cast<uint16_t>(std::uniform_int_distribution<int>(20000, 31000 - n)(rng));
    farm.master_port = static_cast<uint16_t>(farm.base + n + 1);
    bool free = PortFree(farm.master_port);
    for (int i = 0; free && i < n; ++i) free = PortFree(static_cast<uint16_t>(farm.base + i));
    if (!free) continue;
    bool ok = true;
    for (int first = 0; ok && first < n; first += kMaxDrivesPerSim) {
      const int count = std::min(kMaxDrivesPerSim, n - first);
      auto p = SimProcess::Start(static_cast<uint16_t>(farm.base + first), count, farm.master_port);
      ok = p != nullptr;
      if (ok) farm.processes.push_back(std::move(p));
    }
    if (ok) return farm;
  }
  return std::nullopt;
}

struct Window {
  double seconds = 0;
  uint64_t exchanges = 0;  // valid replies
  uint64_t sent = 0;
  uint64_t timeouts = 0;
  uint64_t cycles = 0;
  uint64_t late = 0;
  uint64_t late_stalled = 0;  // late periods overlapping a stall of the loop's own thread
  double cpu_s = 0;           // this process
  double sim_cpu_s = 0;       // the simulator processes
  double load = 0;
  // The host during this very window (HostProbe, same priority, running alongside): what a
  // loop that does nothing but wake on the 2 ms grid lost, and the hypervisor's steal time.
  uint64_t host_wakeups = 0;
  uint64_t host_late = 0;    // wake-ups more than 1 ms (half a cycle) late
  double host_stall_ms = 0;  // sum of the lateness of those wake-ups
  double host_max_late_us = 0;
  double steal_ms = 0;  // /proc/stat steal, all CPUs
  double host_late_pct() const {
    return host_wakeups ? 100.0 * static_cast<double>(host_late) / static_cast<double>(host_wakeups)
                        : 0;
  }
  double late_pct() const {
    return cycles ? 100.0 * static_cast<double>(late) / static_cast<double>(cycles) : 100.0;
  }
  // Late periods while the loop's thread was running: what the exchange itself missed.
  double late_unstalled_pct() const {
    return cycles ? 100.0 * static_cast<double>(late - late_stalled) / static_cast<double>(cycles)
                  : 100.0;
  }
  double cpu_us_per_exchange() const {
    return exchanges ? cpu_s * 1e6 / static_cast<double>(exchanges) : 0;
  }
  double sim_us_per_exchange() const {
    return exchanges ? sim_cpu_s * 1e6 / static_cast<double>(exchanges) : 0;
  }
};

// The host alone: a thread that only sleeps to an absolute 2 ms grid (clock_nanosleep) and
// records how late it wakes, at the same priority as the two sides. No network, no LinUDP: the
// fraction of wake-ups late by more than half a cycle bounds what any 2 ms loop can meet here.
struct HostProbe {
  uint64_t wakeups = 0;
  uint64_t late_half_cycle = 0;  // woke more than 1 ms after its grid point
  double late_sum_us = 0;        // summed lateness of those wake-ups
  double max_late_us = 0;
  double late_pct() const {
    return wakeups ? 100.0 * static_cast<double>(late_half_cycle) / static_cast<double>(wakeups)
                   : 0;
  }
};

HostProbe ProbeHostUntil(SteadyClock::time_point end) {
  HostProbe h;
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  while (SteadyClock::now() < end) {
    next.tv_nsec += std::chrono::nanoseconds(kCycle).count();
    if (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const double late_us = static_cast<double>(now.tv_sec - next.tv_sec) * 1e6 +
                           static_cast<double>(now.tv_nsec - next.tv_nsec) / 1e3;
    ++h.wakeups;
    if (late_us > 1000) {
      ++h.late_half_cycle;
      h.late_sum_us += late_us;
    }
    h.max_late_us = std::max(h.max_late_us, late_us);
  }
  return h;
}

HostProbe ProbeHost(double seconds) {
  return ProbeHostUntil(SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                 std::chrono::duration<double>(seconds)));
}

// Steal time of the whole machine (/proc/stat "cpu" line, 8th value): time the hypervisor ran
// something else while a virtual CPU of this guest wanted to run. Milliseconds.
double StealMs() {
  std::ifstream f("/proc/stat");
  std::string cpu;
  double v[8] = {};
  f >> cpu;
  for (double& x : v) f >> x;
  return v[7] * 1000.0 / static_cast<double>(sysconf(_SC_CLK_TCK));
}

void AddHost(Window& w, const HostProbe& h, double steal_ms) {
  w.host_wakeups = h.wakeups;
  w.host_late = h.late_half_cycle;
  w.host_stall_ms = h.late_sum_us / 1000.0;
  w.host_max_late_us = h.max_late_us;
  w.steal_ms = steal_ms;
}

// ---- gateway side -------------------------------------------------------------------------

drivegw::DriveConfig DriveConfigFor(int i, const SimFarm& farm, int io_priority) {
  drivegw::DriveConfig c;
  c.name = "b" + std::to_string(i + 1);
  c.family = "linmot";
  c.axis.min_mm = 0;
  c.axis.max_mm = 150;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 20000;
  drivegw::LinUdpConfig l;
  l.host = "127.0.0.1";
  l.port = static_cast<uint16_t>(farm.base + i);
  l.bind_host = "127.0.0.1";
  l.master_port = farm.master_port;
  l.cycle = kCycle;
  l.reply_timeout = kReplyTimeout;
  // `rt`: the I/O thread's SCHED_FIFO priority set the way an installation sets it
  // (linudp.io_priority, decision 1311), the same priority the bare loop runs at.
  l.io_priority = io_priority;
  c.linudp = l;
  return c;
}

struct Totals {
  uint64_t replies = 0, sent = 0, timeouts = 0, cycles = 0, late = 0, late_stalled = 0;
};

Totals Sum(const std::vector<std::unique_ptr<drivegw::Drive>>& drives) {
  Totals t;
  for (const auto& d : drives) {
    const auto c = static_cast<const linudp::LinMotUdpDrive&>(*d).exchange_counters();
    if (!c) continue;
    t.replies += c->replies;
    t.sent += c->telegrams_sent;
    t.timeouts += c->timeouts;
    t.cycles += c->cycles;
    t.late += c->late_cycles;
    t.late_stalled += c->late_cycles_stalled;
  }
  return t;
}

std::optional<Window> MeasureGateway(int n, const SimFarm& farm, double seconds, int io_priority) {
  std::vector<std::unique_ptr<drivegw::Drive>> drives;
  for (int i = 0; i < n; ++i) {
    auto d = linudp::CreateLinMotUdpDrive(DriveConfigFor(i, farm, io_priority),
                                          drivegw::SteadyClock::Instance());
    if (!d.ok()) {
      std::fprintf(stderr, "drive: %s\n", std::string(d.status().message()).c_str());
      return std::nullopt;
    }
    if (auto s = (*d)->Activate(); !s.ok()) {
      std::fprintf(stderr, "activate: %s\n", std::string(s.message()).c_str());
      return std::nullopt;
    }
    drives.push_back(std::move(*d));
  }
  // Every drive answered at least once, then a short warm-up.
  const auto online_by = SteadyClock::now() + 10s;
  for (;;) {
    bool all = true;
    for (const auto& d : drives) {
      const auto c = static_cast<const linudp::LinMotUdpDrive&>(*d).exchange_counters();
      all = all && c && c->replies > 0;
    }
    if (all) break;
    if (SteadyClock::now() > online_by) {
      std::fprintf(stderr, "gateway: not every drive answered within 10 s\n");
      return std::nullopt;
    }
    std::this_thread::sleep_for(10ms);
  }
  std::this_thread::sleep_for(300ms);
  const Totals a = Sum(drives);
  const double cpu_a = CpuSeconds(), sim_a = farm.CpuSeconds(), steal_a = StealMs();
  const auto t_a = SteadyClock::now();
  // This thread would only sleep through the window: it probes the host instead.
  const HostProbe host = ProbeHostUntil(t_a + std::chrono::duration_cast<SteadyClock::duration>(
                                                  std::chrono::duration<double>(seconds)));
  const Totals b = Sum(drives);
  const double cpu_b = CpuSeconds(), sim_b = farm.CpuSeconds(), steal_b = StealMs();
  const auto t_b = SteadyClock::now();
  Window w;
  w.seconds = std::chrono::duration<double>(t_b - t_a).count();
  w.exchanges = b.replies - a.replies;
  w.sent = b.sent - a.sent;
  w.timeouts = b.timeouts - a.timeouts;
  w.cycles = b.cycles - a.cycles;
  w.late = b.late - a.late;
  w.late_stalled = b.late_stalled - a.late_stalled;
  w.cpu_s = cpu_b - cpu_a;
  w.sim_cpu_s = sim_b - sim_a;
  w.load = LoadAverage();
  AddHost(w, host, steal_b - steal_a);
  for (auto& d : drives) d->Deactivate();  // the last one closes the shared master socket
  return w;
}

// ---- baseline: bare request/response loop ---------------------------------------------------

std::optional<Window> MeasureBareLoop(int n, const SimFarm& farm, double seconds) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_addr.s_addr = htonl(kLoopback);
  local.sin_port = htons(farm.master_port);
  // The gateway's session released the master port when its last drive deactivated.
  bool bound = false;
  for (int i = 0; i < 100 && !bound; ++i) {
    bound = ::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof(local)) == 0;
    if (!bound) std::this_thread::sleep_for(10ms);
  }
  if (!bound) {
    std::fprintf(stderr, "bare loop: bind %u: %s\n", farm.master_port, std::strerror(errno));
    ::close(fd);
    return std::nullopt;
  }
  // The very bytes an idle gateway drive sends (no control word before an operation, §6.8).
  linudp::Request idle;
  idle.response_definition = linudp::kRespStandard | linudp::kRespRtc;
  const std::vector<uint8_t> request = linudp::EncodeRequest(idle);
  const size_t reply_size = linudp::ResponseLayoutSize(idle.response_definition);

  std::vector<sockaddr_in> to(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    to[i].sin_family = AF_INET;
    to[i].sin_addr.s_addr = htonl(kLoopback);
    to[i].sin_port = htons(static_cast<uint16_t>(farm.base + i));
  }
  struct State {
    bool outstanding = false, sent_in_period = false, met = false;
    SteadyClock::time_point sent_at{};
  };
  std::vector<State> st(static_cast<size_t>(n));
  Window w;
  bool measuring = false;
  uint64_t sent = 0, replies = 0, timeouts = 0, cycles = 0, late = 0, late_stalled = 0;
  // The last stall of this thread, detected as the session detects its own (decision 1312): a
  // wake-up more than kStallThreshold after the wait's end, or a turn that long off the CPU.
  SteadyClock::time_point stall_from{}, stall_until{};
  SteadyClock::time_point woke = SteadyClock::now();
  auto cpu_at_wait = drivegw::transport::ThreadCpuTime();
  auto send = [&](int i, SteadyClock::time_point now) {
    ::sendto(fd, request.data(), request.size(), 0, reinterpret_cast<const sockaddr*>(&to[i]),
             sizeof(sockaddr_in));
    st[i].outstanding = true;
    st[i].sent_in_period = true;
    st[i].sent_at = now;
    ++sent;
  };
  SteadyClock::time_point period = SteadyClock::now();
  const auto warm_end = period + 300ms;
  const auto end = warm_end + std::chrono::duration_cast<SteadyClock::duration>(
                                  std::chrono::duration<double>(seconds));
  double cpu_a = 0, sim_a = 0, steal_a = 0;
  SteadyClock::time_point t_a;
  // The host probe runs alongside the measured window, as on the gateway side.
  HostProbe host;
  std::thread prober([&host, warm_end, end] {
    std::this_thread::sleep_until(warm_end);
    host = ProbeHostUntil(end);
  });
  auto roll = [&](SteadyClock::time_point now) {
    if (now < period + kCycle) return;
    const auto k = static_cast<uint64_t>((now - period) / kCycle);
    // Ended periods j = 0 .. k-1 overlapping the last stall (the same rule as the session).
    uint64_t first = 1, last = 0;
    if (stall_until > stall_from && stall_until > period) {
      first = static_cast<uint64_t>(std::max<SteadyClock::rep>(0, (stall_from - period) / kCycle));
      last = std::min<uint64_t>(
          k - 1, static_cast<uint64_t>((stall_until - period - SteadyClock::duration(1)) / kCycle));
    }
    for (State& s : st) {
      cycles += k;
      late += k - (s.met ? 1 : 0);
      const uint64_t from = s.met ? std::max<uint64_t>(first, 1) : first;
      if (last >= from) late_stalled += last - from + 1;
      s.met = false;
      s.sent_in_period = false;
      if (s.outstanding && now >= s.sent_at + kReplyTimeout) {
        s.outstanding = false;
        ++timeouts;
      }
    }
    period += static_cast<int64_t>(k) * kCycle;
    for (int i = 0; i < n; ++i) {
      if (!st[i].outstanding) send(i, now);
    }
  };
  for (int i = 0; i < n; ++i) send(i, period);
  uint8_t buffer[2048];
  for (;;) {
    SteadyClock::time_point now = SteadyClock::now();
    if (!measuring && now >= warm_end) {
      measuring = true;
      sent = replies = timeouts = cycles = late = late_stalled = 0;
      cpu_a = CpuSeconds();
      sim_a = farm.CpuSeconds();
      steal_a = StealMs();
      t_a = now;
    }
    if (now >= end) break;
    roll(now);
    const auto wait = period + kCycle - now;
    const timespec ts{0,
                      std::max<long>(0, static_cast<long>(std::chrono::nanoseconds(wait).count()))};
    pollfd p{fd, POLLIN, 0};
    const auto due = now + std::chrono::nanoseconds(ts.tv_nsec);
    // A turn whose wall time exceeds this thread's CPU time by the threshold was a stall too.
    const auto wait_from = SteadyClock::now();
    const auto cpu_now = drivegw::transport::ThreadCpuTime();
    if ((wait_from - woke) - (cpu_now - cpu_at_wait) > kStallThreshold) {
      stall_from = woke;
      stall_until = wait_from;
    }
    cpu_at_wait = cpu_now;
    ::ppoll(&p, 1, &ts, nullptr);
    now = SteadyClock::now();
    woke = now;
    if (now - due > kStallThreshold) {
      stall_from = due;
      stall_until = now;
    }
    roll(now);
    for (;;) {
      sockaddr_in from{};
      socklen_t len = sizeof(from);
      const ssize_t got =
          ::recvfrom(fd, buffer, sizeof(buffer), 0, reinterpret_cast<sockaddr*>(&from), &len);
      if (got < 0) break;
      const int i = static_cast<int>(ntohs(from.sin_port)) - farm.base;
      if (i < 0 || i >= n || static_cast<size_t>(got) < reply_size || !st[i].outstanding) continue;
      st[i].outstanding = false;
      ++replies;
      if (st[i].sent_at >= period) st[i].met = true;
      if (!st[i].sent_in_period) send(i, now);  // the reply came late: next exchange at once
    }
  }
  w.seconds = std::chrono::duration<double>(SteadyClock::now() - t_a).count();
  w.cpu_s = CpuSeconds() - cpu_a;
  w.sim_cpu_s = farm.CpuSeconds() - sim_a;
  w.exchanges = replies;
  w.sent = sent;
  w.timeouts = timeouts;
  w.cycles = cycles;
  w.late = late;
  w.late_stalled = late_stalled;
  w.load = LoadAverage();
  const double steal_b = StealMs();
  prober.join();
  AddHost(w, host, steal_b - steal_a);
  ::close(fd);
  return w;
}

struct Row {
  int n;
  Window gw, bare;
};

nlohmann::json WindowJson(const Window& w) {
  return {{"seconds", w.seconds},
          {"exchanges", w.exchanges},
          {"sent", w.sent},
          {"timeouts", w.timeouts},
          {"cycles", w.cycles},
          {"late_cycles", w.late},
          {"late_pct", w.late_pct()},
          {"late_cycles_stalled", w.late_stalled},
          {"late_unstalled_pct", w.late_unstalled_pct()},
          {"cpu_us_per_exchange", w.cpu_us_per_exchange()},
          {"cpu_pct_of_core", 100 * w.cpu_s / w.seconds},
          {"sim_cpu_us_per_exchange", w.sim_us_per_exchange()},
          {"sim_cpu_pct_of_core", 100 * w.sim_cpu_s / w.seconds},
          {"load_average", w.load},
          {"host_late_pct", w.host_late_pct()},
          {"host_wakeups", w.host_wakeups},
          {"host_stall_ms", w.host_stall_ms},
          {"host_max_late_us", w.host_max_late_us},
          {"steal_ms", w.steal_ms}};
}

std::vector<int> ParseList(const char* text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(std::max(1, std::atoi(item.c_str())));
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::max(0.2, std::atof(argv[1])) : 5.0;
  const std::vector<int> ns = ParseList(argc > 2 ? argv[2] : "25,50,100,200,300,400");
  bool rt = argc > 3 && std::string(argv[3]) == "rt";
  if (rt) {
    sched_param param{};
    param.sched_priority = kRtPriority;
    if (::sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
      // Not root: measured at normal priority, and the output says so.
      std::fprintf(stderr, "rt: sched_setscheduler: %s (normal priority)\n", std::strerror(errno));
      rt = false;
    }
  }
  drivegw::log::SetLevel(drivegw::log::Level::kError);  // link-loss warnings of overload runs
  std::signal(SIGPIPE, SIG_IGN);
  std::mt19937 rng(std::random_device{}());

  std::printf("LinUDP cyclic exchange at %lld ms, %.1f s per N and side%s; load average %.2f\n",
              static_cast<long long>(kCycle.count()), seconds, rt ? ", SCHED_FIFO" : "",
              LoadAverage());
  const HostProbe host = ProbeHost(seconds);
  std::printf("host: %llu wake-ups on a 2 ms grid, %.3f %% late by > 1 ms, max %.0f us\n",
              static_cast<unsigned long long>(host.wakeups), host.late_pct(), host.max_late_us);
  std::fflush(stdout);
  // run%: late periods while the loop's own thread ran (not stalled, decision 1312).
  // host% / stall / steal: the host probe alongside each window (wake-ups > 1 ms late, their
  // summed lateness in ms, the hypervisor's steal time in ms).
  std::printf(
      "%5s | %10s %8s %7s %9s %7s %7s %6s %6s %6s | %10s %8s %7s %9s %7s %6s %6s %6s | %6s\n", "N",
      "gw exch/s", "gw late%", "run%", "gw us/tg", "gw cpu%", "sim%", "host%", "stall", "steal",
      "bare ex/s", "bare lt%", "run%", "bare us/tg", "sim%", "host%", "stall", "steal", "ratio");
  std::fflush(stdout);
  std::vector<Row> rows;
  bool failed = false;
  for (const int n : ns) {
    auto farm = StartSims(n, rng);
    if (!farm) {
      std::fprintf(stderr, "N=%d: could not start the simulated drives\n", n);
      failed = true;
      break;
    }
    auto gw = MeasureGateway(n, *farm, seconds, rt ? kRtPriority : 0);
    auto bare = gw ? MeasureBareLoop(n, *farm, seconds) : std::nullopt;
    if (!gw || !bare || gw->exchanges == 0 || bare->exchanges == 0) {
      std::fprintf(stderr, "N=%d: a side exchanged nothing\n", n);
      failed = true;
      break;
    }
    const double ratio = gw->cpu_us_per_exchange() / bare->cpu_us_per_exchange();
    std::printf(
        "%5d | %10.0f %8.3f %7.3f %9.2f %7.1f %7.1f %6.3f %6.1f %6.0f | %10.0f %8.3f %7.3f %9.2f "
        "%7.1f %6.3f %6.1f %6.0f | %6.2f\n",
        n, static_cast<double>(gw->exchanges) / gw->seconds, gw->late_pct(),
        gw->late_unstalled_pct(), gw->cpu_us_per_exchange(), 100 * gw->cpu_s / gw->seconds,
        100 * gw->sim_cpu_s / gw->seconds, gw->host_late_pct(), gw->host_stall_ms, gw->steal_ms,
        static_cast<double>(bare->exchanges) / bare->seconds, bare->late_pct(),
        bare->late_unstalled_pct(), bare->cpu_us_per_exchange(),
        100 * bare->sim_cpu_s / bare->seconds, bare->host_late_pct(), bare->host_stall_ms,
        bare->steal_ms, ratio);
    std::fflush(stdout);
    rows.push_back({n, *gw, *bare});
  }
  if (rows.empty()) return 1;

  int max_n = 0;
  int max_n_vs_bare = 0;  // the gateway no later than the bare loop on the same machine + 0.1 pt
  nlohmann::json per_n = nlohmann::json::array();
  for (const Row& r : rows) {
    if (r.gw.late_pct() < 0.1) max_n = std::max(max_n, r.n);
    if (r.gw.late_pct() < r.bare.late_pct() + 0.1) max_n_vs_bare = std::max(max_n_vs_bare, r.n);
    per_n.push_back({{"n", r.n}, {"gateway", WindowJson(r.gw)}, {"bare_loop", WindowJson(r.bare)}});
  }
  // Informational: where the 0.1 % limit is out of reach even for the bare loop (this VM's
  // scheduling), how far the gateway keeps up with the bare loop.
  drivegw::bench::Report({"P2",
                          "max_drives_2ms_vs_bare_loop",
                          static_cast<double>(max_n_vs_bare),
                          "drives",
                          "",
                          "bare loop's late cycles + 0.1 percentage points, same N, same run",
                          {{"sched_fifo", rt}}});
  drivegw::bench::Report({"P2",
                          "host_timer_late_pct",
                          host.late_pct(),
                          "percent",
                          "",
                          "a bare clock_nanosleep loop on the 2 ms grid, same priority, same run",
                          {{"wakeups", host.wakeups},
                           {"late_over_1ms", host.late_half_cycle},
                           {"max_late_us", host.max_late_us},
                           {"sched_fifo", rt}}});
  const Row* at = &rows.back();
  for (const Row& r : rows) {
    if (r.n == 200) at = &r;
  }
  const double ratio = at->gw.cpu_us_per_exchange() / at->bare.cpu_us_per_exchange();
  drivegw::bench::Report(
      {"P2",
       "max_drives_2ms",
       static_cast<double>(max_n),
       "drives",
       ">=200",
       "bare UDP request/response loop, same N, same 2 ms grid, same sims",
       {{"cycle_ms", 2}, {"late_limit_pct", 0.1}, {"sched_fifo", rt}, {"per_n", per_n}}});
  drivegw::bench::Report({"P2",
                          "cpu_per_telegram_ratio",
                          ratio,
                          "ratio",
                          "<=2",
                          "bare UDP request/response loop CPU per exchange (same N, same run)",
                          {{"n", at->n},
                           {"gateway_cpu_us_per_exchange", at->gw.cpu_us_per_exchange()},
                           {"bare_cpu_us_per_exchange", at->bare.cpu_us_per_exchange()},
                           {"gateway_late_pct", at->gw.late_pct()},
                           {"bare_late_pct", at->bare.late_pct()},
                           {"sched_fifo", rt}}});
  return failed ? 1 : 0;
}
