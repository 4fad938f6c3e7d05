// LinMotDnDrive::RunCurve (issue 6; decisions 013, 987): this generation cannot transfer curve
// shapes (linmot-devicenet.md §8.8: curves 0..63 are defined in LinTalk; decision 953), so a curve
// runs as a timed sequence of set-point moves: equal-duration legs (SegmentCurve), each Set Filter
// Max Speed 0x51 (the leg's speed) + Set Position Setpoint 0x11 (its end point) in the Addressed
// slot (§8.4 lines 0x11, 0x51; §11.4), started on the steady clock; one handle "RunCurve" that ends
// DONE when the axis stands In Position at the curve's end point.
#include <algorithm>
#include <cmath>
#include <thread>

#include "absl/strings/str_cat.h"
#include "adapters/core/curve_run.h"
#include "adapters/core/curve_runner.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/linmot/devicenet/drive.h"

namespace drivegw::linmot::devicenet {
namespace {

using namespace std::chrono_literals;

// Decision 987: a leg lasts at least this long, and long enough that its two Addressed commands
// (0x51, 0x11) occupy at most a fifth of the polls; the rest carry the background reads (actual
// position, set-point, fault details) that status, progress and the end check live on.
constexpr auto kMinLeg = 100ms;
constexpr int kCommandsPerLeg = 2;
constexpr int kSlotShare = 5;
// §8.4 0x51 / 0x53 ranges, §0.5 units.
constexpr int64_t kSpeedMin = 6;
constexpr int64_t kSpeedMax = 24576;
constexpr int64_t kAccelerationMax = 1536;

// The leg's speed in 0x51 increments: rounded up (rounding down would make every leg late; the
// target is absolute, so a leg can only arrive early and wait), at least the command's minimum,
// never above the axis limit. A speed the command cannot carry is refused naming the field.
absl::StatusOr<uint16_t> LegSpeed(const std::string& field, double v_mm_s, double axis_max_mm_s) {
  // A segment slope may exceed the central differences the curve was validated with (012, 1232).
  const double v = std::min(v_mm_s, axis_max_mm_s);
  if (v / kMmSPerSpeedIncrement > static_cast<double>(kSpeedMax) + 1 - 1e-9) {
    return SpeedToDn(field, v).status();  // OutOfRange naming the settable range
  }
  int64_t inc =
      std::max<int64_t>(kSpeedMin, std::llround(std::ceil(v / kMmSPerSpeedIncrement - 1e-9)));
  inc = std::min(inc, kSpeedMax);
  if (static_cast<double>(inc) * kMmSPerSpeedIncrement > axis_max_mm_s + 1e-9) {
    inc = std::llround(std::floor(axis_max_mm_s / kMmSPerSpeedIncrement + 1e-9));
  }
  if (inc < kSpeedMin) return SpeedToDn(field, axis_max_mm_s).status();  // axis slower than 6 inc
  return static_cast<uint16_t>(inc);
}

}  // namespace

// The legs after the first one, at their start times; then the wait for the end point.
class LinMotDnDrive::CurveRunner final : public CurveRunnerBase {
 public:
  struct Leg {
    double start_s = 0;  // since t0
    int16_t target = 0;  // 0x11 value
    uint16_t speed = 0;  // 0x51 value
    bool moves = true;   // false: same target as the leg before, no words
  };

  CurveRunner(LinMotDnDrive* drive, uint64_t id, std::vector<Leg> legs, double duration_s,
              double tolerance_mm, TimePoint t0, uint64_t accepted_gen, uint64_t connection)
      : CurveRunnerBase(id),
        drive_(drive),
        legs_(std::move(legs)),
        duration_s_(duration_s),
        tolerance_mm_(tolerance_mm),
        t0_(t0),
        connection_(connection),
        target_(legs_.front().target),
        accepted_gen_(accepted_gen) {}
  ~CurveRunner() override { Stop(); }

 private:
  TimePoint At(double s) const { return t0_ + FromSeconds(s); }
  size_t legs() const { return legs_.size(); }

  // With mu_ held: the handle is over (superseded, ended) or the drive goes.
  bool OverLocked() const {
    if (stop_ || !drive_->active_ || drive_->curve_command_ != id()) return true;
    const auto info = drive_->GetCommand(id());
    return !info || IsFinal(info->state);
  }
  // With mu_ held: ends the handle (progress 1 first when it is DONE).
  void EndLocked(CommandState state, const std::string& message) {
    if (OverLocked()) return;
    drive_->curve_command_.reset();
    drive_->PublishLocked(true);  // no longer MOVING for the curve
    if (state == CommandState::kDone) drive_->UpdateProgress(id(), 1);
    drive_->UpdateCommand(id(), state, message);
    log::Debug("devicenet_curve_end", log::Fields()
                                          .Add("drive", drive_->name_)
                                          .Add("command", id())
                                          .Add("state", ToString(state))
                                          .Add("message", message));
  }
  // With mu_ held: ends the handle for what the drive reports; true when the run is over.
  bool CheckLocked();
  // Sends leg k under op_mu_ (after any Move that got there first); false when the run is over.
  bool SendLeg(size_t k);
  void Run() override;
  void RequestStop() override { SetStopFlag(drive_->mu_, drive_->cv_, stop_); }

  LinMotDnDrive* const drive_;
  const std::vector<Leg> legs_;
  const double duration_s_;
  const double tolerance_mm_;
  const TimePoint t0_;
  const uint64_t connection_;  // drive_->connection_ when the run started (decision 983)
  // Guarded by drive_->mu_.
  bool stop_ = false;
  int16_t target_ = 0;         // the newest set-point the drive echoed
  uint64_t accepted_gen_ = 0;  // the poll generation that echoed it
};

bool LinMotDnDrive::CurveRunner::CheckLocked() {
  if (OverLocked()) return true;
  LinMotDnDrive& d = *drive_;
  // Decision 983: the image is reset on a link loss; the curve cannot go on.
  if (d.link_ == LinkState::kOffline || d.connection_ != connection_) {
    EndLocked(CommandState::kError,
              absl::StrCat("link to ", d.endpoint(), " lost", d.link_reason_.empty() ? "" : ": ",
                           d.link_reason_));
    return true;
  }
  if (d.FaultPendingLocked()) {
    // The details follow within a few polls (decision 982); a RUN lost to the fault is ERROR.
    const bool published = d.published_ && d.published_->state == DriveState::kFault;
    if (!d.FaultDetailsKnownLocked() && !published) return false;
    EndLocked(CommandState::kError, "drive fault: " + d.FaultLocked().text);
    return true;
  }
  if (d.sample_.valid && !d.sample_.low.run_state()) {
    EndLocked(CommandState::kAborted,
              absl::StrCat("interrupted: drive left RUN, now ", d.StateTextLocked()));
    return true;
  }
  // A set-point read after the newest leg's echo that is not the leg's: another master or a
  // native command moved the axis elsewhere (as for Move, decision 984).
  if (d.cache_.setpoint && d.cache_.setpoint_gen > accepted_gen_ && *d.cache_.setpoint != target_) {
    EndLocked(CommandState::kAborted,
              absl::StrCat("superseded on the drive (position set-point ", *d.cache_.setpoint,
                           ", curve leg ", target_, ")"));
    return true;
  }
  return false;
}

bool LinMotDnDrive::CurveRunner::SendLeg(size_t k) {
  LinMotDnDrive& d = *drive_;
  std::lock_guard op(d.op_mu_);
  std::unique_lock lock(d.mu_);
  if (CheckLocked()) return false;
  const Leg& leg = legs_[k];
  if (!leg.moves) return true;
  const std::string what = absl::StrCat("RunCurve: leg ", k + 1, " of ", legs());
  Transaction t;
  absl::Status s = d.WriteFilterLocked(lock, CommandId::kSetFilterMaxSpeed, leg.speed,
                                       d.clock_.Now() + d.config().timeouts.request,
                                       absl::StrCat(what, ": Set Filter Max Speed"));
  if (s.ok()) {
    auto r = d.TransactLocked(
        lock, Command{Raw(CommandId::kSetPositionSetpoint), d.options_.motor, false, leg.target},
        d.clock_.Now() + d.config().timeouts.accept, what);
    if (!r.ok()) {
      s = r.status();
    } else {
      t = *r;
      if (t.error_rose) {
        s = d.CodedErrorStatus(lock, what, d.clock_.Now() + d.config().timeouts.request);
      }
    }
  }
  if (!s.ok()) {
    // A fault that rose meanwhile (a motor error is no coded refusal) ends the run with its
    // details, which follow within a few polls (decision 982).
    const TimePoint until = d.clock_.Now() + d.config().timeouts.request;
    while (d.FaultPendingLocked() && d.active_ && d.clock_.Now() < until) {
      if (CheckLocked()) return false;
      d.cv_.wait_for(lock, std::min<Duration>(until - d.clock_.Now(), 50ms));
    }
    EndLocked(CommandState::kError, std::string(s.message()));
    return false;
  }
  if (OverLocked()) return false;
  target_ = leg.target;
  accepted_gen_ = t.response_gen;
  return true;
}

void LinMotDnDrive::CurveRunner::Run() {
  LinMotDnDrive& d = *drive_;
  // Leg 0 went out with the command (RunCurve); legs 1.. at their start times. Progress = legs
  // whose end time passed (decision 987, as 1232).
  for (size_t k = 1; k < legs(); ++k) {
    {
      std::unique_lock lock(d.mu_);
      const TimePoint due = At(legs_[k].start_s);
      for (;;) {
        if (CheckLocked()) return;
        const TimePoint now = d.clock_.Now();
        if (now >= due) break;
        d.cv_.wait_for(lock, due - now);
      }
    }
    d.UpdateProgress(id(), static_cast<double>(k) / static_cast<double>(legs()));
    if (!SendLeg(k)) return;
  }
  // The end: In Position (the drive's window around the last set-point, §7.4) in a response
  // after the last leg's echo that also carried a fresh actual position, within the tolerance.
  // The end point as the set-point carries it (1/51.2 mm, §0.5): a tolerance of 0 can be met.
  const double end_mm = PositionFromDn(legs_.back().target);
  const Duration request = d.config().timeouts.request;
  // The deadline runs from the curve's end, and again from every fresh position that shows the
  // axis still moving: a loaded host ends the last leg late; a stalled axis is reported after
  // timeouts.request without progress.
  TimePoint deadline = At(duration_s_) + request;
  std::optional<int16_t> last_actual;
  std::unique_lock lock(d.mu_);
  for (;;) {
    if (CheckLocked()) return;
    const TimePoint now = d.clock_.Now();
    const bool fresh = d.cache_.actual_position && d.cache_.actual_gen > accepted_gen_;
    if (fresh && d.cache_.actual_gen == d.answered_gen_ &&
        d.sample_.low.in_position(d.options_.motor)) {
      const double at_mm = PositionFromDn(*d.cache_.actual_position);
      if (std::fabs(at_mm - end_mm) <= tolerance_mm_) {
        EndLocked(CommandState::kDone, absl::StrCat("end point reached at ", at_mm, " mm"));
        return;
      }
    }
    if (fresh && last_actual != d.cache_.actual_position) {
      last_actual = d.cache_.actual_position;
      deadline = std::max(deadline, now + request);
    }
    if (now > deadline) {
      EndLocked(
          CommandState::kError,
          absl::StrCat("end point ", end_mm, " mm not reached within ",
                       d.config().timeouts.request.count(),
                       " ms (timeouts.request) without progress after the curve's end: axis "
                       "at ",
                       d.cache_.actual_position
                           ? absl::StrCat(PositionFromDn(*d.cache_.actual_position), " mm")
                           : std::string("?"),
                       ", ", d.StateTextLocked(), " (start_tolerance_mm ", tolerance_mm_, ")"));
      return;
    }
    d.cv_.wait_for(lock, std::min<Duration>(deadline - now, 50ms));
  }
}

bool LinMotDnDrive::CurveOpenLocked() const {
  if (!curve_command_) return false;
  const auto info = GetCommand(*curve_command_);
  return info && !IsFinal(info->state);
}

void LinMotDnDrive::StopCurveRunner() {
  StopRunner(curve_mu_, curve_);
  std::lock_guard lock(mu_);
  if (curve_command_) UpdateCommand(*curve_command_, CommandState::kAborted, "drive deactivated");
  curve_command_.reset();
}

absl::StatusOr<CommandInfo> LinMotDnDrive::RunCurve(const Curve& curve,
                                                    const CurveRunOptions& options) {
  const std::string kind = "RunCurve";
  DGW_RETURN_IF_ERROR(RequireActive("RunCurve"));
  const std::string prefix = absl::StrCat("drive '", name_, "': RunCurve: ");
  const double tolerance_mm = options.start_tolerance_mm;
  DGW_RETURN_IF_ERROR(CheckStartTolerance(prefix, tolerance_mm));
  auto samples = SampleCurve(curve);
  if (!samples.ok()) return PrefixedStatus(samples.status(), prefix);
  const double duration_s =
      samples->time_step_s * static_cast<double>(samples->position_mm.size() - 1);

  // Decision 987: as many legs as the Addressed slot carries besides the background reads.
  const double min_leg_s = std::max(std::chrono::duration<double>(kMinLeg).count(),
                                    kCommandsPerLeg * kSlotShare * ToSeconds(options_.poll_period));
  const int max_legs = std::max(1, static_cast<int>(std::floor(duration_s / min_leg_s + 1e-9)));
  const std::vector<CurveSegment> segments = SegmentCurve(*samples, max_legs);
  if (segments.empty()) return absl::InvalidArgumentError(prefix + "curve has no legs");

  // Everything the legs send is computed before anything moves. Filter acceleration = the
  // hardest ramp the axis allows (decision 1232's reason: absolute targets, a leg can only be
  // late), rounded down and capped at the command's top (§8.4 0x53: 1..1536 x 238.419 mm/s²).
  const AxisConfig& axis = config().axis;
  auto acceleration =
      AccelerationToDn("axis.max_acceleration_mm_s2",
                       std::min(axis.max_acceleration_mm_s2, static_cast<double>(kAccelerationMax) *
                                                                 kMmS2PerAccelerationIncrement));
  if (!acceleration.ok()) return PrefixedStatus(acceleration.status(), prefix);
  std::vector<CurveRunner::Leg> legs;
  double prev_end_s = 0;
  for (size_t k = 0; k < segments.size(); ++k) {
    const CurveSegment& seg = segments[k];
    const std::string field =
        absl::StrCat("leg ", k + 1, " of ", segments.size(), " (t = ", seg.end_time_s, " s)");
    if (!(seg.position_mm >= axis.min_mm && seg.position_mm <= axis.max_mm)) {
      return absl::OutOfRangeError(absl::StrCat(prefix, field, ".position_mm: ", seg.position_mm,
                                                " is outside the axis range [", axis.min_mm, ", ",
                                                axis.max_mm, "]"));
    }
    CurveRunner::Leg leg;
    leg.start_s = prev_end_s;
    auto target = PositionToDn(field + ".position_mm", seg.position_mm);
    if (!target.ok()) return PrefixedStatus(target.status(), prefix);
    leg.target = *target;
    auto speed = LegSpeed(field + ".velocity_mm_s", seg.velocity_mm_s, axis.max_velocity_mm_s);
    if (!speed.ok()) return PrefixedStatus(speed.status(), prefix);
    leg.speed = *speed;
    // Leg 0 always sends its set-point: from then on the drive's set-point is the curve's.
    leg.moves = k == 0 || leg.target != legs.back().target;
    legs.push_back(leg);
    prev_end_s = seg.end_time_s;
  }

  // A curve still running refuses (Stop or Move first); one that ended lets go of its thread.
  const std::shared_ptr<CurveRunner> previous = LoadRunner(curve_mu_, curve_);
  {
    std::lock_guard lock(mu_);
    if (CurveOpenLocked()) {
      return absl::FailedPreconditionError(absl::StrCat(prefix, "curve command ", *curve_command_,
                                                        " is still running; Stop or Move first"));
    }
  }
  if (previous) previous->Join();

  std::shared_ptr<CurveRunner> runner;
  uint64_t id = 0;
  {
    std::lock_guard op(op_mu_);
    std::unique_lock lock(mu_);
    if (!OnlineLocked()) {
      return absl::UnavailableError(absl::StrCat(prefix, "no poll response from ", endpoint(),
                                                 " (link ", ToString(link_), ")"));
    }
    if (!sample_.low.run_state() || FaultPendingLocked()) {
      return absl::FailedPreconditionError(
          absl::StrCat(prefix, "needs RUN (ENABLED), drive is in ", StateTextLocked()));
    }
    if (CurveOpenLocked()) {
      return absl::FailedPreconditionError(absl::StrCat(prefix, "curve command ", *curve_command_,
                                                        " is still running; Stop or Move first"));
    }
    if (MotionActiveLocked()) {
      return absl::FailedPreconditionError(absl::StrCat(prefix, "the axis is moving (",
                                                        velocity_mm_s_,
                                                        " mm/s); a curve starts from standstill"));
    }
    // Decision 013: the axis must stand at the curve's first point; read fresh (0x18).
    const TimePoint request_deadline = clock_.Now() + config().timeouts.request;
    auto actual = GetLocked(lock, CommandId::kGetActualPosition, options_.motor, request_deadline);
    if (!actual.ok()) return actual.status();
    const double at_mm = PositionFromDn(*actual);
    const double start_mm = samples->position_mm.front();
    if (std::fabs(at_mm - start_mm) > tolerance_mm) {
      return absl::FailedPreconditionError(absl::StrCat(
          prefix, "axis at ", at_mm, " mm, curve '", curve.name, "' starts at ", start_mm,
          " mm (start_tolerance_mm ", tolerance_mm, "); move to the start first"));
    }

    const CommandInfo info = StartCommand(kind, true);  // supersedes the running motion (PLCopen)
    id = info.id;
    motion_.reset();
    homing_.reset();
    curve_command_ = info.id;
    UpdateProgress(info.id, 0);
    TimePoint t0{};
    uint64_t accepted_gen = 0;
    const std::string what = absl::StrCat(kind, ": leg 1 of ", legs.size());
    absl::Status sent = [&]() -> absl::Status {
      DGW_RETURN_IF_ERROR(WriteFilterLocked(lock, CommandId::kSetFilterMaxAcceleration,
                                            *acceleration, request_deadline,
                                            absl::StrCat(kind, ": Set Filter Max Acceleration")));
      DGW_RETURN_IF_ERROR(WriteFilterLocked(lock, CommandId::kSetFilterMaxSpeed, legs.front().speed,
                                            request_deadline,
                                            absl::StrCat(what, ": Set Filter Max Speed")));
      t0 = clock_.Now();  // the legs' clock starts with leg 0's set-point
      DGW_ASSIGN_OR_RETURN(const Transaction t,
                           TransactLocked(lock,
                                          Command{Raw(CommandId::kSetPositionSetpoint),
                                                  options_.motor, false, legs.front().target},
                                          clock_.Now() + config().timeouts.accept, what));
      if (t.error_rose) return CodedErrorStatus(lock, what, request_deadline);
      accepted_gen = t.response_gen;
      return absl::OkStatus();
    }();
    if (!sent.ok()) {
      if (curve_command_ == info.id) curve_command_.reset();
      UpdateCommand(info.id, CommandState::kError, std::string(sent.message()));
      return sent;
    }
    if (curve_command_ != info.id || !GetCommand(info.id) || IsFinal(GetCommand(info.id)->state)) {
      // Ended while leg 0 went out (link loss, deactivation): the handle says how.
      std::optional<CommandInfo> ended = GetCommand(info.id);
      if (!ended) return absl::InternalError(prefix + "command lost");
      return *ended;
    }
    UpdateCommand(info.id, CommandState::kActive);
    runner = std::make_shared<CurveRunner>(this, info.id, std::move(legs), duration_s, tolerance_mm,
                                           t0, accepted_gen, connection_);
    log::Info("devicenet_curve_run",
              log::Fields()
                  .Add("drive", name_)
                  .Add("command", info.id)
                  .Add("curve", curve.name)
                  .Add("legs", static_cast<uint64_t>(segments.size()))
                  .Add("min_leg_ms", min_leg_s * 1000)
                  .Add("acceleration", static_cast<uint64_t>(*acceleration)));
  }
  StoreRunner(curve_mu_, curve_, runner);
  runner->Start();
  std::optional<CommandInfo> result = GetCommand(id);
  if (!result) return absl::InternalError(prefix + "command lost");
  return *result;
}

}  // namespace drivegw::linmot::devicenet
