// Test support: a child process (posix_spawn) with stdout and stderr in a log file, killed with
// SIGKILL on demand (crash tests) or SIGTERM-then-SIGKILL when destroyed.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace drivegw::test_support {

inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The last `n` characters of `text` (a process log in a failure message).
inline std::string Tail(const std::string& text, size_t n = 3000) {
  return text.size() <= n ? text : "..." + text.substr(text.size() - n);
}

class ChildProcess {
 public:
  ChildProcess(std::vector<std::string> argv, std::string log) : log_(std::move(log)) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    error_ = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (error_ != 0) pid_ = -1;
  }
  ~ChildProcess() {
    if (!Running()) return;
    ::kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (Running() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (Running()) Kill();
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return pid_ > 0; }
  int spawn_error() const { return error_; }
  bool Running() {
    if (pid_ <= 0 || exited_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      exit_status_ = status;
      return false;
    }
    return true;
  }
  // SIGKILL and reap: no handler, no shutdown path runs (a crash or `kill -9`).
  void Kill() {
    if (pid_ <= 0 || exited_) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &exit_status_, 0);
    exited_ = true;
  }
  std::string log() const { return ReadWholeFile(log_); }
  // Running or how it exited, and the end of its output: for failure messages.
  std::string Describe() {
    const bool running = Running();
    return (running ? std::string("running")
                    : "exited (wait status " + std::to_string(exit_status_) + ")") +
           "; output:\n" + Tail(log());
  }

 private:
  std::string log_;
  pid_t pid_ = -1;
  int error_ = 0;
  bool exited_ = false;
  int exit_status_ = 0;
};

}  // namespace drivegw::test_support
