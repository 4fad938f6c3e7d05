// Test support: wait for a drive's published status without polling sleeps (Drive::WaitForStatus,
// adapters/core/drive.h) — the one copy of the loop the drive, vcan and contract tests share.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>

#include "adapters/core/drive.h"

namespace drivegw::test_support {

// Waits until `pred` holds for a published status or `timeout` passes; returns the last status
// either way (the caller asserts on it, so a timeout shows the state the drive was left in).
inline DriveStatus WaitStatus(const Drive& drive,
                              const std::function<bool(const DriveStatus&)>& pred,
                              std::chrono::steady_clock::duration timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  DriveStatus s = drive.GetStatus();
  while (!pred(s) && std::chrono::steady_clock::now() < deadline) {
    s = drive.WaitForStatus(s.sequence, deadline);
  }
  return s;
}

// Waits until command `id` is final (DONE/ABORTED/ERROR) or `timeout` passes; returns its record.
inline CommandInfo WaitCommandFinal(const Drive& drive, uint64_t id,
                                    std::chrono::steady_clock::duration timeout) {
  WaitStatus(
      drive, [&](const DriveStatus&) { return IsFinal(drive.GetCommand(id)->state); }, timeout);
  return *drive.GetCommand(id);
}

}  // namespace drivegw::test_support
