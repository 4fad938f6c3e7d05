// The one service core behind gRPC and REST: looks up drives, validates requests against the
// axis, maps units, calls the Drive, and writes the audit log for every mutating call.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/drive.pb.h"
#include "server/core/call_context.h"
#include "server/core/cyclic_stream.h"
#include "server/core/lease_manager.h"
#include "server/core/watch_snapshots.h"
#include "server/core/watch_stream.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

// UNAVAILABLE "drive 'x1' is DOWN since <RFC 3339 UTC> (<reason>): <action> refused" when the
// ACTIVE drive's health is DOWN, else OK (decision 1431). `action` is the RPC name, "MoveAbsolute".
absl::Status RefuseIfDown(const Drive& d, std::string_view action);

class DriveServiceCore {
 public:
  // `audit` may be null (tests without storage); drives keep their order for ListDrives.
  // `leases` (may be null: none) is checked before every mutating drive access (decision 019).
  DriveServiceCore(std::vector<std::shared_ptr<Drive>> drives, storage::AuditLog* audit,
                   const LeaseManager* leases = nullptr);

  absl::StatusOr<v1::ListDrivesResponse> ListDrives(const v1::ListDrivesRequest& r,
                                                    const CallContext& c);
  absl::StatusOr<v1::Drive> GetDrive(const v1::GetDriveRequest& r, const CallContext& c);
  // The same two reads written into an empty message the caller owns (the REST direct path puts
  // it on an arena, decision 1363); `out` is left empty on an error.
  absl::Status ListDrives(const v1::ListDrivesRequest& r, const CallContext& c,
                          v1::ListDrivesResponse* out);
  absl::Status GetDrive(const v1::GetDriveRequest& r, const CallContext& c, v1::Drive* out);
  absl::StatusOr<v1::CommandHandle> Enable(const v1::EnableRequest& r, const CallContext& c);
  absl::StatusOr<v1::CommandHandle> Disable(const v1::DisableRequest& r, const CallContext& c);
  absl::StatusOr<v1::CommandHandle> Home(const v1::HomeRequest& r, const CallContext& c);
  absl::StatusOr<v1::CommandHandle> MoveAbsolute(const v1::MoveAbsoluteRequest& r,
                                                 const CallContext& c);
  // MoveAbsolute without a blocked thread (issue 10, P1; decision 1301): the same name lookup,
  // lease check, validation, drive command and audit entry, the drive started through
  // Drive::MoveAsync. `done` runs exactly once on a thread of `blocking`, after the audit entry
  // is durable (never before, never on a drive's I/O thread). Lookup, lease and validation run
  // on the caller's thread (no I/O); their refusals are audited and reported via `blocking` too.
  using HandleCompletion = std::function<void(absl::StatusOr<v1::CommandHandle>)>;
  void MoveAbsoluteAsync(const v1::MoveAbsoluteRequest& r, const CallContext& c, Executor& blocking,
                         HandleCompletion done);
  absl::StatusOr<v1::CommandHandle> MoveRelative(const v1::MoveRelativeRequest& r,
                                                 const CallContext& c);
  absl::StatusOr<v1::CommandHandle> MoveVelocity(const v1::MoveVelocityRequest& r,
                                                 const CallContext& c);
  // Interpolated move of two or more drives of one controller: looks up every target (each drive
  // once, one family), checks positions and dynamics against the axes, then hands the whole group
  // to the first drive (Drive::MoveCoordinated). One audit entry naming every drive.
  absl::StatusOr<v1::MoveCoordinatedResponse> MoveCoordinated(const v1::MoveCoordinatedRequest& r,
                                                              const CallContext& c);
  absl::StatusOr<v1::CommandHandle> Stop(const v1::StopRequest& r, const CallContext& c);
  absl::StatusOr<v1::CommandHandle> AcknowledgeFault(const v1::AcknowledgeFaultRequest& r,
                                                     const CallContext& c);
  absl::StatusOr<v1::CommandHandle> GetCommand(const v1::GetCommandRequest& r,
                                               const CallContext& c);
  absl::StatusOr<v1::Parameter> ReadParameter(const v1::ReadParameterRequest& r,
                                              const CallContext& c);
  absl::StatusOr<v1::Parameter> WriteParameter(const v1::WriteParameterRequest& r,
                                               const CallContext& c);
  absl::StatusOr<v1::NativeCommandResponse> SendNativeCommand(const v1::SendNativeCommandRequest& r,
                                                              const CallContext& c);

  // StreamCyclicSetpoints (gRPC only): checks the first message (drive, mode, its optional set
  // point as setpoints[0]), starts the drive's cyclic command (BLOCKS: Drive::StartCyclic) and
  // queues that set point; the front end then feeds the returned stream and ends it. A refused
  // start writes the stream's one audit entry here; otherwise the stream's End writes it.
  absl::StatusOr<std::unique_ptr<CyclicSetpointStream>> StartCyclicSetpoints(
      const v1::CyclicSetpointRequest& first, const CallContext& c);

  // WatchDrives, opened (server/core/drive_watch.cpp): checks the request (max_rate_hz, names)
  // and returns the stream's non-blocking source and period for the shared WatchTicker. The
  // source yields a drive's snapshot only when its content changed (the first one always), so at
  // most one per drive and period; it ends with Shutdown().
  struct OpenedWatch {
    std::unique_ptr<WatchSource> source;
    std::chrono::steady_clock::duration period;
  };
  absl::StatusOr<OpenedWatch> OpenWatch(const v1::WatchDrivesRequest& r, const CallContext& c);

  // Ends every running WatchDrives promptly (server shutdown).
  void Shutdown() { shutting_down_.store(true); }

  const std::vector<std::shared_ptr<Drive>>& drives() const { return drives_; }

 private:
  // A configured drive with its resource name "drives/x1", formatted once: the name is the
  // drive's const config (decision 1363). The endpoint is not kept here: Drive::endpoint() is
  // asked per read, a drive may report a new one (DirectReadsCacheTest).
  struct Configured {
    Drive* drive = nullptr;
    std::string resource_name;
  };
  // "drives/x1" (or "x1") -> the drive; NotFound naming the resource, InvalidArgument for a
  // malformed name.
  absl::StatusOr<const Configured*> FindConfigured(const std::string& field,
                                                   const std::string& name) const;
  absl::StatusOr<Drive*> Find(const std::string& field, const std::string& name) const;
  void FillDrive(const Configured& d, v1::Drive* out) const;
  template <typename Req>
  absl::StatusOr<v1::CommandHandle> RunCommand(
      const char* action, const Req& r, const CallContext& c,
      const std::function<absl::StatusOr<CommandInfo>(Drive&)>& op);
  void Audit(const CallContext& c, const std::string& drive, const std::string& action,
             const google::protobuf::Message& request, const absl::Status& result);

  std::vector<std::shared_ptr<Drive>> drives_;
  std::vector<Configured> configured_;  // drives_'s order (ListDrives)
  std::map<std::string, const Configured*, std::less<>> by_name_;
  storage::AuditLog* audit_;
  const LeaseManager* leases_;
  std::atomic<bool> shutting_down_{false};
  std::unique_ptr<WatchSnapshots> snapshots_;  // WatchDrives' shared conversions
};

}  // namespace drivegw::server
