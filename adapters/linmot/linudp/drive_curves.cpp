// LinMotUdpDrive curves (issue 6): DownloadCurve / UploadCurve through the LinUDP curve service
// with read-back, RunCurve as 044h with progress and end-point check.
// docs/decisions/013-curve-run.md, 706-linmot-curve-info-block.md,
// 707-linudp-curve-download-run.md.
#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/curve_run.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/linmot/linudp/curve_service.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/linmot/mc/state_var.h"

namespace drivegw::linmot::linudp {
namespace {

// [CS] waits 1.5 s per curve block (linmot-linudp.md 5.1.6); never less than that.
constexpr Duration kCurveBlockTimeout = std::chrono::milliseconds(1500);
// Progress is republished in steps of at least 1 % (the status stream is not a sample stream).
constexpr double kProgressStep = 0.01;

absl::Status Prefixed(const std::string& where, const absl::Status& s) {
  return absl::Status(s.code(), absl::StrCat(where, ": ", s.message()));
}

}  // namespace

absl::Status LinMotUdpDrive::WithCurveService(
    const std::function<absl::Status(CurveService&)>& fn) {
  // One curve sequence at a time on the RTC channel; other RTC users wait.
  std::lock_guard rtc(rtc_mu_);
  const Duration timeout = std::max<Duration>(config().timeouts.request, kCurveBlockTimeout);
  CurveService service(name_,
                       [&](uint8_t id, uint16_t w2, uint16_t w3, uint16_t w4,
                           const std::string& what) -> absl::StatusOr<RtcReply> {
                         std::unique_lock lock(mu_);
                         const TimePoint deadline = clock_.Now() + timeout;
                         DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, what.c_str()));
                         return RtcTransactLocked(lock, id, w2, w3, w4, deadline, timeout, what);
                       });
  return fn(service);
}

absl::Status LinMotUdpDrive::EnsureCurve(const WireCurve& wire, bool force) {
  const uint16_t id = wire.info.curve_id;
  uint64_t epoch = 0;
  {
    std::lock_guard lock(mu_);
    auto it = verified_curves_.find(id);
    if (!force && it != verified_curves_.end() && it->second == wire) return absl::OkStatus();
    verified_curves_.erase(id);  // whatever happens next, the drive's curve is unknown
    epoch = curve_epoch_;
  }
  log::Info("curve_download", log::Fields()
                                  .Add("drive", name_)
                                  .Add("curve_id", int{id})
                                  .Add("points", static_cast<int64_t>(wire.points.size())));
  DGW_RETURN_IF_ERROR(WithCurveService([&](CurveService& s) { return s.Download(wire); }));
  std::lock_guard lock(mu_);
  // Only a curve verified within one unbroken link is known to be on the drive.
  if (curve_epoch_ == epoch) verified_curves_[id] = wire;
  return absl::OkStatus();
}

absl::Status LinMotUdpDrive::DownloadCurve(const LinMotParametricCurve& curve) {
  DGW_RETURN_IF_ERROR(RequireActive("DownloadCurve"));
  const std::string where = absl::StrCat("drive '", name_, "': DownloadCurve");
  absl::StatusOr<WireCurve> wire = ToWireCurve(curve);
  if (!wire.ok()) return Prefixed(where, wire.status());
  // An explicit download always goes to the drive (the caller may know better than the cache).
  return EnsureCurve(*wire, /*force=*/true);
}

absl::StatusOr<LinMotParametricCurve> LinMotUdpDrive::UploadCurve(int curve_id) {
  DGW_RETURN_IF_ERROR(RequireActive("UploadCurve"));
  using L = LinMotParametricCurve;
  if (curve_id < L::kMinCurveId || curve_id > L::kMaxCurveId) {
    return absl::InvalidArgumentError(absl::StrCat("drive '", name_, "': UploadCurve: curve_id ",
                                                   curve_id, " outside ", L::kMinCurveId, "..",
                                                   L::kMaxCurveId, " (linmot-mc.md §7 L997)"));
  }
  WireCurve wire;
  DGW_RETURN_IF_ERROR(WithCurveService([&](CurveService& s) -> absl::Status {
    DGW_ASSIGN_OR_RETURN(wire, s.Upload(static_cast<uint16_t>(curve_id)));
    return absl::OkStatus();
  }));
  absl::StatusOr<LinMotParametricCurve> model = FromWireCurve(wire);
  if (!model.ok()) {
    return absl::DataLossError(
        absl::StrCat("drive '", name_, "': UploadCurve: ", model.status().message()));
  }
  return model;
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::RunCurve(const Curve& curve,
                                                     const CurveRunOptions& options) {
  DGW_RETURN_IF_ERROR(RequireActive("RunCurve"));
  const std::string where = absl::StrCat("drive '", name_, "': RunCurve '", curve.name, "'");
  // Decision 013: a parametric curve runs under its own ID, a position/time curve under the
  // scratch ID; both in wire form (ToLinMotCurve) with its default start parameters.
  const auto* parametric = std::get_if<LinMotParametricCurve>(&curve.shape);
  const int id = parametric ? parametric->curve_id : options.linmot_scratch_curve_id;
  absl::StatusOr<LinMotParametricCurve> model = ToLinMotCurve(curve, id);
  if (!model.ok()) return Prefixed(where, model.status());
  absl::StatusOr<WireCurve> wire = ToWireCurve(*model);
  if (!wire.ok()) return Prefixed(where, wire.status());
  absl::StatusOr<CurveSamples> samples = SampleCurve(Curve{curve.name, "", *model});
  if (!samples.ok()) return Prefixed(where, samples.status());
  const double start_mm = samples->position_mm.front();
  const double end_mm = samples->position_mm.back();
  const Duration duration =
      FromSeconds(samples->time_step_s * static_cast<double>(samples->position_mm.size() - 1));

  // Decision 013: the axis must stand at the curve's start. Checked before the download (fail
  // fast) and again right before the command leaves.
  auto check_start = [&]() -> absl::Status {
    std::lock_guard lock(mu_);
    if (!OnlineLocked()) {
      return absl::UnavailableError(
          absl::StrCat(where, ": no reply from ", endpoint(), " (link ", ToString(link_), ")"));
    }
    if (MainStateLocked() != static_cast<uint8_t>(mc::MainState::kOperationEnabled)) {
      return absl::FailedPreconditionError(absl::StrCat(
          where, ": needs main state 8 (Operation Enabled), drive is in ", StateTextLocked()));
    }
    const double actual_mm =
        static_cast<double>(sample_.actual_position) * LinMotParametricCurve::kPointUnitMm;
    if (std::abs(actual_mm - start_mm) > options.start_tolerance_mm) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "%s: the axis stands at %.4f mm, the curve starts at %.4f mm (start_tolerance_mm "
          "%g); move to the start first",
          where, actual_mm, start_mm, options.start_tolerance_mm));
    }
    return absl::OkStatus();
  };
  {
    // Decision 707: a curve is not rewritten under a run that still uses its ID.
    std::lock_guard lock(mu_);
    auto cached = verified_curves_.find(wire->info.curve_id);
    const bool same = cached != verified_curves_.end() && cached->second == *wire;
    if (!same && motion_ && motion_->curve && motion_->curve->curve_id == wire->info.curve_id) {
      return absl::FailedPreconditionError(
          absl::StrCat(where, ": curve ", wire->info.curve_id, " is running (command ", motion_->id,
                       "); stop it or run this curve under another ID"));
    }
  }
  DGW_RETURN_IF_ERROR(check_start());
  if (absl::Status s = EnsureCurve(*wire, /*force=*/false); !s.ok()) return Prefixed(where, s);

  std::unique_lock op = LockOperation();
  DGW_RETURN_IF_ERROR(check_start());
  // §5.5 044h (L528): offset 0.1 µm, time scale UInt16 0.01 %, amplitude SInt16 0.1 % — the
  // curve's defaults, which ToWireCurve checked against those ranges.
  const CurveInfoBlock& info = wire->info;
  const mc::McCommand cmd = mc::TimeCurveWithAdjustableOffsetTimeScaleAmplitudeScale(
      info.curve_id, info.default_offset, static_cast<uint16_t>(info.default_time_scale),
      static_cast<int16_t>(info.default_amplitude_scale));
  CurveTrack track;
  track.curve_id = info.curve_id;
  track.end_mm = end_mm;
  track.tolerance_mm = options.start_tolerance_mm;
  track.duration = duration;
  return RunMotion("RunCurve", cmd, /*needs_in_target=*/false, duration, track);
}

std::optional<std::pair<CommandState, std::string>> LinMotUdpDrive::EvaluateCurveLocked(
    MotionTracker& m, TimePoint now, bool finished) {
  CurveTrack& c = *m.curve;
  if (finished) {
    // Decision 707: DONE = set-point generation over and the axis at the curve's end point (the
    // manual does not say that a curve sets In Target Position). Outside the tolerance the axis
    // may still be settling: wait until the D-11 completion deadline, then ERROR.
    const double actual_mm =
        static_cast<double>(sample_.actual_position) * LinMotParametricCurve::kPointUnitMm;
    if (std::abs(actual_mm - c.end_mm) > c.tolerance_mm) {
      if (!m.completion_deadline || now < *m.completion_deadline) return std::nullopt;
      return std::make_pair(
          CommandState::kError,
          absl::StrFormat("curve ended at %.4f mm, %.4f mm from its end point %.4f mm "
                          "(tolerance %g mm)",
                          actual_mm, actual_mm - c.end_mm, c.end_mm, c.tolerance_mm));
    }
    UpdateProgress(m.id, 1.0);
    return std::make_pair(CommandState::kDone, std::string());
  }
  if (c.started) {
    const double elapsed = ToSeconds(now - *c.started);
    const double total = ToSeconds(c.duration);
    const double progress = total > 0 ? std::clamp(elapsed / total, 0.0, 1.0) : 1.0;
    if (progress - c.reported >= kProgressStep || (progress == 1.0 && c.reported < 1.0)) {
      c.reported = progress;
      UpdateProgress(m.id, progress);
    }
  }
  return std::nullopt;
}

}  // namespace drivegw::linmot::linudp
