// Test support for drives on a lossy link (issue 11 fault injection, decision 1421): the steps
// every family's property test takes the same way.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "adapters/core/drive.h"
#include "tests/support/wait_status.h"

namespace drivegw::test_support {

// Enables `drive` on a lossy link. A lost reply may end one Enable ERROR or DEADLINE_EXCEEDED
// truthfully, so it tries `attempts` times, each after the link is back (not OFFLINE, within
// `wait`), and prints why an attempt failed. Success once one ends DONE.
inline ::testing::AssertionResult EnableUnderLoss(Drive& drive,
                                                  std::chrono::steady_clock::duration wait,
                                                  int attempts = 5) {
  for (int attempt = 0; attempt < attempts; ++attempt) {
    auto r = drive.Enable();
    if (r.ok() && r->state == CommandState::kDone) return ::testing::AssertionSuccess();
    std::printf("enable attempt %d: %s\n", attempt,
                r.ok() ? r->message.c_str() : std::string(r.status().message()).c_str());
    WaitStatus(
        drive, [](const DriveStatus& s) { return s.state != DriveState::kOffline; }, wait);
  }
  return ::testing::AssertionFailure()
         << "Enable never reached DONE in " << attempts << " attempts";
}

}  // namespace drivegw::test_support
