// What every family's RunCurve shares around its own leg or set-point logic (issue 6, decision
// 013): the runner's lifecycle (a worker thread started once, stopped by Deactivate, joined
// before a new run), the drive's slot holding its latest runner, and the checks and error prefixes
// of the call. Header-only: the families' drive libraries include it.
#pragma once

#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/drive.h"

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

// The lifecycle every family's curve runner shares: one worker thread running the runner's Run(),
// stopped at once by Deactivate (Stop), joined before the next run once its command ended (Join).
// A runner's destructor calls Stop(): its members must outlive the thread.
class CurveRunnerBase {
 public:
  CurveRunnerBase(const CurveRunnerBase&) = delete;
  CurveRunnerBase& operator=(const CurveRunnerBase&) = delete;
  virtual ~CurveRunnerBase() = default;

  uint64_t id() const { return id_; }  // the run's command handle
  void Start() {
    thread_ = std::thread([this] { Run(); });
  }
  void Stop() {
    RequestStop();
    Join();
  }
  void Join() {
    if (thread_.joinable()) thread_.join();
  }

 protected:
  explicit CurveRunnerBase(uint64_t id) : id_(id) {}
  // The thread's body; it returns soon after RequestStop.
  virtual void Run() = 0;
  // Makes Run leave soon: sets the runner's flag and wakes its wait.
  virtual void RequestStop() = 0;

 private:
  const uint64_t id_;
  std::thread thread_;
};

// RequestStop of a runner whose loop waits on `cv` under `mu` and checks `flag` there: the flag
// is set under the mutex, so that the wait cannot miss it.
template <typename Mutex>
void SetStopFlag(Mutex& mu, std::condition_variable& cv, bool& flag) {
  {
    std::lock_guard lock(mu);
    flag = true;
  }
  cv.notify_all();
}

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
// Deactivate: the latest runner leaves at once (its thread is joined).
template <typename Runner>
void StopRunner(std::mutex& mu, const std::shared_ptr<Runner>& slot) {
  if (const std::shared_ptr<Runner> runner = LoadRunner(mu, slot)) runner->Stop();
}
// A new run may start once the latest runner's command ended (`get_command(id)`: the handle or
// nullopt); its thread is then joined. FailedPrecondition "<prefix>curve command <id> is still
// running; Stop or Move first<hint>" otherwise.
template <typename Runner, typename GetCommand>
absl::Status JoinEndedRunner(std::mutex& mu, const std::shared_ptr<Runner>& slot,
                             GetCommand get_command, const std::string& prefix,
                             const char* hint = "") {
  const std::shared_ptr<Runner> previous = LoadRunner(mu, slot);
  if (!previous) return absl::OkStatus();
  const auto info = get_command(previous->id());
  if (info && !IsFinal(info->state)) {
    return absl::FailedPreconditionError(absl::StrCat(
        prefix, "curve command ", info->id, " is still running; Stop or Move first", hint));
  }
  previous->Join();
  return absl::OkStatus();
}

}  // namespace drivegw
