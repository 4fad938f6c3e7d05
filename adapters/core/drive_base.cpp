// DriveBase: lifecycle, status snapshots and command handles shared by every family.
#include "adapters/core/drive_base.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"

namespace drivegw {
namespace {
// Enough history for a client to read back a handle minutes later; bounded for year-long runs.
constexpr size_t kCommandHistory = 256;

const char* ToString(Lifecycle l) {
  switch (l) {
    case Lifecycle::kUnconfigured:
      return "UNCONFIGURED";
    case Lifecycle::kActive:
      return "ACTIVE";
    case Lifecycle::kInactive:
      return "INACTIVE";
  }
  return "?";
}
}  // namespace

const char* ToString(DriveState s) {
  switch (s) {
    case DriveState::kOffline:
      return "OFFLINE";
    case DriveState::kDisabled:
      return "DISABLED";
    case DriveState::kReady:
      return "READY";
    case DriveState::kEnabled:
      return "ENABLED";
    case DriveState::kMoving:
      return "MOVING";
    case DriveState::kHoming:
      return "HOMING";
    case DriveState::kFault:
      return "FAULT";
  }
  return "?";
}

const char* ToString(CommandState s) {
  switch (s) {
    case CommandState::kBusy:
      return "BUSY";
    case CommandState::kActive:
      return "ACTIVE";
    case CommandState::kDone:
      return "DONE";
    case CommandState::kAborted:
      return "ABORTED";
    case CommandState::kError:
      return "ERROR";
  }
  return "?";
}

bool EventFieldsDiffer(const DriveStatus& a, const DriveStatus& b) {
  const bool health_differs = a.health.has_value() != b.health.has_value() ||
                              (a.health && b.health && a.health->state != b.health->state);
  return a.state != b.state || health_differs || a.fault.code != b.fault.code ||
         a.fault.text != b.fault.text || a.fault.fatal != b.fault.fatal ||
         a.warnings != b.warnings || a.homed != b.homed;
}

DriveBase::DriveBase(DriveConfig config) : config_(std::move(config)) {
  status_.time = std::chrono::system_clock::now();
}

absl::Status DriveBase::Activate() {
  {
    std::lock_guard lock(mu_);
    if (lifecycle_ == Lifecycle::kActive) {
      return absl::FailedPreconditionError(absl::StrCat(
          "drive '", config_.name, "': Activate needs state UNCONFIGURED or INACTIVE, is ACTIVE"));
    }
  }
  absl::Status s = DoActivate();
  if (!s.ok()) {
    return absl::Status(s.code(),
                        absl::StrCat("drive '", config_.name, "': activate: ", s.message()));
  }
  std::lock_guard lock(mu_);
  log::Info("lifecycle", log::Fields()
                             .Add("drive", config_.name)
                             .Add("family", config_.family)
                             .Add("from", ToString(lifecycle_))
                             .Add("to", "ACTIVE"));
  lifecycle_ = Lifecycle::kActive;
  return absl::OkStatus();
}

void DriveBase::Deactivate() {
  {
    std::lock_guard lock(mu_);
    if (lifecycle_ != Lifecycle::kActive) return;
  }
  DoDeactivate();
  std::lock_guard lock(mu_);
  lifecycle_ = Lifecycle::kInactive;
  log::Info("lifecycle",
            log::Fields().Add("drive", config_.name).Add("from", "ACTIVE").Add("to", "INACTIVE"));
  changed_.notify_all();
  event_changed_.notify_all();
}

Lifecycle DriveBase::lifecycle() const {
  std::lock_guard lock(mu_);
  return lifecycle_;
}

absl::Status DriveBase::RequireActive(const char* operation) const {
  std::lock_guard lock(mu_);
  if (lifecycle_ == Lifecycle::kActive) return absl::OkStatus();
  return absl::FailedPreconditionError(absl::StrCat("drive '", config_.name, "': ", operation,
                                                    " needs lifecycle ACTIVE, is ",
                                                    ToString(lifecycle_)));
}

DriveStatus DriveBase::GetStatus() const {
  std::lock_guard lock(mu_);
  return status_;
}

std::optional<CommandInfo> DriveBase::GetCommand(uint64_t id) const {
  std::lock_guard lock(mu_);
  for (const Entry& e : commands_) {
    if (e.info.id == id) return e.info;
  }
  return std::nullopt;
}

DriveStatus DriveBase::WaitForStatus(uint64_t after_sequence,
                                     std::chrono::steady_clock::time_point deadline) const {
  std::unique_lock lock(mu_);
  changed_.wait_until(lock, deadline, [&] {
    return status_.sequence > after_sequence || lifecycle_ == Lifecycle::kInactive;
  });
  return status_;
}

DriveStatus DriveBase::WaitForEventStatus(uint64_t after_sequence,
                                          std::chrono::steady_clock::time_point deadline) const {
  std::unique_lock lock(mu_);
  event_changed_.wait_until(lock, deadline, [&] {
    return event_sequence_ > after_sequence || lifecycle_ == Lifecycle::kInactive;
  });
  return status_;
}

void DriveBase::PublishStatus(DriveStatus status) {
  std::lock_guard lock(mu_);
  status.sequence = status_.sequence + 1;
  status.time = std::chrono::system_clock::now();
  status.last_command.reset();
  if (last_command_id_) {
    if (Entry* e = FindLocked(*last_command_id_)) status.last_command = e->info;
  }
  status.health = status_.health;
  const bool event = EventFieldsDiffer(status_, status);
  status_ = std::move(status);
  changed_.notify_all();
  if (event) EventChangedLocked();
}

void DriveBase::EventChangedLocked() {
  event_sequence_ = status_.sequence;
  event_changed_.notify_all();
}

void DriveBase::SetHealth(const HealthInfo& health) {
  std::lock_guard lock(mu_);
  if (status_.health == health) return;
  const HealthState from = status_.health ? status_.health->state : HealthState::kDown;
  if (!status_.health || from != health.state) {
    log::Fields fields;
    fields.Add("drive", config_.name)
        .Add("family", config_.family)
        .Add("from", status_.health ? ToString(from) : "NONE")
        .Add("to", ToString(health.state))
        .Add("failures", health.consecutive_failures)
        .Add("reason", health.reason);
    if (health.state == HealthState::kDown) {
      log::Warn("drive_health", fields);
    } else {
      log::Info("drive_health", fields);
    }
  }
  const bool event = !status_.health || status_.health->state != health.state;
  status_.health = health;
  RepublishLocked();
  if (event) EventChangedLocked();
}

void DriveBase::RepublishLocked() {
  status_.sequence += 1;
  status_.time = std::chrono::system_clock::now();
  status_.last_command.reset();
  if (last_command_id_) {
    if (Entry* e = FindLocked(*last_command_id_)) status_.last_command = e->info;
  }
  changed_.notify_all();
}

DriveBase::Entry* DriveBase::FindLocked(uint64_t id) {
  for (Entry& e : commands_) {
    if (e.info.id == id) return &e;
  }
  return nullptr;
}

CommandInfo DriveBase::StartCommand(const std::string& kind, bool supersedes_motion) {
  std::lock_guard lock(mu_);
  const auto now = std::chrono::system_clock::now();
  if (supersedes_motion) {
    for (Entry& e : commands_) {
      if (e.motion && !IsFinal(e.info.state)) {
        e.info.state = CommandState::kAborted;
        e.info.message = absl::StrCat("superseded by ", kind);
        e.info.ended = now;
      }
    }
  }
  Entry entry;
  entry.info.id = next_command_id_++;
  entry.info.kind = kind;
  entry.info.state = CommandState::kBusy;
  entry.info.created = now;
  entry.motion = supersedes_motion;
  commands_.push_back(entry);
  while (commands_.size() > kCommandHistory) commands_.pop_front();
  last_command_id_ = entry.info.id;
  RepublishLocked();
  log::Debug("command", log::Fields()
                            .Add("drive", config_.name)
                            .Add("id", entry.info.id)
                            .Add("kind", kind)
                            .Add("state", "BUSY"));
  return entry.info;
}

void DriveBase::UpdateCommand(uint64_t id, CommandState state, const std::string& message) {
  std::lock_guard lock(mu_);
  Entry* e = FindLocked(id);
  if (e == nullptr || IsFinal(e->info.state) || e->info.state == state) return;
  e->info.state = state;
  if (!message.empty()) e->info.message = message;
  if (IsFinal(state)) e->info.ended = std::chrono::system_clock::now();
  log::Debug("command", log::Fields()
                            .Add("drive", config_.name)
                            .Add("id", id)
                            .Add("kind", e->info.kind)
                            .Add("state", ToString(state)));
  RepublishLocked();
}

void DriveBase::UpdateProgress(uint64_t id, double fraction) {
  std::lock_guard lock(mu_);
  Entry* e = FindLocked(id);
  if (e == nullptr || IsFinal(e->info.state)) return;
  const double clamped = std::clamp(fraction, 0.0, 1.0);
  if (e->info.progress == clamped) return;
  e->info.progress = clamped;
  RepublishLocked();
}

std::vector<uint64_t> DriveBase::OpenMotionCommands() const {
  std::lock_guard lock(mu_);
  std::vector<uint64_t> ids;
  for (const Entry& e : commands_) {
    if (e.motion && !IsFinal(e.info.state)) ids.push_back(e.info.id);
  }
  return ids;
}

}  // namespace drivegw
