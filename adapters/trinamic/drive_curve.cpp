// TrinamicDrive::RunCurve (issue 6; decisions 013, 1231-1233): the curve cut into equal-duration
// legs (SegmentCurve), each a position-mode ramp (`$14` vmax/amax, `$26` + `$23` target,
// trinamic-sixpack.md §4.2, §5.4) started at the leg's start time on the steady clock; one handle
// of kind "RunCurve" that ends DONE when the motor stands at the curve's end point.
#include <algorithm>
#include <cmath>
#include <optional>
#include <thread>

#include "absl/strings/str_cat.h"
#include "adapters/core/curve_run.h"
#include "adapters/core/curve_runner.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/trinamic/drive.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;

// Decision 1231: a leg lasts at least this long (and at least 5 polls of the axis, and long
// enough that its up to three words take at most a fifth of the line).
constexpr auto kMinLeg = 100ms;
constexpr int kPollsPerLeg = 5;
constexpr int kWordsPerLeg = 3;       // `$14`, `$26`, `$23`
constexpr int kLineShare = 5;         // the legs' words use at most 1/5 of the line
constexpr double kWordBits = 9 * 10;  // 9-byte word, 8N1 (§2.5)
constexpr auto kWordGap = 2ms;        // spacing after every word (§2.5 [P], L303)

}  // namespace

// The legs after the first one, at their start times; then the wait for the end point.
class TrinamicDrive::CurveRunner final : public CurveRunnerBase {
 public:
  struct Leg {
    double start_s = 0;  // since the run's start
    int32_t target = 0;
    Ramp ramp;
    bool moves = true;  // false: the curve stands still for this leg, no words
  };

  // `first_word`: when leg 0's words had gone out (RunCurve sends them).
  CurveRunner(TrinamicDrive* drive, uint64_t id, std::vector<Leg> legs, double duration_s,
              int32_t tolerance, SessionClock::time_point t0, SessionClock::time_point first_word)
      : CurveRunnerBase(id),
        drive_(drive),
        legs_(std::move(legs)),
        duration_s_(duration_s),
        tolerance_(tolerance),
        t0_(t0),
        last_word_(first_word) {}
  ~CurveRunner() override { Stop(); }

 private:
  SessionClock::time_point At(double s) const {
    return t0_ +
           std::chrono::duration_cast<SessionClock::duration>(std::chrono::duration<double>(s));
  }
  // With mu_ held: the handle is over (superseded, fault, link loss, reset) or the drive goes.
  bool OverLocked() const {
    const auto info = drive_->GetCommand(id());
    return stop_ || !info || IsFinal(info->state) || !drive_->tracker_ ||
           drive_->tracker_->id != id();
  }
  // With mu_ held: ends the handle (progress 1 first when it is DONE).
  void EndLocked(CommandState state, const std::string& message) {
    if (OverLocked()) return;
    drive_->tracker_.reset();
    drive_->PublishLocked();
    if (state == CommandState::kDone) drive_->UpdateProgress(id(), 1);
    drive_->UpdateCommand(id(), state, message);
  }
  void Run() override;
  void RequestStop() override { SetStopFlag(drive_->mu_, drive_->cv_, stop_); }
  // Sends leg k under op_mu_ (after any Move that got there first); false when the run is over.
  bool SendLeg(size_t k);

  TrinamicDrive* const drive_;
  const std::vector<Leg> legs_;
  const double duration_s_;
  const int32_t tolerance_;  // microsteps
  const SessionClock::time_point t0_;
  bool stop_ = false;                   // guarded by drive_->mu_
  SessionClock::time_point last_word_;  // samples sent after it reflect the newest leg
};

bool TrinamicDrive::CurveRunner::SendLeg(size_t k) {
  std::lock_guard op(drive_->op_mu_);
  {
    std::lock_guard lock(drive_->mu_);
    if (OverLocked()) return false;
  }
  const Leg& leg = legs_[k];
  if (leg.moves) {
    absl::Status s = drive_->WriteRamp(leg.ramp);
    if (s.ok()) s = drive_->StartRampTo(leg.target);
    if (!s.ok()) {
      std::lock_guard lock(drive_->mu_);
      EndLocked(CommandState::kError,
                absl::StrCat("leg ", k + 1, " of ", legs_.size(), ": ", s.message()));
      return false;
    }
  }
  std::lock_guard lock(drive_->mu_);
  if (OverLocked()) return false;
  last_word_ = SessionClock::now();
  drive_->tracker_->target = leg.target;
  drive_->tracker_->sent = last_word_;
  return true;
}

void TrinamicDrive::CurveRunner::Run() {
  // Leg 0 went out with the command (RunCurve); legs 1.. at their start times. Legs done =
  // legs whose end time passed (progress, decision 1232).
  for (size_t k = 1; k < legs_.size(); ++k) {
    {
      std::unique_lock lock(drive_->mu_);
      const auto due = At(legs_[k].start_s);
      while (!OverLocked() && SessionClock::now() < due) drive_->cv_.wait_until(lock, due);
      if (OverLocked()) return;
    }
    drive_->UpdateProgress(id(), static_cast<double>(k) / static_cast<double>(legs_.size()));
    if (!SendLeg(k)) return;
    drive_->PollSoon();
  }
  // The end: a sample sent after the last word shows the motor standing (action 0).
  const int32_t end = legs_.back().target;
  // The deadline runs from the curve's end, and again from every sample that shows the motor
  // still moving: a loaded host (or controller) may finish the last leg late, a motor that stands
  // away from the end point or stalls is reported after timeouts.request without progress.
  auto deadline = At(duration_s_) + drive_->config().timeouts.request;
  std::optional<int32_t> last_pos;
  std::unique_lock lock(drive_->mu_);
  for (;;) {
    if (OverLocked()) return;
    const auto& s = drive_->sample_;
    if (s && s->sent > last_word_ && s->action != kActionInactive &&
        (!last_pos || *last_pos != s->posact)) {
      last_pos = s->posact;
      deadline = std::max(deadline, SessionClock::now() + drive_->config().timeouts.request);
    }
    if (s && s->sent > last_word_ && s->action == kActionInactive) {
      if (std::abs(int64_t{s->posact} - end) <= tolerance_) {
        EndLocked(CommandState::kDone,
                  absl::StrCat("end point reached at ", std::to_string(s->posact), " microsteps"));
      } else {
        EndLocked(CommandState::kAborted,
                  absl::StrCat("motion ended at ", std::to_string(s->posact),
                               " microsteps, curve end ", std::to_string(end)));
      }
      return;
    }
    if (SessionClock::now() > deadline) {
      EndLocked(
          CommandState::kError,
          absl::StrCat("end point ", std::to_string(end), " microsteps not reached within ",
                       std::to_string(drive_->config().timeouts.request.count()),
                       " ms (timeouts.request) without progress after the curve's end: motor at ",
                       s ? std::to_string(s->posact) : std::string("?"), ", ",
                       s ? ActionText(s->action) : std::string("no sample")));
      return;
    }
    drive_->cv_.wait_until(lock, std::min(deadline, SessionClock::now() + 50ms));
  }
}

absl::StatusOr<CommandInfo> TrinamicDrive::RunCurve(const Curve& curve,
                                                    const CurveRunOptions& options) {
  const std::string kind = "RunCurve";
  DGW_RETURN_IF_ERROR(RequireActive(kind.c_str()));
  const double tolerance_mm = options.start_tolerance_mm;
  DGW_RETURN_IF_ERROR(CheckStartTolerance(Prefix(kind), tolerance_mm));
  auto samples = SampleCurve(curve);
  if (!samples.ok()) return PrefixedStatus(samples.status(), Prefix(kind));
  const double duration_s =
      samples->time_step_s * static_cast<double>(samples->position_mm.size() - 1);

  // Decision 1231: as many legs as the line carries besides the polling.
  const auto& tc = *config().trinamic;
  const auto word = std::chrono::duration<double>(tc.can ? 0.0 : kWordBits / LineBaud()) +
                    std::chrono::duration<double>(kWordGap);
  const double min_leg_s =
      std::max({std::chrono::duration<double>(kMinLeg).count(),
                kPollsPerLeg * std::chrono::duration<double>(tc.poll_period).count(),
                kWordsPerLeg * kLineShare * word.count()});
  const int max_legs = std::max(1, static_cast<int>(std::floor(duration_s / min_leg_s + 1e-9)));
  const std::vector<CurveSegment> segments = SegmentCurve(*samples, max_legs);
  if (segments.empty()) return absl::InvalidArgumentError(Prefix(kind) + "curve has no legs");

  // Every leg's words are computed before anything moves (decision 1232): target in range,
  // vmax = the leg's speed (clamped to the axis limit: a segment slope may exceed the central
  // differences the curve was validated with), amax = the hardest ramp axis and PACK allow.
  const AxisConfig& axis = config().axis;
  const VelocityScale scale{shadow_.clkdiv(), shadow_.div()};
  int amax = 0;
  {
    const int64_t limit = std::min<int64_t>(
        32767, std::max<int64_t>(1, shadow_.Get(Opcode::kStartingVelocity, "vstart")) * 64);
    auto a = MmPerSecond2ToAmax(axis.max_acceleration_mm_s2, scale, mpu_);
    auto one = AmaxToMmPerSecond2(1, scale, mpu_);
    const bool below_one = !a.ok() && one.ok() && axis.max_acceleration_mm_s2 < *one;
    amax = static_cast<int>(a.ok() ? std::min<int64_t>(*a, limit) : below_one ? 1 : limit);
  }
  std::vector<CurveRunner::Leg> legs;
  double prev_end_s = 0;
  double prev_mm = samples->position_mm.front();
  for (size_t k = 0; k < segments.size(); ++k) {
    const CurveSegment& seg = segments[k];
    const std::string field = absl::StrCat("leg ", k + 1, " (t = ", seg.end_time_s, " s)");
    CurveRunner::Leg leg;
    leg.start_s = prev_end_s;
    auto target = TargetFor(field, seg.position_mm);
    if (!target.ok()) return PrefixedStatus(target.status(), Prefix(kind));
    leg.target = *target;
    auto prev_target = MmToMicrosteps(prev_mm, mpu_);
    leg.moves = !prev_target.ok() || *prev_target != leg.target;
    if (leg.moves) {
      const double v = std::min(seg.velocity_mm_s, axis.max_velocity_mm_s);
      auto vmax = MmPerSecondToVelocity(std::max(v, 0.0), scale, mpu_);
      if (!vmax.ok()) return PrefixedStatus(vmax.status(), absl::StrCat(Prefix(kind), field, ": "));
      leg.ramp = Ramp{std::max(1, *vmax), amax};
    }
    legs.push_back(leg);
    prev_end_s = seg.end_time_s;
    prev_mm = seg.position_mm;
  }

  // A curve still running refuses (its motor moves; decision 1232), one that ended lets go.
  DGW_RETURN_IF_ERROR(JoinEndedRunner(
      curve_mu_, curve_, [&](uint64_t id) { return GetCommand(id); }, Prefix(kind)));

  std::lock_guard op(op_mu_);
  const double start_mm = samples->position_mm.front();
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireOperationalLocked(kind));
    if (sample_->action != kActionInactive) {
      return absl::FailedPreconditionError(
          absl::StrCat(Prefix(kind), "motor ", std::to_string(axis_), " is active (",
                       ActionText(sample_->action), "); a curve starts from standstill"));
    }
    const double at_mm = sample_->posact / mpu_;
    if (std::abs(at_mm - start_mm) > tolerance_mm) {
      return absl::FailedPreconditionError(absl::StrCat(
          Prefix(kind), "axis at ", at_mm, " mm, curve '", curve.name, "' starts at ", start_mm,
          " mm (start_tolerance_mm ", tolerance_mm, "); move to the start first"));
    }
  }
  const int32_t tolerance = static_cast<int32_t>(std::floor(tolerance_mm * mpu_ + 1e-9));
  const auto t0 = SessionClock::now();
  const CommandInfo info = StartCommand(kind, true);  // supersedes the running motion (PLCopen)
  {
    std::lock_guard lock(mu_);
    Tracker t;
    t.id = info.id;
    t.kind = kind;
    t.track = TrackKind::kCurve;
    t.target = legs.front().moves ? legs.front().target : sample_ ? sample_->posact : 0;
    t.sent = t0;
    tracker_ = t;
  }
  UpdateProgress(info.id, 0);
  if (legs.front().moves) {
    absl::Status s = WriteRamp(legs.front().ramp);
    if (s.ok()) s = StartRampTo(legs.front().target);
    if (!s.ok()) {
      {
        std::lock_guard lock(mu_);
        if (tracker_ && tracker_->id == info.id) tracker_.reset();
      }
      UpdateCommand(info.id, CommandState::kError, std::string(s.message()));
      return s;
    }
  }
  const auto first_word = SessionClock::now();
  {
    std::lock_guard lock(mu_);
    if (tracker_ && tracker_->id == info.id) tracker_->sent = first_word;
  }
  PollSoon();
  auto accepted = AwaitAcceptance(info.id, kind);
  if (!accepted.ok()) return accepted;
  auto runner = std::make_shared<CurveRunner>(this, info.id, std::move(legs), duration_s, tolerance,
                                              t0, first_word);
  StoreRunner(curve_mu_, curve_, runner);
  runner->Start();
  log::Info("trinamic_curve_run", log::Fields()
                                      .Add("drive", name_)
                                      .Add("command", info.id)
                                      .Add("curve", curve.name)
                                      .Add("legs", static_cast<uint64_t>(segments.size()))
                                      .Add("min_leg_ms", min_leg_s * 1000));
  return *GetCommand(info.id);
}

void TrinamicDrive::StopCurveRunner() { StopRunner(curve_mu_, curve_); }

}  // namespace drivegw::trinamic
