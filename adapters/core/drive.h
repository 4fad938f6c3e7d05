// The Drive seam: every family implements this, the server core talks only to it.
// Lifecycle (ros2_control's, with reasons): UNCONFIGURED -> Activate -> ACTIVE -> Deactivate
// -> INACTIVE; every failure is an absl::Status naming the drive and the cause.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/clock.h"
#include "adapters/core/command.h"
#include "adapters/core/curve.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/executor.h"
#include "adapters/core/health.h"

namespace drivegw {

// Unified drive state (API v1 DriveState).
enum class DriveState { kOffline, kDisabled, kReady, kEnabled, kMoving, kHoming, kFault };
const char* ToString(DriveState s);

// PLCopen function block states of a command handle.
enum class CommandState { kBusy, kActive, kDone, kAborted, kError };
const char* ToString(CommandState s);
inline bool IsFinal(CommandState s) {
  return s == CommandState::kDone || s == CommandState::kAborted || s == CommandState::kError;
}

using WallTime = std::chrono::system_clock::time_point;

struct CommandInfo {
  uint64_t id = 0;   // unique per drive, starts at 1
  std::string kind;  // "MoveAbsolute", "Enable", ...
  CommandState state = CommandState::kBusy;
  std::string message;
  WallTime created{};
  std::optional<WallTime> ended;
  // Fraction 0..1 of a command that knows how far it is (RunCurve: elapsed curve time / duration);
  // empty for the others. Published with the status like the state (DriveBase::UpdateProgress).
  std::optional<double> progress;
};

// How RunCurve starts a curve (issue 6; docs/decisions/013-curve-run.md).
struct CurveRunOptions {
  // The curve starts where its first point is; the axis must stand there within this tolerance
  // (a jump would be a following error on the drive), else FailedPrecondition naming both.
  double start_tolerance_mm = 0.1;
  // LinMot: a PositionTimeCurve is converted and downloaded under this curve ID (1..100) before
  // it runs; a LinMotParametricCurve runs under its own ID.
  int linmot_scratch_curve_id = 100;
};

struct NativeState {
  uint32_t main_state = 0;
  uint32_t sub_state = 0;
  std::string text;
  uint32_t status_word = 0;
  uint32_t warn_word = 0;
};

struct Fault {
  uint32_t code = 0;  // 0 = none
  std::string text;
  bool fatal = false;
};

struct DriveStatus {
  DriveState state = DriveState::kOffline;
  NativeState native;
  double position_mm = 0;
  double velocity_mm_s = 0;
  double demand_position_mm = 0;
  bool homed = false;
  bool in_target = false;
  bool motion_active = false;
  std::vector<std::string> warnings;
  Fault fault;
  std::optional<CommandInfo> last_command;
  WallTime time{};
  uint64_t sequence = 0;  // set by DriveBase::PublishStatus
  // UP/DEMOTED/DOWN of the drive's link (decision 1431), kept by DriveBase::SetHealth: the
  // family's PublishStatus never overwrites it. Empty for a drive whose family reports none (a
  // test double): the core then refuses nothing on health grounds.
  std::optional<HealthInfo> health;
};

enum class Lifecycle { kUnconfigured, kActive, kInactive };

// Link health of the drive's session for the fleet card (issue 8): the counters the metrics read
// (server/ops/drive_metrics.cpp) plus the last round trip the family passed to
// wire::ObserveRoundTrip. Zero/empty while not ACTIVE or for a family that has none.
struct LinkHealth {
  uint64_t requests = 0;
  uint64_t replies = 0;
  uint64_t missed = 0;  // timeouts, missed replies or heartbeat losses, per family
  std::optional<double> last_round_trip_ms;
};

class Drive {
 public:
  virtual ~Drive() = default;
  Drive() = default;
  Drive(const Drive&) = delete;
  Drive& operator=(const Drive&) = delete;

  virtual const DriveConfig& config() const = 0;
  // Human-readable address of the device, e.g. "udp://127.0.0.1:49360".
  virtual std::string endpoint() const = 0;

  // Opens the transport and starts cyclic exchange. The drive may still be OFFLINE after an
  // OK return (a drive that is switched off is a state, not an activation failure).
  virtual absl::Status Activate() = 0;
  // Stops cyclic exchange and closes the transport; idempotent.
  virtual void Deactivate() = 0;
  virtual Lifecycle lifecycle() const = 0;

  // Each returns the command handle. Enable, Disable and AcknowledgeFault return when the drive
  // reached the requested state (DONE) or failed; Home and motion commands return once the
  // drive accepted them (ACTIVE) and end DONE/ABORTED/ERROR later (see GetCommand, status).
  virtual absl::StatusOr<CommandInfo> Enable() = 0;
  virtual absl::StatusOr<CommandInfo> Disable() = 0;
  virtual absl::StatusOr<CommandInfo> Home() = 0;
  virtual absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) = 0;
  virtual absl::StatusOr<CommandInfo> AcknowledgeFault() = 0;

  // Move without a blocked caller (issue 10, P1; docs/decisions/1301-async-move.md): starts `cmd`
  // and calls `done` exactly once with what Move would have returned (the ACTIVE handle, or the
  // same error). `done` always runs on a thread of `blocking`, never inline in MoveAsync and never
  // on a family's I/O thread, so it may block briefly (the caller's durable audit append).
  // `blocking` must outlive the call. The default runs the synchronous Move on `blocking`;
  // families with a reply-driven session override it to send at once and complete from the reply.
  using CommandCompletion = std::function<void(absl::StatusOr<CommandInfo>)>;
  virtual void MoveAsync(const MotionCommand& cmd, Executor& blocking, CommandCompletion done) {
    blocking.Post([this, cmd, done = std::move(done)] { done(Move(cmd)); });
  }

  // A running cyclic set-point stream: Push queues the next set point (non-blocking; the family
  // forwards one per bus cycle), Close ends the cyclic command (the axis stops with its limits) and
  // returns the final handle. Destroying an open stream closes it.
  class CyclicStream {
   public:
    virtual ~CyclicStream() = default;
    virtual const CommandInfo& command() const = 0;
    virtual absl::Status Push(const CyclicSetpoint& setpoint) = 0;
    virtual CyclicStats stats() const = 0;
    virtual absl::StatusOr<CommandInfo> Close() = 0;
  };
  // Starts MC_CyclicPosition / MC_CyclicSpeed (or the family's equivalent). Families without a
  // cyclic set-point channel: Unimplemented.
  virtual absl::StatusOr<std::unique_ptr<CyclicStream>> StartCyclic(CyclicMode mode) {
    (void)mode;
    return absl::UnimplementedError(absl::StrCat("drive '", config().name, "': family '",
                                                 config().family,
                                                 "' has no cyclic set-point channel"));
  }
  // Coordinated move of `group`: this drive first, then its partners, all of this family and on
  // the same controller (the family checks). Returns one handle per drive, in group order, once
  // the controller accepted the move. Families without interpolation: Unimplemented.
  virtual absl::StatusOr<std::vector<CommandInfo>> MoveCoordinated(const CoordinatedMove& move,
                                                                   std::span<Drive* const> group) {
    (void)move;
    (void)group;
    return absl::UnimplementedError(
        absl::StrCat("drive '", config().name, "': family '", config().family,
                     "' has no coordinated (interpolated) multi-axis move"));
  }

  // Curves (issue 6; decision 013). Families that store curves on the drive (LinMot curve service)
  // download a parametric curve under its ID and verify it by reading it back; UploadCurve reads
  // one (NotFound when the drive has no curve with that ID). Others: Unimplemented.
  virtual absl::Status DownloadCurve(const LinMotParametricCurve& curve) {
    (void)curve;
    return absl::UnimplementedError(absl::StrCat("drive '", config().name, "': family '",
                                                 config().family,
                                                 "' stores no curves on the drive (RunCurve "
                                                 "streams them)"));
  }
  virtual absl::StatusOr<LinMotParametricCurve> UploadCurve(int curve_id) {
    (void)curve_id;
    return absl::UnimplementedError(absl::StrCat("drive '", config().name, "': family '",
                                                 config().family,
                                                 "' stores no curves on the drive"));
  }
  // Runs `curve` as one motion command "RunCurve": LinMot natively (time-curve commands 04xh),
  // STOBER as cyclic position set points, Trinamic as a timed sequence of moves. Returns once the
  // drive accepted it (ACTIVE); the handle carries progress and ends DONE (at the curve's end
  // point) or ERROR/ABORTED. The caller validated the curve against the axis (ValidateCurve).
  virtual absl::StatusOr<CommandInfo> RunCurve(const Curve& curve, const CurveRunOptions& options) {
    (void)curve;
    (void)options;
    return absl::UnimplementedError(absl::StrCat("drive '", config().name, "': family '",
                                                 config().family, "' cannot run curves"));
  }

  // The per-drive wire trace (issue 7; adapters/core/wire_observer.h): while on, every telegram,
  // instruction or frame of this drive is logged as one `event=wire` line. Off at start; may be
  // switched at any time, in any lifecycle state. Families without one: Unimplemented.
  virtual absl::Status SetWireTrace(bool on) {
    (void)on;
    return absl::UnimplementedError(absl::StrCat("drive '", config().name, "': family '",
                                                 config().family, "' has no wire trace"));
  }

  virtual absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) = 0;
  virtual absl::Status WriteParameter(const ParameterRef& ref, int64_t value) = 0;
  virtual absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) = 0;

  virtual DriveStatus GetStatus() const = 0;
  // Not part of DriveStatus: the counters change every cycle, the snapshots only on a change.
  virtual LinkHealth link_health() const { return {}; }
  virtual std::optional<CommandInfo> GetCommand(uint64_t id) const = 0;
  // Blocks until a snapshot newer than `after_sequence` exists or `deadline` (steady clock)
  // passes; returns the newest snapshot either way.
  virtual DriveStatus WaitForStatus(uint64_t after_sequence,
                                    std::chrono::steady_clock::time_point deadline) const = 0;
  // Like WaitForStatus, but wakes only for a snapshot newer than `after_sequence` in which a
  // field drive events are derived from changed (EventFieldsDiffer), or when the drive is
  // deactivated: a moving axis publishes its position every cycle, and the drive-event recorder
  // must not wake for each one (issue 10). A drive that does not tell such changes apart wakes on
  // every snapshot; a caller that compares snapshots stays correct either way.
  virtual DriveStatus WaitForEventStatus(uint64_t after_sequence,
                                         std::chrono::steady_clock::time_point deadline) const {
    return WaitForStatus(after_sequence, deadline);
  }
};

// Whether `b` differs from `a` in a field a drive event (server/core/drive_event_recorder) is
// derived from: the state (any change, so that an event's "before" state is the one just before
// it), the health's presence or state, the fault, the warnings, homed. Position, velocity,
// command progress and native words are not. A superset of what DriveEventsBetween reports, so a
// waiter that only wakes on these changes misses no event.
bool EventFieldsDiffer(const DriveStatus& a, const DriveStatus& b);

}  // namespace drivegw
