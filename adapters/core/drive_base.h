// Bookkeeping every family shares: lifecycle checks, status snapshots with sequence numbers
// and waiting, and the command-handle table (PLCopen states, newest supersedes the older).
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>

#include "adapters/core/drive.h"

namespace drivegw {

class DriveBase : public Drive {
 public:
  explicit DriveBase(DriveConfig config);
  ~DriveBase() override = default;

  const DriveConfig& config() const final { return config_; }

  // Lifecycle wrappers: check the state, call the family hook, log the transition.
  absl::Status Activate() final;
  void Deactivate() final;
  Lifecycle lifecycle() const final;

  DriveStatus GetStatus() const final;
  std::optional<CommandInfo> GetCommand(uint64_t id) const final;
  DriveStatus WaitForStatus(uint64_t after_sequence,
                            std::chrono::steady_clock::time_point deadline) const final;
  DriveStatus WaitForEventStatus(uint64_t after_sequence,
                                 std::chrono::steady_clock::time_point deadline) const final;

 protected:
  virtual absl::Status DoActivate() = 0;
  virtual void DoDeactivate() = 0;

  // Publishes a new snapshot: stamps time, sequence, the newest command and the health, wakes
  // waiters.
  void PublishStatus(DriveStatus status);
  // The family's HealthModel changed (decision 1431): republishes when `health` differs from the
  // snapshot's and logs a state change as event=drive_health. Takes only this drive's leaf lock,
  // so a session may call it from its I/O thread with its own locks held.
  void SetHealth(const HealthInfo& health);

  // Creates a BUSY command; a still-running motion command of the same group is ABORTED
  // (PLCopen: a new move supersedes the running one).
  CommandInfo StartCommand(const std::string& kind, bool supersedes_motion);
  // Moves a command to a new state (final states are sticky) and republishes the status.
  void UpdateCommand(uint64_t id, CommandState state, const std::string& message = "");
  // Sets the progress (clamped to 0..1) of a non-final command and republishes the status.
  void UpdateProgress(uint64_t id, double fraction);
  // Non-final motion commands (for families that end them on target / abort / fault).
  std::vector<uint64_t> OpenMotionCommands() const;

  // Fails with FailedPrecondition unless the lifecycle is ACTIVE.
  absl::Status RequireActive(const char* operation) const;

 private:
  struct Entry {
    CommandInfo info;
    bool motion = false;
  };
  Entry* FindLocked(uint64_t id);
  void RepublishLocked();
  // Marks the snapshot just published as one with an event change and wakes the event waiters.
  void EventChangedLocked();

  const DriveConfig config_;
  mutable std::mutex mu_;
  mutable std::condition_variable changed_;
  // Event waiters (WaitForEventStatus) wait here, woken only by EventChangedLocked and
  // Deactivate; `event_sequence_` is the newest snapshot's sequence with an event change.
  mutable std::condition_variable event_changed_;
  uint64_t event_sequence_ = 0;
  Lifecycle lifecycle_ = Lifecycle::kUnconfigured;
  DriveStatus status_;
  uint64_t next_command_id_ = 1;
  std::optional<uint64_t> last_command_id_;
  std::deque<Entry> commands_;  // bounded history, newest last
};

}  // namespace drivegw
