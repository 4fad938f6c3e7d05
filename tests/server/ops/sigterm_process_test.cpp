// Graceful shutdown of the drivegw process (issue 7 "Operations"; decision 022): a child drivegw
// drives a simulated LinMot axis hosted by this test; while the axis moves, SIGTERM makes the
// gateway stop the axis with a controlled stop and exit 0 within shutdown_timeout_s (its
// watchdog would exit 3 past the bound); afterwards the simulator's axis stands short of the
// target.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "sim/linmot/server.h"
#include "tests/e2e/http_client.h"

extern char** environ;

namespace drivegw {
namespace {

using namespace std::chrono_literals;
using drivegw::testing::HttpRequest;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Polls `pred` every 20 ms until it holds or `timeout` passes (a wait, not a timing assert).
bool Eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(20ms);
  }
  return pred();
}

class Child {
 public:
  Child(std::vector<std::string> argv, const std::string& log) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  ~Child() {
    if (Running()) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  bool started() const { return pid_ > 0; }
  bool Running() {
    if (pid_ <= 0 || exited_) return false;
    if (::waitpid(pid_, &status_, WNOHANG) == pid_) {
      exited_ = true;
      return false;
    }
    return true;
  }
  void Signal(int sig) { ::kill(pid_, sig); }
  int status() const { return status_; }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

TEST(GracefulShutdown_SigtermWhileMoving, AxisStoppedAndExit0) {
  char tmpl[] = "/tmp/drivegw-sigterm-XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  const std::string dir = tmpl;

  sim::linmot::SimOptions so;
  so.name = "x1";
  so.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
  so.master_port = 0;  // reply to the gateway's (ephemeral) source port
  so.stroke_min_mm = 0;
  so.stroke_max_mm = 150;
  auto sim = sim::linmot::LinMotServer::Start(so, SteadyClock::Instance());
  ASSERT_TRUE(sim.ok()) << sim.status();

  const std::string config = dir + "/drivegw.yaml";
  {
    std::ofstream out(config);
    out << "listen: {grpc: \"127.0.0.1:0\", http: \"127.0.0.1:0\"}\n"
        << "data_dir: " << dir << "/data\n"
        << "shutdown_timeout_s: 10\n"
        << "drives:\n"
        << "  - name: x1\n"
        << "    family: linmot\n"
        << "    linudp: {host: 127.0.0.1, port: " << (*sim)->port()
        << ", master_port: 0, bind_host: 127.0.0.1}\n"
        << "    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 1000, "
           "max_acceleration_mm_s2: 10000}\n";
  }
  const std::string log = dir + "/drivegw.log";
  Child gw({DGW_GATEWAY_BIN, "--config", config}, log);
  ASSERT_TRUE(gw.started());

  // main.cpp prints the ports once the gateway started.
  int http_port = 0;
  ASSERT_TRUE(Eventually(
      [&] {
        std::smatch m;
        const std::string text = ReadFile(log);
        if (!std::regex_search(text, m, std::regex("HTTP on :([0-9]+)"))) return false;
        http_port = std::stoi(m[1]);
        return true;
      },
      30s))
      << ReadFile(log);

  auto enable = HttpRequest(http_port, "POST", "/v1/drives/x1:enable", "{}");
  ASSERT_EQ(enable.status, 200) << enable.body << ReadFile(log);
  // A slow, long move: 140 mm at 20 mm/s takes 7 s.
  auto move =
      HttpRequest(http_port, "POST", "/v1/drives/x1:moveAbsolute",
                  R"({"position_mm": 140, "velocity_mm_s": 20, "acceleration_mm_s2": 1000})");
  ASSERT_EQ(move.status, 200) << move.body;
  ASSERT_TRUE(Eventually([&] { return (*sim)->Snapshot().device.motion_active; }, 10s));

  gw.Signal(SIGTERM);
  ASSERT_TRUE(Eventually([&] { return !gw.Running(); }, 30s)) << ReadFile(log);
  ASSERT_TRUE(WIFEXITED(gw.status())) << "wait status " << gw.status() << "\n" << ReadFile(log);
  // 0: every moving drive stood; 1: one still moved; 3: the bound's watchdog fired.
  EXPECT_EQ(WEXITSTATUS(gw.status()), 0) << ReadFile(log);

  const std::string text = ReadFile(log);
  EXPECT_NE(text.find("event=shutdown_stop drive=x1"), std::string::npos) << text;
  EXPECT_NE(text.find("event=shutdown_done stopped=x1 still_moving="), std::string::npos) << text;
  EXPECT_NE(text.find("event=gateway_stopped"), std::string::npos) << text;

  // The simulator's axis stands, short of the target (stopped, not run to the end).
  const auto a = (*sim)->Snapshot().device;
  EXPECT_FALSE(a.motion_active);
  EXPECT_EQ(a.demand_velocity_mm_s, 0);
  EXPECT_LT(a.actual_position_mm, 139);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace drivegw
