#pragma once

// The statuses both LinMot drives (LinUDP and DeviceNet) answer a command with once a wait on the
// drive ended (WaitPeerLocked, session_peer.h) or a Home started. Header-only.

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/drive.h"

namespace drivegw::linmot {

// The status of a WaitPeerLocked result, messages after `where` ("drive 'x': Home: "): OK when
// reached, DeadlineExceeded with `detail`, Unavailable "link to <endpoint> lost<offline_suffix()>"
// (the family's reason, formatted only then), FailedPrecondition "drive deactivated".
template <typename Wait, typename OfflineSuffix>
absl::Status WaitPeerStatus(Wait w, const std::string& where, const std::string& detail,
                            const std::string& endpoint, OfflineSuffix offline_suffix) {
  switch (w) {
    case Wait::kReached:
      return absl::OkStatus();
    case Wait::kDeadline:
      return absl::DeadlineExceededError(absl::StrCat(where, detail));
    case Wait::kOffline:
      return absl::UnavailableError(
          absl::StrCat(where, "link to ", endpoint, " lost", offline_suffix()));
    case Wait::kInactive:
      return absl::FailedPreconditionError(absl::StrCat(where, "drive deactivated"));
  }
  return absl::InternalError(where);
}

// The handle of a Home the drive started: Internal when it is gone, Aborted (after `where`) when
// it already ended in ERROR or ABORTED.
inline absl::StatusOr<CommandInfo> StartedHome(const std::optional<CommandInfo>& info,
                                               const std::string& where) {
  if (!info) return absl::InternalError("Home: command lost");
  if (info->state == CommandState::kError || info->state == CommandState::kAborted) {
    return absl::AbortedError(absl::StrCat(where, info->message));
  }
  return *info;
}

}  // namespace drivegw::linmot
