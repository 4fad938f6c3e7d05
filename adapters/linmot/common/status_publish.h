#pragma once

// When and how the LinMot drives (LinUDP and DeviceNet) republish their DriveStatus: an unchanged
// status at most once per heartbeat (dashboard liveness), a state change logged at info unless it
// is operational churn of a running command. Header-only: both drive libraries include it.

#include <optional>
#include <string>
#include <string_view>

#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/log.h"

namespace drivegw::linmot {

// An unchanged status is republished at least this often (dashboard liveness).
inline constexpr Duration kStatusHeartbeat = std::chrono::seconds(1);

// The fields whose change makes a status worth publishing (not its sequence or time stamp).
inline bool SameStatus(const DriveStatus& a, const DriveStatus& b) {
  return a.state == b.state && a.native.main_state == b.native.main_state &&
         a.native.sub_state == b.native.sub_state && a.native.status_word == b.native.status_word &&
         a.native.warn_word == b.native.warn_word && a.position_mm == b.position_mm &&
         a.velocity_mm_s == b.velocity_mm_s && a.demand_position_mm == b.demand_position_mm &&
         a.homed == b.homed && a.in_target == b.in_target && a.motion_active == b.motion_active &&
         a.warnings == b.warnings && a.fault.code == b.fault.code && a.fault.fatal == b.fault.fatal;
}

// Whether the heartbeat allows skipping a status that did not change since `published_at`.
inline bool WithinHeartbeat(bool force, const std::optional<DriveStatus>& published,
                            TimePoint published_at, TimePoint now) {
  return !force && published && now - published_at < kStatusHeartbeat;
}

// Logs "drive_state" when `s` changes the published state. Operational churn (ENABLED <-> MOVING
// <-> HOMING) is per command: debug; the rest is info. `key` = `detail()`: the family's native
// detail, formatted only when a line is written.
template <typename Detail>
void LogStateChange(const std::optional<DriveStatus>& published, const DriveStatus& s,
                    const std::string& drive, const char* family, std::string_view key,
                    Detail detail) {
  if (published && published->state == s.state) return;
  auto operational = [](DriveState d) {
    return d == DriveState::kEnabled || d == DriveState::kMoving || d == DriveState::kHoming;
  };
  const bool churn = published && operational(published->state) && operational(s.state);
  (churn ? log::Debug : log::Info)("drive_state",
                                   log::Fields()
                                       .Add("drive", drive)
                                       .Add("family", family)
                                       .Add("from", published ? ToString(published->state) : "-")
                                       .Add("to", ToString(s.state))
                                       .Add(key, detail()));
}

}  // namespace drivegw::linmot
