// Controlled stop of moving drives for a graceful shutdown (issue 7 "Operations"; decision 022).
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "adapters/core/drive.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::ops {

struct StopReport {
  std::vector<std::string> stopped;       // got StopMotion and stood before the deadline
  std::vector<std::string> still_moving;  // StopMotion refused, or still moving at the deadline
};

// True while the published status says the axis moves (MOVING, HOMING or motion active).
bool IsMoving(const DriveStatus& s);

// Sends StopMotion with the axis's configured acceleration limit as deceleration (the steepest
// ramp the configuration allows, so the stop is controlled and short) to every moving drive at
// once, then waits until each stands or `deadline` passes. Each stop is audited as
// action "ShutdownStop" by principal "drivegw" (`audit` may be null).
StopReport StopMovingDrives(const std::vector<std::shared_ptr<Drive>>& drives,
                            std::chrono::steady_clock::time_point deadline,
                            storage::AuditLog* audit);

}  // namespace drivegw::ops
