// A drivegw child process for the reliability tests (issue 11 "Crash safety", "Soak"): spawned
// with a config file, stdout/stderr to a log, ports read from the log once it serves; killed
// with SIGKILL on destruction if still running. Same pattern as server/ops/sigterm_process_test.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace drivegw::testing {

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Polls `pred` every 20 ms until it holds or `timeout` passes (a wait, not a timing assert).
inline bool Eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return pred();
}

class GatewayProcess {
 public:
  GatewayProcess(const std::string& binary, const std::string& config, std::string log)
      : log_(std::move(log)) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::vector<std::string> argv = {binary, "--config", config};
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  ~GatewayProcess() { Kill(); }
  GatewayProcess(const GatewayProcess&) = delete;
  GatewayProcess& operator=(const GatewayProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool started() const { return pid_ > 0; }
  std::string Log() const { return ReadText(log_); }

  // Waits until main.cpp printed the HTTP port (the gateway serves); 0 on time-out or exit.
  int WaitForHttpPort(std::chrono::milliseconds timeout) {
    int port = 0;
    Eventually(
        [&] {
          std::smatch m;
          const std::string text = Log();
          if (std::regex_search(text, m, std::regex("HTTP on :([0-9]+)"))) {
            port = std::stoi(m[1]);
            return true;
          }
          return !Running();
        },
        timeout);
    return port;
  }

  bool Running() {
    if (pid_ <= 0 || exited_) return false;
    if (::waitpid(pid_, &status_, WNOHANG) == pid_) exited_ = true;
    return !exited_;
  }
  // SIGKILL and reap: the process is gone when this returns.
  void Kill() {
    if (!Running()) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status_, 0);
    exited_ = true;
  }
  int status() const { return status_; }

 private:
  std::string log_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

}  // namespace drivegw::testing
