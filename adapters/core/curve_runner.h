// What every family's RunCurve shares around its own leg or set-point logic (issue 6, decision
// 013): the runner's worker thread (started once, stopped by Deactivate, joined before a new run),
// the drive's slot holding its latest runner, and the checks and error prefixes of the call.
// Header-only: the families' drive libraries include it.
#pragma once

#include <cmath>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace drivegw {

// `s` with `prefix` before its message (same code): "drive 'x': RunCurve: <message>".
inline absl::Status PrefixedStatus(const absl::Status& s, const std::string& prefix) {
  return absl::Status(s.code(), absl::StrCat(prefix, s.message()));
}

// CurveRunOptions::start_tolerance_mm: finite and >= 0, InvalidArgument after `prefix` otherwise.
inline absl::Status CheckStartTolerance(const std::string& prefix, double tolerance_mm) {
  if (!std::isfinite(tolerance_mm) || tolerance_mm < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, "start_tolerance_mm: ", tolerance_mm, " must be >= 0"));
  }
  return absl::OkStatus();
}

// A curve runner's thread. `request_stop` makes the runner's loop leave soon (sets its flag,
// wakes its wait); Stop calls it and joins, Join only joins (a run that ended by itself). Declare
// it as the runner's last member: it is destroyed, and the thread stopped, first.
class RunnerThread {
 public:
  explicit RunnerThread(std::function<void()> request_stop)
      : request_stop_(std::move(request_stop)) {}
  ~RunnerThread() { Stop(); }
  RunnerThread(const RunnerThread&) = delete;
  RunnerThread& operator=(const RunnerThread&) = delete;

  void Start(std::function<void()> body) { thread_ = std::thread(std::move(body)); }
  void Stop() {
    request_stop_();
    Join();
  }
  void Join() {
    if (thread_.joinable()) thread_.join();
  }

  // A `request_stop` for a runner whose loop waits on `cv` under `mu` and checks `flag` there:
  // the flag is set under the mutex, so that the wait cannot miss it.
  template <typename Mutex>
  static std::function<void()> SetUnder(Mutex& mu, std::condition_variable& cv, bool& flag) {
    return [&mu, &cv, &flag] {
      {
        std::lock_guard lock(mu);
        flag = true;
      }
      cv.notify_all();
    };
  }

 private:
  const std::function<void()> request_stop_;
  std::thread thread_;
};

// The drive's latest runner lives in `slot` under its own mutex `mu` (never held with the drive's
// state mutex: a runner's Stop waits for its thread, which takes that one). Copy out, then call.
template <typename Runner>
std::shared_ptr<Runner> LoadRunner(std::mutex& mu, const std::shared_ptr<Runner>& slot) {
  std::lock_guard lock(mu);
  return slot;
}
template <typename Runner>
void StoreRunner(std::mutex& mu, std::shared_ptr<Runner>& slot, std::shared_ptr<Runner> runner) {
  std::lock_guard lock(mu);
  slot = std::move(runner);
}

}  // namespace drivegw
