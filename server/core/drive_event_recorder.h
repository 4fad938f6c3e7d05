// Drive-side events into the audit trail (issue 7 "Audit trail"): faults with the drive's own
// code and text, warnings, OFFLINE/ONLINE transitions and homing done, each an entry with
// principal "drive:<name>" (decision 017).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/drive.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

// One event found by comparing two published snapshots.
struct DriveEvent {
  std::string action;  // "drive.fault", "drive.fault_cleared", "drive.warning",
                       // "drive.warning_cleared", "drive.offline", "drive.online", "drive.homed",
                       // "drive.health"
  std::string request_json;  // the drive's own data (fault code and text, warnings, warn word)
  std::string message;
  std::string before_json;  // {"state": ...} where the state changed
  std::string after_json;
};

// The events between `before` and `after` (pure; the recorder and its tests share it).
std::vector<DriveEvent> DriveEventsBetween(const DriveStatus& before, const DriveStatus& after);

// At most `max_per_window` events per window of `window` (steady time passed in, so it is
// testable without waiting); the rest are counted for one "drive.events_suppressed" entry.
class EventBudget {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  EventBudget(int max_per_window, std::chrono::steady_clock::duration window, TimePoint start)
      : max_(max_per_window), window_(window), window_start_(start) {}

  // Called once per observed snapshot before its events: when the window has ended, starts a
  // new one and returns how many events the old one suppressed (0 = nothing to record).
  int64_t Roll(TimePoint now);
  // One event: true = record it, false = counted as suppressed.
  bool Take();

 private:
  int max_;
  std::chrono::steady_clock::duration window_;
  TimePoint window_start_;
  int taken_ = 0;
  int64_t suppressed_ = 0;
};

class DriveEventRecorder {
 public:
  // Recorded per drive and window before further events are only counted (a flapping link must
  // not flood the log); the count is written as "drive.events_suppressed" when the window ends.
  static constexpr int kMaxEventsPerWindow = 20;
  static constexpr std::chrono::seconds kWindow{60};

  // Starts one watcher thread per drive; each sleeps in Drive::WaitForEventStatus
  // between snapshots that change an event field. `audit` (not null) must outlive the recorder;
  // drives stay alive through the shared pointers. Drives start OFFLINE, so the first snapshot with
  // a link is "drive.online".
  DriveEventRecorder(std::vector<std::shared_ptr<Drive>> drives, storage::AuditLog* audit);
  ~DriveEventRecorder();
  DriveEventRecorder(const DriveEventRecorder&) = delete;
  DriveEventRecorder& operator=(const DriveEventRecorder&) = delete;

  // Ends the threads (each within one wait slice); idempotent.
  void Stop();

 private:
  void Watch(const std::shared_ptr<Drive>& drive);
  // Waits up to `d` unless Stop() comes first; false once stopped.
  bool Sleep(std::chrono::milliseconds d);

  storage::AuditLog* audit_;
  std::atomic<bool> stop_{false};
  std::mutex mu_;
  std::condition_variable stopped_;
  std::vector<std::thread> threads_;
};

}  // namespace drivegw::server
