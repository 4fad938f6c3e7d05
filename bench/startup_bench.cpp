// Start-up time and memory of the real `drivegw` process with 200 configured drives (issue 10,
// P7: RSS < 64 MB, ready < 1 s): starts the simulators of a realistic mix (LinMot LinUDP drives
// behind one `drivegw-sim linmot --count N`, LinMot DeviceNet drives on a user-space CAN bus,
// STOBER CANopen nodes on another, Trinamic SIXpacks on CAN buses of their own), writes the
// configuration, fork/execs the gateway and measures exec -> /readyz 200, exec -> every drive
// seen not OFFLINE (informational), then VmRSS/VmHWM, threads and fds after a steady period. The
// same for a 1-drive configuration shows the per-drive cost. No baseline: the issue names none.
//
//   startup_bench [steady_s = 10] [drives = 200] [rounds = 3] [drivegw path] [drivegw-sim path]
//
// Exit 0 when every round became ready and had all its drives online; timings are never
// asserted (docs/performance.md "P7").
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/report.h"

namespace {

namespace fs = std::filesystem;
using SteadyTime = std::chrono::steady_clock;
using namespace std::chrono_literals;

// A multicast group of its own, so this bench never shares a bus with a test or another bench.
constexpr char kGroup[] = "239.74.163.95";

double MsSince(SteadyTime::time_point t0) {
  return std::chrono::duration<double, std::milli>(SteadyTime::now() - t0).count();
}

// ---------------------------------------------------------------------------------------------
// Child processes.

struct Child {
  pid_t pid = -1;
  int out_fd = -1;  // the child's stdout (simulators) or stderr (gateway), non-blocking
  std::string out;  // what was read so far
};

// fork/exec `argv` with stdout (or stderr when `capture_stderr`) on a pipe; the other stream goes
// to `log_path`.
Child Spawn(const std::vector<std::string>& argv, bool capture_stderr,
            const std::string& log_path) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    std::perror("startup_bench: pipe");
    std::exit(1);
  }
  const int log_fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fds[1], capture_stderr ? STDERR_FILENO : STDOUT_FILENO);
    if (log_fd >= 0) ::dup2(log_fd, capture_stderr ? STDOUT_FILENO : STDERR_FILENO);
    ::execv(args[0], args.data());
    std::perror("startup_bench: exec");
    ::_exit(127);
  }
  ::close(fds[1]);
  if (log_fd >= 0) ::close(log_fd);
  if (pid < 0) {
    std::perror("startup_bench: fork");
    std::exit(1);
  }
  ::fcntl(fds[0], F_SETFL, O_NONBLOCK);
  return Child{pid, fds[0], {}};
}

// Reads what is available (waiting up to `wait`); false once the pipe is closed.
bool Drain(Child& c, std::chrono::milliseconds wait) {
  pollfd p{c.out_fd, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(wait.count())) <= 0) return true;
  char buf[8192];
  while (true) {
    const ssize_t n = ::read(c.out_fd, buf, sizeof buf);
    if (n > 0) {
      c.out.append(buf, static_cast<size_t>(n));
      continue;
    }
    return !(n == 0);
  }
}

// Waits until `c`'s output holds `lines` newlines; false after `timeout` or when it exited.
bool WaitForLines(Child& c, size_t lines, std::chrono::milliseconds timeout) {
  const auto deadline = SteadyTime::now() + timeout;
  while (static_cast<size_t>(std::count(c.out.begin(), c.out.end(), '\n')) < lines) {
    if (SteadyTime::now() > deadline || !Drain(c, 20ms)) return false;
  }
  return true;
}

void Stop(Child& c) {
  if (c.pid > 0) {
    ::kill(c.pid, SIGTERM);
    int status = 0;
    ::waitpid(c.pid, &status, 0);
    c.pid = -1;
  }
  if (c.out_fd >= 0) ::close(c.out_fd);
  c.out_fd = -1;
}

// ---------------------------------------------------------------------------------------------
// HTTP: one GET per connection (Connection: close), enough for /readyz and /v1/drives.

struct HttpReply {
  int status = 0;  // 0: no connection / no reply
  std::string body;
};

HttpReply Get(uint16_t port, const std::string& path) {
  HttpReply r;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return r;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return r;
  }
  const std::string req =
      "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  if (::send(fd, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) {
    ::close(fd);
    return r;
  }
  std::string in;
  char buf[16384];
  size_t header_end = std::string::npos;
  size_t content_length = std::string::npos;
  while (true) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    in.append(buf, static_cast<size_t>(n));
    if (header_end == std::string::npos &&
        (header_end = in.find("\r\n\r\n")) != std::string::npos) {
      std::string head = in.substr(0, header_end);
      std::transform(head.begin(), head.end(), head.begin(), ::tolower);
      if (const size_t cl = head.find("content-length:"); cl != std::string::npos) {
        content_length = std::strtoul(head.c_str() + cl + 15, nullptr, 10);
      }
    }
    if (header_end != std::string::npos && content_length != std::string::npos &&
        in.size() >= header_end + 4 + content_length) {
      break;
    }
  }
  ::close(fd);
  if (in.rfind("HTTP/1.1 ", 0) != 0 || header_end == std::string::npos) return r;
  r.status = std::atoi(in.c_str() + 9);
  r.body = in.substr(header_end + 4);
  return r;
}

// ---------------------------------------------------------------------------------------------
// The drive mix and its simulators.

// A free UDP port on loopback (bound, read, closed): the master port the LinMot drives share.
uint16_t FreeUdpPort() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

// User-space CAN bus ports: a block of 8 per process, so parallel runs never share a bus.
uint16_t BusPort(int n) { return static_cast<uint16_t>(21000 + (::getpid() * 8 + n) % 40000); }

std::string BusSpec(uint16_t port) {
  return std::string("udp:") + kGroup + ":" + std::to_string(port);
}
std::string BusYaml(uint16_t port) {
  return std::string("{udp: {group: ") + kGroup + ", port: " + std::to_string(port) + "}}";
}

// The axis mapping of a drive entry: travel and dynamics limits (docs/config.md "drives[i].axis").
std::string AxisYaml(int min_mm, int max_mm, int velocity_mm_s, int acceleration_mm_s2) {
  return "axis: {min_mm: " + std::to_string(min_mm) + ", max_mm: " + std::to_string(max_mm) +
         ", max_velocity_mm_s: " + std::to_string(velocity_mm_s) +
         ", max_acceleration_mm_s2: " + std::to_string(acceleration_mm_s2) + "}";
}

struct Mix {
  int linmot = 0, devicenet = 0, stober = 0, trinamic = 0;
  int total() const { return linmot + devicenet + stober + trinamic; }
};

// 200 drives: 150 LinMot LinUDP, 24 LinMot DeviceNet, 14 STOBER, 12 Trinamic (two SIXpacks);
// other counts scale the CAN families the same way, LinMot takes the rest (1 drive: LinMot).
Mix MixFor(int drives) {
  Mix m;
  m.devicenet = std::min(63, drives * 24 / 200);
  m.stober = std::min(127, drives * 14 / 200);
  m.trinamic = drives * 12 / 200;
  m.linmot = drives - m.devicenet - m.stober - m.trinamic;
  return m;
}

struct Paths {
  std::string gateway, sim;
};

struct Setup {
  fs::path dir;
  std::vector<Child> sims;
  std::string config_path;
};

void Fail(const std::string& what, const std::string& log_path) {
  std::fprintf(stderr, "startup_bench: %s\n", what.c_str());
  std::ifstream log(log_path);
  std::stringstream s;
  s << log.rdbuf();
  std::fprintf(stderr, "%s\n", s.str().c_str());
  std::exit(1);
}

// Starts the simulators of `mix` and writes the gateway's configuration for them.
Setup Prepare(const Paths& paths, const Mix& mix, int round) {
  Setup s;
  s.dir = fs::temp_directory_path() /
          ("drivegw-startup-" + std::to_string(::getpid()) + "-" + std::to_string(round));
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  const std::string sim_log = (s.dir / "sims.log").string();
  std::ostringstream yaml;
  yaml << "listen: {grpc: 127.0.0.1:0, http: 127.0.0.1:0}\n"
       << "data_dir: " << (s.dir / "data").string() << "\n"
       << "drives:\n";

  if (mix.linmot > 0) {
    // Real LinMot drives answer the master port they are configured with (41136): one shared
    // master socket, hence one free port here that the simulators answer.
    const uint16_t master = FreeUdpPort();
    Child c = Spawn({paths.sim, "linmot", "--port", "0", "--master-port", std::to_string(master),
                     "--count", std::to_string(mix.linmot), "--name", "lm"},
                    false, sim_log);
    if (!WaitForLines(c, static_cast<size_t>(mix.linmot), 20s))
      Fail("linmot simulator did not start", sim_log);
    // "linmot lm-1 listening on 127.0.0.1:PORT (master port M)"
    std::istringstream lines(c.out);
    std::string line;
    int i = 0;
    while (std::getline(lines, line) && i < mix.linmot) {
      const size_t at = line.find("127.0.0.1:");
      if (at == std::string::npos) continue;
      const int port = std::atoi(line.c_str() + at + 10);
      yaml << "  - {name: lm" << ++i << ", family: linmot, linudp: {host: 127.0.0.1, port: " << port
           << ", master_port: " << master << "}, " << AxisYaml(0, 150, 2000, 20000) << "}\n";
    }
    s.sims.push_back(std::move(c));
  }
  if (mix.devicenet > 0) {
    const uint16_t bus = BusPort(0);
    Child c = Spawn({paths.sim, "linmot-devicenet", "--can", BusSpec(bus), "--mac", "1", "--count",
                     std::to_string(mix.devicenet), "--name", "dn"},
                    false, sim_log);
    if (!WaitForLines(c, static_cast<size_t>(mix.devicenet), 20s))
      Fail("devicenet simulator did not start", sim_log);
    for (int i = 1; i <= mix.devicenet; ++i) {
      yaml << "  - {name: dn" << i << ", family: linmot-devicenet, can: " << BusYaml(bus)
           << ", mac_id: " << i << ", " << AxisYaml(0, 150, 1000, 10000) << "}\n";
    }
    s.sims.push_back(std::move(c));
  }
  if (mix.stober > 0) {
    const uint16_t bus = BusPort(1);
    for (int node = 1; node <= mix.stober; ++node) {
      // I423 as in the demo (decision 413): the gateway is no hard real-time master.
      Child c = Spawn({paths.sim, "stober", "--can", BusSpec(bus), "--node", std::to_string(node),
                       "--extrapolation-ms", "100"},
                      false, sim_log);
      if (!WaitForLines(c, 1, 20s)) Fail("stober simulator did not start", sim_log);
      yaml << "  - {name: st" << node << ", family: stober, can: " << BusYaml(bus)
           << ", node_id: " << node << ", " << AxisYaml(-10000, 10000, 1000, 10000) << "}\n";
      s.sims.push_back(std::move(c));
    }
  }
  // One SIXpack (6 motors) per bus of its own; the last one may use fewer motors.
  for (int pack = 0; pack * 6 < mix.trinamic; ++pack) {
    const uint16_t bus = BusPort(2 + pack);
    Child c =
        Spawn({paths.sim, "trinamic", "--can", BusSpec(bus), "--address", "1"}, false, sim_log);
    if (!WaitForLines(c, 1, 20s)) Fail("trinamic simulator did not start", sim_log);
    for (int axis = 0; axis < 6 && pack * 6 + axis < mix.trinamic; ++axis) {
      yaml << "  - {name: tr" << pack * 6 + axis + 1
           << ", family: trinamic, trinamic: {can: " << BusYaml(bus)
           << ", address: 1, axis: " << axis << ", microsteps_per_unit: 640}, "
           << AxisYaml(0, 200, 40, 190) << "}\n";
    }
    s.sims.push_back(std::move(c));
  }
  s.config_path = (s.dir / "drivegw.yaml").string();
  std::ofstream(s.config_path) << yaml.str();
  return s;
}

// ---------------------------------------------------------------------------------------------
// One measured start.

struct ProcStatus {
  double rss_mb = 0, hwm_mb = 0, rss_anon_mb = 0, rss_file_mb = 0;
  int threads = 0, fds = 0;
};

ProcStatus ReadProc(pid_t pid) {
  ProcStatus p;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    double kb = 0;
    if (key == "VmRSS:" && status >> kb) p.rss_mb = kb / 1024;
    if (key == "VmHWM:" && status >> kb) p.hwm_mb = kb / 1024;
    if (key == "RssAnon:" && status >> kb) p.rss_anon_mb = kb / 1024;
    if (key == "RssFile:" && status >> kb) p.rss_file_mb = kb / 1024;
    if (key == "Threads:") status >> p.threads;
    status.ignore(1 << 16, '\n');
  }
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec);
       !ec && it != fs::directory_iterator(); it.increment(ec)) {
    ++p.fds;
  }
  return p;
}

struct RunResult {
  bool ok = false;
  double ready_ms = 0;  // fork/exec -> first /readyz 200
  // fork/exec -> every drive has been seen not OFFLINE at least once (-1: not within 30 s). A
  // LinUDP link that later flaps on a loaded host (150 drives polled every 5 ms) is P2's subject,
  // not start-up's; `online_now` says how many were online at the last look.
  double online_ms = -1;
  int online = 0;                                  // drives seen online at least once
  int online_now = 0;                              // drives not OFFLINE at the last look
  std::map<std::string, double> family_online_ms;  // family -> its last drive's first online
  ProcStatus proc;
};

// Drives not OFFLINE in a ListDrives body; the first time each is seen online goes into `seen`
// (name -> family, ms) so the slowest family shows (detail only).
int CountOnline(const std::string& body, double now_ms,
                std::map<std::string, std::pair<std::string, double>>& seen) {
  const auto j = nlohmann::json::parse(body, nullptr, false);
  if (j.is_discarded() || !j.contains("drives")) return -1;
  int online = 0;
  for (const auto& d : j["drives"]) {
    const std::string state = d.contains("status") ? d["status"].value("state", "") : "";
    if (state.empty() || state == "OFFLINE") continue;
    ++online;
    seen.emplace(d.value("name", ""), std::make_pair(d.value("family", ""), now_ms));
  }
  return online;
}

RunResult RunOnce(const Paths& paths, int drives, double steady_s, int round) {
  RunResult r;
  const Mix mix = MixFor(drives);
  Setup s = Prepare(paths, mix, round);
  const std::string gw_log = (s.dir / "drivegw.stdout").string();
  const auto t0 = SteadyTime::now();
  Child gw = Spawn({paths.gateway, "--config", s.config_path}, true, gw_log);
  // "drivegw: gRPC on :N, HTTP on :M — Ctrl-C stops" once Gateway::Start returned.
  uint16_t http_port = 0;
  while (http_port == 0 && MsSince(t0) < 60000) {
    if (!Drain(gw, 5ms)) break;
    if (const size_t at = gw.out.find(", HTTP on :"); at != std::string::npos) {
      http_port = static_cast<uint16_t>(std::atoi(gw.out.c_str() + at + 11));
    }
  }
  if (http_port == 0) {
    std::fprintf(stderr, "startup_bench: gateway did not start:\n%s\n", gw.out.c_str());
  } else {
    while (MsSince(t0) < 60000) {
      if (Get(http_port, "/readyz").status == 200) {
        r.ready_ms = MsSince(t0);
        r.ok = true;
        break;
      }
      Drain(gw, 2ms);
    }
  }
  // Log lines keep coming: a reader keeps the pipe from filling while this thread measures.
  std::mutex mu;
  bool stop_reader = false;
  std::thread reader([&] {
    while (true) {
      {
        std::lock_guard lock(mu);
        if (stop_reader) return;
      }
      if (!Drain(gw, 50ms)) return;
      std::lock_guard lock(mu);
      if (gw.out.size() > (1u << 20)) gw.out.erase(0, gw.out.size() - (1u << 16));
    }
  });
  if (r.ok) {
    std::map<std::string, std::pair<std::string, double>> seen;
    while (MsSince(t0) < 30000 + r.ready_ms) {
      const HttpReply list = Get(http_port, "/v1/drives");
      if (list.status == 200) r.online_now = CountOnline(list.body, MsSince(t0), seen);
      r.online = static_cast<int>(seen.size());
      if (r.online == drives) {
        r.online_ms = MsSince(t0);
        break;
      }
      std::this_thread::sleep_for(50ms);
    }
    for (const auto& [name, first] : seen) {
      double& ms = r.family_online_ms[first.first];
      ms = std::max(ms, first.second);
    }
    const double steady_until_ms = r.ready_ms + steady_s * 1000;
    if (MsSince(t0) < steady_until_ms) {
      std::this_thread::sleep_for(
          std::chrono::duration<double, std::milli>(steady_until_ms - MsSince(t0)));
    }
    r.proc = ReadProc(gw.pid);
    if (const HttpReply list = Get(http_port, "/v1/drives"); list.status == 200) {
      r.online_now = CountOnline(list.body, MsSince(t0), seen);
    }
    if (r.online != drives) {
      std::fprintf(stderr, "startup_bench: %d of %d drives seen online within 30 s\n", r.online,
                   drives);
      r.ok = false;
    }
  }
  {
    std::lock_guard lock(mu);
    stop_reader = true;
  }
  reader.join();
  Stop(gw);
  for (Child& c : s.sims) Stop(c);
  std::ofstream(s.dir / "drivegw.stderr") << gw.out;
  // Kept for a look after a failure, or when STARTUP_BENCH_KEEP is set.
  if (r.ok && std::getenv("STARTUP_BENCH_KEEP") == nullptr) fs::remove_all(s.dir);
  return r;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const double steady_s = argc > 1 ? std::atof(argv[1]) : 10;
  const int drives = argc > 2 ? std::atoi(argv[2]) : 200;
  const int rounds = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;
  const fs::path here = fs::canonical("/proc/self/exe").parent_path();
  Paths paths;
  paths.gateway = argc > 4 ? argv[4] : (here.parent_path() / "server" / "drivegw").string();
  paths.sim = argc > 5 ? argv[5] : (here.parent_path() / "sim" / "drivegw-sim").string();
  for (const std::string& p : {paths.gateway, paths.sim}) {
    if (::access(p.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "startup_bench: %s is not executable (build drivegw and drivegw-sim)\n",
                   p.c_str());
      return 1;
    }
  }
  const Mix mix = MixFor(drives);
  double load[3] = {0, 0, 0};
  if (::getloadavg(load, 3) < 0) load[0] = -1;
  std::printf(
      "startup_bench: %d drives (%d linmot, %d linmot-devicenet, %d stober, %d trinamic), "
      "%d rounds, %.1f s steady state, load average %.2f\n",
      drives, mix.linmot, mix.devicenet, mix.stober, mix.trinamic, rounds, steady_s, load[0]);
  std::printf("%-8s %5s %10s %11s %8s %8s %8s %8s %7s %5s\n", "config", "round", "ready_ms",
              "online_ms", "rss_MB", "hwm_MB", "anon_MB", "file_MB", "threads", "fds");
  bool all_ok = true;
  std::map<int, std::vector<RunResult>> runs;
  for (int round = 0; round < rounds; ++round) {
    // Alternating, so a load change on this shared machine hits both configurations alike.
    for (int n : {1, drives}) {
      const RunResult r = RunOnce(paths, n, steady_s, round * 2 + (n == 1 ? 0 : 1));
      all_ok = all_ok && r.ok;
      runs[n].push_back(r);
      std::printf("%-8s %5d %10.1f %11.1f %8.1f %8.1f %8.1f %8.1f %7d %5d\n",
                  (std::to_string(n) + "dr").c_str(), round, r.ready_ms, r.online_ms, r.proc.rss_mb,
                  r.proc.hwm_mb, r.proc.rss_anon_mb, r.proc.rss_file_mb, r.proc.threads,
                  r.proc.fds);
      std::fflush(stdout);
    }
  }
  auto med = [&](int n, auto field) {
    std::vector<double> v;
    for (const RunResult& r : runs[n]) v.push_back(field(r));
    return Median(v);
  };
  auto rounds_of = [&](int n, auto field) {
    std::vector<double> v;
    for (const RunResult& r : runs[n]) v.push_back(field(r));
    return v;
  };
  const double ready = med(drives, [](const RunResult& r) { return r.ready_ms; });
  const double ready1 = med(1, [](const RunResult& r) { return r.ready_ms; });
  const double online = med(drives, [](const RunResult& r) { return r.online_ms; });
  const double rss = med(drives, [](const RunResult& r) { return r.proc.rss_mb; });
  const double rss1 = med(1, [](const RunResult& r) { return r.proc.rss_mb; });
  const double hwm = med(drives, [](const RunResult& r) { return r.proc.hwm_mb; });
  const double threads = med(drives, [](const RunResult& r) { return r.proc.threads; });
  const double threads1 = med(1, [](const RunResult& r) { return r.proc.threads; });
  const double fds = med(drives, [](const RunResult& r) { return r.proc.fds; });
  const double fds1 = med(1, [](const RunResult& r) { return r.proc.fds; });
  const double per_drive_kb = drives > 1 ? (rss - rss1) * 1024 / (drives - 1) : 0;
  std::printf(
      "median of %d rounds: ready %.1f ms (1 drive: %.1f), all online %.1f ms, RSS %.1f MB "
      "(1 drive: %.1f; %.1f kB per drive), HWM %.1f MB, threads %.0f (1 drive: %.0f), fds "
      "%.0f (1 drive: %.0f)\n",
      rounds, ready, ready1, online, rss, rss1, per_drive_kb, hwm, threads, threads1, fds, fds1);
  std::printf("last round, exec -> the last drive of each family online:");
  for (const auto& [family, ms] : runs[drives].back().family_online_ms) {
    std::printf(" %s %.0f ms;", family.c_str(), ms);
  }
  std::printf("\n");

  const nlohmann::json mix_json = {{"linmot", mix.linmot},
                                   {"linmot_devicenet", mix.devicenet},
                                   {"stober", mix.stober},
                                   {"trinamic", mix.trinamic}};
  const std::string none = "none (issue: —); 1-drive configuration in the same run for comparison";
  using drivegw::bench::Report;
  Report({"P7",
          "startup_ready_ms",
          ready,
          "ms",
          "<1000",
          none,
          {{"drives", drives},
           {"mix", mix_json},
           {"ready_ms_1_drive", ready1},
           {"all_online_ms", online},
           {"ready_ms_rounds", rounds_of(drives, [](const RunResult& r) { return r.ready_ms; })},
           {"online_at_rss_sample_last_round", runs[drives].back().online_now},
           {"family_online_ms_last_round", runs[drives].back().family_online_ms},
           {"rounds", rounds},
           {"load_average", load[0]}}});
  Report({"P7",
          "rss_mb",
          rss,
          "MB",
          "<64",
          none,
          {{"drives", drives},
           {"steady_s", steady_s},
           {"vm_hwm_mb", hwm},
           {"rss_mb_1_drive", rss1},
           {"rss_anon_mb", med(drives, [](const RunResult& r) { return r.proc.rss_anon_mb; })},
           {"rss_file_mb", med(drives, [](const RunResult& r) { return r.proc.rss_file_mb; })},
           {"rounds", rounds},
           {"load_average", load[0]}}});
  Report({"P7",
          "per_drive_rss_kb",
          per_drive_kb,
          "kB",
          "",
          "(RSS at N drives - RSS at 1) / (N - 1)",
          {{"rss_mb", rss}, {"rss_mb_1_drive", rss1}, {"drives", drives}}});
  Report({"P7",
          "all_online_ms",
          online,
          "ms",
          "",
          "informational: exec -> every drive seen not OFFLINE once",
          {{"drives", drives}}});
  Report({"P7",
          "threads",
          threads,
          "threads",
          "",
          "informational",
          {{"threads_1_drive", threads1}, {"drives", drives}}});
  Report(
      {"P7", "fds", fds, "fds", "", "informational", {{"fds_1_drive", fds1}, {"drives", drives}}});
  return all_ok ? 0 : 1;
}
