// StoberDrive::RunCurve (issue 6; decisions 013, 1208): the curve resampled to the SYNC period
// and streamed as MC_CyclicPosition set points (stober-motion.md §3.11, L1715-1847) through the
// drive's own cyclic stream (drive_cyclic.cpp, decision 1205), under one handle of kind
// "RunCurve". A thread per run keeps the stream's queue filled ahead of the SYNC, publishes the
// progress, holds the end point until the axis reports it and then closes the stream.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "absl/strings/str_cat.h"
#include "adapters/core/curve_run.h"
#include "adapters/core/curve_runner.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/stober/drive.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;

// Set points queued ahead of the SYNC: about 100 ms of bus time, so a runner thread that is
// scheduled late on a loaded host does not leave cycles empty; well inside the stream's 64
// (decision 1208).
constexpr double kLeadS = 0.1;
constexpr size_t kMinLead = 4;
constexpr size_t kMaxLead = 48;
constexpr auto kTick = 5ms;
// Progress is republished when it moved this much (or reached 1): at most 200 updates per run.
constexpr double kProgressStep = 0.005;

}  // namespace

class StoberDrive::CurveRunner final : public CurveRunnerBase {
 public:
  CurveRunner(StoberDrive* drive, std::unique_ptr<CyclicStream> stream,
              std::vector<double> positions, std::vector<double> velocities, double tolerance_mm,
              size_t lead)
      : CurveRunnerBase(stream->command().id),
        drive_(drive),
        stream_(std::move(stream)),
        positions_(std::move(positions)),
        velocities_(std::move(velocities)),
        tolerance_mm_(tolerance_mm),
        lead_(lead) {}
  ~CurveRunner() override { Stop(); }

 private:
  void Run() override;
  // Deactivate: leave at once; the drive detaches the stream (no call back into it). A run whose
  // command ended closes its stream and leaves by itself (Join).
  void RequestStop() override { stop_ = true; }
  // Ends the handle unless a newer command took the tracker already.
  void End(CommandState state, const std::string& message) {
    std::lock_guard lock(drive_->mu_);
    if (drive_->tracker_ && drive_->tracker_->id == id()) drive_->EndTrackerLocked(state, message);
  }

  StoberDrive* const drive_;
  const std::unique_ptr<CyclicStream> stream_;
  const std::vector<double> positions_;
  const std::vector<double> velocities_;
  const double tolerance_mm_;
  const size_t lead_;
  std::atomic<bool> stop_{false};
};

void StoberDrive::CurveRunner::Run() {
  const size_t n = positions_.size();
  const double end = positions_.back();
  size_t next = 0;  // next curve set point to queue
  double reported = 0;
  std::optional<uint64_t> settle_after;  // status sequence when the last set point had gone out
  TimePoint settle_deadline{};
  uint64_t seq = drive_->GetStatus().sequence;
  while (!stop_) {
    const auto info = drive_->GetCommand(id());
    // Superseded by another motion command (ABORTED), cancelled by the motion core (I91, e.g.
    // event 78 after I423 without set points), fault or link loss (ERROR): stop streaming.
    if (!info || IsFinal(info->state)) break;
    const CyclicStats st = stream_->stats();
    uint64_t queued = st.received - std::min(st.received, st.sent + st.late);
    for (; queued < lead_; ++queued) {
      // After the curve the end point is held (v = 0): a cycle without a set point would be
      // extrapolated and, after I423, cancelled (L1344, L1767).
      const CyclicSetpoint sp =
          next < n ? CyclicSetpoint{positions_[next], velocities_[next]} : CyclicSetpoint{end, 0};
      if (!stream_->Push(sp).ok()) break;
      if (next < n) ++next;
    }
    const double progress =
        static_cast<double>(std::min<uint64_t>(st.sent, n)) / static_cast<double>(n);
    if (progress >= reported + kProgressStep || (progress >= 1 && reported < 1)) {
      drive_->UpdateProgress(id(), progress);
      reported = progress;
    }
    const DriveStatus s = drive_->GetStatus();
    if (st.sent >= n) {
      if (!settle_after) {
        settle_after = s.sequence;
        settle_deadline = drive_->clock_.Now() + drive_->config().timeouts.request;
      } else if (s.sequence > *settle_after && std::abs(s.position_mm - end) <= tolerance_mm_) {
        End(CommandState::kDone,
            absl::StrCat("end point ", end, " mm reached (actual ", s.position_mm, " mm)"));
        break;
      } else if (drive_->clock_.Now() > settle_deadline) {
        End(CommandState::kError,
            absl::StrCat("end point ", end, " mm not reached within ",
                         drive_->config().timeouts.request.count(),
                         " ms (timeouts.request) after the last set point: actual ", s.position_mm,
                         " mm, tolerance ", tolerance_mm_, " mm"));
        break;
      }
    }
    seq = drive_->WaitForStatus(std::max(seq, s.sequence), std::chrono::steady_clock::now() + kTick)
              .sequence;
  }
  if (stop_) return;
  // Close ends the cyclic command: MC_Stop while the axis still runs it (at the end point it
  // stands, the stop is immediate), nothing when a newer command superseded it; RPDO4 gets its
  // default mapping back (drive_cyclic.cpp).
  if (auto closed = stream_->Close(); !closed.ok()) {
    log::Warn("stober_curve_close", log::Fields()
                                        .Add("drive", drive_->config().name)
                                        .Add("command", id())
                                        .Add("error", std::string(closed.status().message())));
  }
}

absl::StatusOr<CommandInfo> StoberDrive::RunCurve(const Curve& curve,
                                                  const CurveRunOptions& options) {
  const std::string kind = "RunCurve";
  DGW_RETURN_IF_ERROR(RequireActive(kind.c_str()));
  const double tolerance = options.start_tolerance_mm;
  DGW_RETURN_IF_ERROR(CheckStartTolerance(Prefix(kind), tolerance));
  auto samples = SampleCurve(curve);
  if (!samples.ok()) return PrefixedStatus(samples.status(), Prefix(kind));
  // One set point per SYNC (A291 = the SYNC period, decision 1205); the derived velocity is the
  // feed-forward I426 of each set point (L1729, L1805).
  const double period_s = ToSeconds(config().canopen.sync_period);
  auto positions = ResampleCurve(*samples, period_s);
  if (!positions.ok()) return PrefixedStatus(positions.status(), Prefix(kind));
  CurveSamples velocity_column = *samples;
  velocity_column.position_mm = samples->velocity_mm_s;
  auto velocities = ResampleCurve(velocity_column, period_s);
  if (!velocities.ok()) return PrefixedStatus(velocities.status(), Prefix(kind));

  // The previous run must have let go of its stream; one still running refuses (the axis moves,
  // and MC_CyclicPosition "should be avoided" from motion, L1799).
  DGW_RETURN_IF_ERROR(JoinEndedRunner(
      curve_mu_, curve_, [&](uint64_t id) { return GetCommand(id); }, Prefix(kind),
      " (a cyclic start from motion should be avoided, stober-motion.md L1799)"));

  const double start = positions->front();
  auto at_start = [&]() -> absl::Status {  // under mu_, right before the edge
    const DriveStatus now = BuildStatusLocked();
    if (now.state == DriveState::kMoving) {
      return absl::FailedPreconditionError(
          absl::StrCat(Prefix(kind), "axis is moving (", now.native.text,
                       "); a curve starts from standstill (stober-motion.md L1799)"));
    }
    if (std::abs(actual_.position - start) > tolerance) {
      return absl::FailedPreconditionError(absl::StrCat(
          Prefix(kind), "axis at ", actual_.position, " mm, curve '", curve.name, "' starts at ",
          start, " mm (start_tolerance_mm ", tolerance, "); move to the start first"));
    }
    return absl::OkStatus();
  };
  auto stream = OpenCyclic(CyclicMode::kPosition, kind, at_start);
  if (!stream.ok()) return stream.status();
  const uint64_t id = (*stream)->command().id;
  if (const auto info = GetCommand(id); !info || IsFinal(info->state)) {
    // The edge was not taken (decision 1207) or the drive failed at once: the handle says why.
    (void)(*stream)->Close();
    if (!info) return absl::InternalError(Prefix(kind) + "command lost");
    return *GetCommand(id);
  }
  UpdateProgress(id, 0);
  const auto lead =
      std::clamp<size_t>(static_cast<size_t>(std::ceil(kLeadS / period_s)), kMinLead, kMaxLead);
  auto runner = std::make_shared<CurveRunner>(this, std::move(*stream), *std::move(positions),
                                              *std::move(velocities), tolerance, lead);
  StoreRunner(curve_mu_, curve_, runner);
  runner->Start();
  log::Info("stober_curve_run", log::Fields()
                                    .Add("drive", config().name)
                                    .Add("command", id)
                                    .Add("curve", curve.name)
                                    .Add("lead", static_cast<uint64_t>(lead)));
  return *GetCommand(id);
}

void StoberDrive::StopCurveRunner() { StopRunner(curve_mu_, curve_); }

}  // namespace drivegw::stober
