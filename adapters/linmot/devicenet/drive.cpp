// LinMotDnDrive: control word sequences, Addressed command transactions, background reads,
// motion and homing trackers, status mapping (linmot-devicenet.md §7, §8, §11).
#include "adapters/linmot/devicenet/drive.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "adapters/core/log.h"
#include "adapters/core/motion_limits.h"
#include "adapters/core/status.h"
#include "adapters/core/units.h"
#include "adapters/linmot/common/command_status.h"
#include "adapters/linmot/common/session_peer.h"
#include "adapters/linmot/common/status_publish.h"

namespace drivegw::linmot::devicenet {
namespace {

constexpr uint16_t kRun = ControlWord::kRunRequest;
constexpr uint16_t kStop = ControlWord::kStopRequest;
constexpr uint16_t kInit = ControlWord::kInitRequest;

// Velocity from actual positions at least this far apart (decision 982).
constexpr Duration kMinVelocityWindow = std::chrono::milliseconds(20);
// Below this measured speed an axis outside In Position counts as standing (decision 982):
// a few position increments (19.5 µm) per velocity window.
constexpr double kStandstillMmS = 2.0;
// §8.4: position set-points are ±32256 increments (±630 mm).
constexpr int64_t kPositionLimit = 32256;
// Home: INIT that ran between two polls is recognised after this many answered polls without
// the INIT State bit (decision 984).
constexpr int kInitSettleResponses = 3;

// A new fault's details (0x0A, 0x08) are read within this many responses (decision 982).
constexpr int kFaultHoldResponses = 4;

// Native fault codes for errors that are not coded errors (decision 986).
constexpr uint32_t kFaultMotorError = 0x0001'0000;
constexpr uint32_t kFaultSystemError = 0x0002'0000;
constexpr uint32_t kFaultPendingUnread = 0x0003'0000;

std::string Hex16(uint16_t v) { return absl::StrFormat("0x%04X", v); }

// Coded errors that no reset can cure: hardware or firmware mismatch (decision 986).
bool IsFatalCoded(uint16_t code) {
  return code == kCodedNeedsDnController || code == kCodedProcessorSpeed;
}

// STYLE §6 codes for a command the drive refused with a coded error (decision 985).
absl::StatusCode CodeFor(uint16_t coded) {
  switch (coded) {
    case kCodedRangeError:
      return absl::StatusCode::kOutOfRange;
    case kCodedUnknownCommand:
    case kCodedDriveNotSpecified:
    case kCodedDriveNotMaster:
      return absl::StatusCode::kInvalidArgument;
    default:
      return absl::StatusCode::kFailedPrecondition;
  }
}

// Rounds a profile limit down (the drive never exceeds what was commanded, decision 984) and
// checks it against the command's range.
absl::StatusOr<uint16_t> LimitToDn(const std::string& field, double value, double unit, int64_t lo,
                                   int64_t hi, const char* unit_text) {
  if (!std::isfinite(value)) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " is not a finite number"));
  }
  const double scaled = std::floor(value / unit + 1e-9);
  if (scaled < static_cast<double>(lo) || scaled > static_cast<double>(hi)) {
    return absl::OutOfRangeError(absl::StrFormat(
        "%s: %g is outside the settable range [%g, %g] (%d..%d x %s, linmot-devicenet.md §0.5)",
        field, value, static_cast<double>(lo) * unit, static_cast<double>(hi) * unit, lo, hi,
        unit_text));
  }
  return static_cast<uint16_t>(scaled);
}

// Time from rest over `distance` with a trapezoid or triangle, after stopping from `v0`.
double PlannedSeconds(double distance, double v0, double vmax, double acc) {
  if (vmax <= 0 || acc <= 0) return 0;
  const double stop_s = std::fabs(v0) / acc;
  const double d = std::fabs(distance) + v0 * v0 / (2 * acc);
  if (d <= 0) return stop_s;
  const double ramps = vmax * vmax / acc;
  if (d >= ramps) return stop_s + 2 * vmax / acc + (d - ramps) / vmax;
  return stop_s + 2 * std::sqrt(d / acc);
}

std::string JoinNames(const std::vector<std::string>& names) { return absl::StrJoin(names, ", "); }

std::vector<std::string> Named(WordKind kind, uint16_t raw, uint16_t ignore_mask = 0) {
  std::vector<std::string> out;
  for (const std::string& n : SetBitNames(kind, static_cast<uint16_t>(raw & ~ignore_mask))) {
    if (n != "Reserved" && n != "reserved") out.push_back(n);
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pure helpers.

DriveState MapDnState(bool online, StatusLowWord low, Motor motor, bool motion_active) {
  if (!online) return DriveState::kOffline;
  if (low.error_state() || low.error_pending()) return DriveState::kFault;
  if (low.emergency_stop()) return DriveState::kDisabled;
  if (low.init_state()) return DriveState::kHoming;
  if (low.run_state()) {
    return motion_active && !low.in_position(motor) ? DriveState::kMoving : DriveState::kEnabled;
  }
  if (low.disable_state()) return DriveState::kDisabled;
  return DriveState::kReady;  // STOPPED: initialised, RUN not requested (D-10)
}

absl::StatusOr<int16_t> PositionToDn(const std::string& field, double mm) {
  DGW_ASSIGN_OR_RETURN(const int64_t v, units::ToFixed(field, mm, kPositionIncrementsPerMm,
                                                       -kPositionLimit, kPositionLimit));
  return static_cast<int16_t>(v);
}

double PositionFromDn(int32_t increments) { return increments / kPositionIncrementsPerMm; }

absl::StatusOr<uint16_t> SpeedToDn(const std::string& field, double mm_s) {
  return LimitToDn(field, mm_s, kMmSPerSpeedIncrement, 6, 24576, "190.735 µm/s");
}

absl::StatusOr<uint16_t> AccelerationToDn(const std::string& field, double mm_s2) {
  return LimitToDn(field, mm_s2, kMmS2PerAccelerationIncrement, 1, 1536, "238.419 mm/s²");
}

// ---------------------------------------------------------------------------------------------
// Lifecycle.

LinMotDnDrive::LinMotDnDrive(DriveConfig config, const Clock& clock, DnDriveOptions options)
    : DriveBase(std::move(config)),
      clock_(clock),
      name_(this->config().name),
      options_(std::move(options)) {}

LinMotDnDrive::~LinMotDnDrive() { Deactivate(); }

std::string LinMotDnDrive::endpoint() const {
  const std::string bus = config().can ? transport::CanSpecString(*config().can) : "?";
  return absl::StrCat("devicenet://", bus, "/", config().mac_id.value_or(0));
}

absl::Status LinMotDnDrive::DoActivate() {
  if (!config().can || !config().mac_id) {
    return absl::InvalidArgumentError("can and mac_id are required (family linmot-devicenet)");
  }
  const IoLayout& layout = options_.layout;
  DGW_RETURN_IF_ERROR(ValidateLayout(layout));
  const ModuleSet& m = layout.modules;
  if (!m.control_in || !m.addressed_in || !m.status_out || !m.addressed_out) {
    return absl::InvalidArgumentError(absl::StrCat(
        "devicenet layout: ", ConsumedModulesText(layout), " / ", ProducedModulesText(layout),
        " lacks Control In, Addressed In, Status Out or Addressed Out (decision 981)"));
  }
  if ((layout.master_drives & MotorMask()) == 0) {
    return absl::InvalidArgumentError(absl::StrCat("devicenet motor ", MotorName(options_.motor),
                                                   " is not a master drive of the layout"));
  }
  std::shared_ptr<Session> session = options_.session_override;
  if (!session) {
    auto acquired = SessionPool::Instance().Acquire(*config().can, options_.session, clock_);
    if (!acquired.ok()) return acquired.status();
    session = *acquired;
  }
  {
    std::lock_guard lock(mu_);
    active_ = true;
    link_ = LinkState::kUnknown;
    link_reason_.clear();
    sample_ = Sample{};
    cache_ = Cache{};
    history_.clear();
    velocity_mm_s_ = 0;
    // §11.2 step 8: the first poll carries control word 0 and No Command.
    control_word_ = 0;
    ++cw_generation_;
    tx_.reset();
    motion_.reset();
    homing_.reset();
    published_.reset();
  }
  PeerOptions po;
  po.name = name_;
  po.mac_id = *config().mac_id;
  po.consumed_size = ConsumedSize(layout);
  po.produced_size = ProducedSize(layout);
  po.poll_period = options_.poll_period;
  po.response_timeout = options_.response_timeout;
  po.expected_packet_rate_ms = options_.expected_packet_rate_ms;
  po.explicit_epr_ms = options_.explicit_epr_ms;
  po.explicit_timeout = options_.explicit_timeout;
  po.restart_wait = options_.restart_wait;
  // drives[i].health (decision 1431); absent keys keep the session defaults (the watchdog
  // decides, set-up back-off 100 ms..2 s). Register validates, naming the key.
  const HealthOverrides& h = config().health;
  if (h.down_after_failures) po.down_after_failures = *h.down_after_failures;
  if (h.backoff_min) po.retry_min = *h.backoff_min;
  if (h.backoff_max) po.retry_max = *h.backoff_max;
  if (h.up_after) po.up_after = *h.up_after;
  po.wire_trace = wire_trace_;
  absl::StatusOr<PeerId> id = session->Register(po, this);
  std::lock_guard lock(mu_);
  if (!id.ok()) {
    active_ = false;
    return id.status();
  }
  session_ = session;
  peer_id_ = *id;
  PublishLocked(true);
  return absl::OkStatus();
}

void LinMotDnDrive::DoDeactivate() {
  StopCurveRunner();  // decision 987: its legs go through this connection
  {
    // §11.9: clear the control word for an answered poll before releasing the set.
    std::unique_lock lock(mu_);
    if (OnlineLocked() && control_word_ != 0) {
      SetControlWordLocked(0);
      const auto bound =
          std::min<Duration>(config().timeouts.request, std::chrono::milliseconds(500));
      WaitControlWordLocked(lock, clock_.Now() + bound);
    }
  }
  // Unregisters outside mu_; no callback runs after this returns.
  std::shared_ptr<Session> session = DetachSessionPeer(mu_, session_, peer_id_, active_);
  {
    std::lock_guard lock(mu_);
    if (motion_) UpdateCommand(motion_->id, CommandState::kAborted, "drive deactivated");
    if (homing_) UpdateCommand(homing_->id, CommandState::kAborted, "drive deactivated");
    motion_.reset();
    homing_.reset();
    tx_.reset();
    link_ = LinkState::kUnknown;
    PublishLocked(true);
    cv_.notify_all();
  }
  session.reset();  // the last drive on a bus closes the channel here, outside mu_
}

std::optional<PeerCounters> LinMotDnDrive::exchange_counters() const {
  return SessionPeerCounters(mu_, session_, peer_id_);
}

std::optional<SessionCounters> LinMotDnDrive::session_counters() const {
  return SessionCountersOf(mu_, session_);
}

// ---------------------------------------------------------------------------------------------
// I/O thread side.

CommandSlot LinMotDnDrive::BackgroundSlotLocked() {
  // §11.4: a standing Get is answered with the live value; the rotation reads position, set-point
  // and, while pending, the error and warning details (§11.7 step 1).
  const Motor m = options_.motor;
  std::vector<Command> list;
  if (sample_.low.error_pending() || sample_.low.error_state()) {
    // First after a new fault (rotation_ restarts at 0): coded error, motor, system word.
    list.push_back(Command{Raw(CommandId::kGetCodedError), std::nullopt, false, 0});
    list.push_back(Command{Raw(CommandId::kGetErrorState), m, false, 0});
    list.push_back(Command{Raw(CommandId::kGetErrorState), std::nullopt, false, 0});
  }
  list.push_back(Command{Raw(CommandId::kGetActualPosition), m, false, 0});
  list.push_back(Command{Raw(CommandId::kGetPositionSetpoint), m, false, 0});
  if (sample_.low.warning_pending()) {
    list.push_back(Command{Raw(CommandId::kGetWarnState), std::nullopt, false, 0});
    list.push_back(Command{Raw(CommandId::kGetWarnState), m, false, 0});
  }
  const Command& c = list[rotation_++ % list.size()];
  auto slot = EncodeCommand(c, Module::kAddressed);
  return slot.ok() ? *slot : CommandSlot{};
}

std::vector<uint8_t> LinMotDnDrive::BuildPollCommand() noexcept {
  std::lock_guard lock(mu_);
  ConsumedImage image = EmptyConsumed(options_.layout);
  image.control = ControlWord{control_word_};
  ++poll_gen_;
  if (tx_ && !tx_->done && tx_->once && tx_->first_gen != 0) {
    tx_->done = true;  // D-28: a Reset Controller left standing would reset the drive again
  }
  if (tx_ && !tx_->done) {
    if (tx_->first_gen == 0) tx_->first_gen = poll_gen_;
    image.addressed = tx_->slot;
    if (tx_->once) cv_.notify_all();
  } else {
    image.addressed = BackgroundSlotLocked();
  }
  cw_in_flight_ = cw_generation_;
  urgent_ = false;
  auto bytes = EncodeConsumed(options_.layout, image);
  if (!bytes.ok()) {
    log::Error("devicenet_internal",
               log::Fields().Add("drive", name_).Add("error", bytes.status().message()));
    return std::vector<uint8_t>(ConsumedSize(options_.layout), 0);
  }
  return *std::move(bytes);
}

bool LinMotDnDrive::HasUrgentRequest() noexcept {
  std::lock_guard lock(mu_);
  return urgent_;
}

void LinMotDnDrive::MarkUrgentLocked() {
  urgent_ = true;
  if (session_) session_->Expedite();
}

void LinMotDnDrive::SetControlWordLocked(uint16_t cw) {
  if (control_word_ == cw) return;
  control_word_ = cw;
  ++cw_generation_;
  MarkUrgentLocked();
  log::Debug("control_word", log::Fields().Add("drive", name_).Add("cw", Hex16(cw)));
}

void LinMotDnDrive::AbsorbResponseLocked(CommandSlot addressed) {
  auto r = DecodeResponse(addressed);
  if (!r.ok() || r->spec == nullptr || r->spec->kind != CommandKind::kGet) return;
  const uint8_t mask = r->echo.motor_mask;
  const bool ours = mask == MotorMask();
  const uint16_t raw = r->raw_value;
  switch (static_cast<CommandId>(r->spec->id)) {
    case CommandId::kGetActualPosition:
      if (!ours) return;
      cache_.actual_position = static_cast<int16_t>(raw);
      cache_.actual_gen = answered_gen_;
      history_.push_back({sample_.received, *cache_.actual_position});
      break;
    case CommandId::kGetPositionSetpoint:
      if (!ours) return;
      cache_.setpoint = static_cast<int16_t>(raw);
      cache_.setpoint_gen = answered_gen_;
      break;
    case CommandId::kGetCodedError:
      cache_.coded_error = raw;
      break;
    case CommandId::kGetErrorState:
      if (mask == 0) cache_.system_error = raw;
      if (ours) cache_.motor_error = raw;
      break;
    case CommandId::kGetWarnState:
      if (mask == 0) cache_.system_warn = raw;
      if (ours) cache_.motor_warn = raw;
      break;
    default:
      break;
  }
}

void LinMotDnDrive::OnPollResponse(std::span<const uint8_t> produced, TimePoint received) noexcept {
  std::lock_guard lock(mu_);
  if (!active_) return;
  auto image = DecodeProduced(options_.layout, produced);
  if (!image.ok() || !image->status_low || !image->addressed) {
    log::Debug("devicenet_response_undecodable",
               log::Fields().Add("drive", name_).Add("error", image.status().message()));
    return;
  }
  sample_.valid = true;
  sample_.low = *image->status_low;
  sample_.high = image->status_high.value_or(StatusHighWord{});
  sample_.received = received;
  sample_.gen = poll_gen_;
  answered_gen_ = poll_gen_;
  cw_answered_ = cw_in_flight_;
  AbsorbResponseLocked(*image->addressed);

  if (tx_ && !tx_->done && tx_->first_gen != 0 && answered_gen_ >= tx_->first_gen) {
    if (!tx_->error_before && sample_.low.error_pending()) tx_->error_rose = true;
    const bool toggle_ok =
        !tx_->toggle || ToggleAccepted(CommandWord::FromRaw(tx_->slot.word).toggle, sample_.high,
                                       tx_->motor.value_or(options_.motor));
    // §11.4: done when a poll that carried it is answered with its echo (and, for T-commands,
    // the Command Toggle bit equals T — unless the drive refused it, D-7).
    if (image->addressed->word == tx_->slot.word && (toggle_ok || tx_->error_rose)) {
      tx_->done = true;
      tx_->response = *image->addressed;
      tx_->low_at_response = sample_.low;
      tx_->response_gen = answered_gen_;
    }
  }
  if (!sample_.low.error_pending() && !sample_.low.error_state()) {
    cache_.coded_error.reset();
    cache_.system_error.reset();
    cache_.motor_error.reset();
  }
  if (!sample_.low.warning_pending()) {
    cache_.system_warn.reset();
    cache_.motor_warn.reset();
  }

  // Velocity: difference quotient over the newest sample at least one window old (decision 982).
  const Duration window = std::max(kMinVelocityWindow, 4 * options_.poll_period);
  while (history_.size() >= 2 && received - history_[1].t >= window) history_.pop_front();
  if (history_.size() >= 2) {
    const double dt = ToSeconds(history_.back().t - history_.front().t);
    if (dt > 0) {
      velocity_mm_s_ =
          PositionFromDn(int32_t{history_.back().actual} - history_.front().actual) / dt;
    }
  } else {
    velocity_mm_s_ = 0;
  }

  // Decision 982: a new fault is published with its code and text; its details take one to
  // three more (urgent) polls, for which status and trackers wait.
  if (FaultPendingLocked() && !FaultDetailsKnownLocked() && fault_hold_ < kFaultHoldResponses) {
    if (fault_hold_ == 0) rotation_ = 0;
    ++fault_hold_;
    MarkUrgentLocked();
    cv_.notify_all();
    return;
  }
  if (!FaultPendingLocked()) fault_hold_ = 0;
  // Status first: a handle that ends on this response is then republished with this sample.
  PublishLocked(false);
  EvaluateTrackersLocked(received);
  cv_.notify_all();
}

void LinMotDnDrive::OnLinkChange(LinkState state, const std::string& reason) noexcept {
  std::lock_guard lock(mu_);
  if (!active_) return;
  link_ = state;
  link_reason_ = reason;
  if (state == LinkState::kOffline) {
    // Decision 983: the next connection starts from a fresh image (control word 0, No Command);
    // nothing of this one is replayed. Open handles end: their outcome is unknowable now.
    ++connection_;
    control_word_ = 0;
    ++cw_generation_;
    tx_.reset();
    cache_ = Cache{};  // D-29: a restarted drive lost its RAM values (filter limits included)
    history_.clear();
    velocity_mm_s_ = 0;
    sample_.valid = false;
    const std::string why = absl::StrCat("link to ", endpoint(), " lost: ", reason);
    if (motion_) UpdateCommand(motion_->id, CommandState::kError, why);
    if (homing_) UpdateCommand(homing_->id, CommandState::kError, why);
    motion_.reset();
    homing_.reset();
  }
  PublishLocked(true);
  cv_.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Trackers (evaluated on every response).

void LinMotDnDrive::EvaluateTrackersLocked(TimePoint now) {
  EvaluateMotionLocked(now);
  EvaluateHomingLocked(now);
}

void LinMotDnDrive::EvaluateMotionLocked(TimePoint now) {
  if (!motion_) return;
  const MotionTracker m = *motion_;
  auto end = [&](CommandState st, const std::string& message) {
    UpdateCommand(m.id, st, message);
    motion_.reset();
  };
  if (FaultPendingLocked()) return end(CommandState::kError, "drive fault: " + FaultLocked().text);
  if (!sample_.low.run_state()) {
    return end(CommandState::kAborted,
               absl::StrCat("interrupted: drive left RUN, now ", StateTextLocked()));
  }
  if (answered_gen_ <= m.accepted_gen) return;  // not yet a response after the acceptance
  if (cache_.setpoint && cache_.setpoint_gen > m.accepted_gen && *cache_.setpoint != m.target) {
    return end(CommandState::kAborted,
               absl::StrCat("superseded on the drive (position set-point ", *cache_.setpoint,
                            ", commanded ", m.target, ")"));
  }
  // DONE with a position read from this very response, so that the snapshot published with the
  // handle shows where the axis stopped (the rotation reads it every other poll).
  if (sample_.low.in_position(options_.motor) && cache_.actual_gen == answered_gen_) {
    return end(CommandState::kDone, "");
  }
  if (m.completion_deadline && now >= *m.completion_deadline) {
    end(CommandState::kError, "completion time-out: not In Position (decision 984)");
  }
}

void LinMotDnDrive::EvaluateHomingLocked(TimePoint now) {
  if (!homing_) return;
  HomingTracker& h = *homing_;
  auto end = [&](CommandState st, const std::string& message) {
    const uint64_t id = h.id;
    homing_.reset();
    PublishLocked(true);  // `homed` first, so that the handle's end shows it (decision 982)
    UpdateCommand(id, st, message);
  };
  if (FaultPendingLocked()) {
    SetControlWordLocked(0);
    return end(CommandState::kError, "drive fault: " + FaultLocked().text);
  }
  if (cw_answered_ < h.cw_gen) return;  // the drive has not seen this phase's control word yet
  const StatusLowWord low = sample_.low;
  switch (h.phase) {
    case HomingPhase::kStarting:
      if (low.init_state()) {
        h.phase = HomingPhase::kRunning;
        UpdateCommand(h.id, CommandState::kActive);
        break;
      }
      // An INIT shorter than a poll period is never seen: INIT Done without RUN after a few
      // answered polls means it ran (decision 984).
      if (low.init_done() && !low.run_state() && ++h.settle >= kInitSettleResponses) {
        UpdateCommand(h.id, CommandState::kActive);
        h.phase = HomingPhase::kRunning;
        break;
      }
      break;
    case HomingPhase::kRunning:
    case HomingPhase::kRestoring:
      break;
  }
  if (h.phase == HomingPhase::kRunning && !low.init_state()) {
    if (!low.init_done()) {
      SetControlWordLocked(0);
      return end(CommandState::kError, "INIT ended without INIT Done");
    }
    // Back to RUN: the request rises from 0 (lines 864, 910 want a fresh edge).
    SetControlWordLocked(kRun);
    h.cw_gen = cw_generation_;
    h.phase = HomingPhase::kRestoring;
    return;
  }
  if (h.phase == HomingPhase::kRestoring && low.run_state()) {
    return end(CommandState::kDone, "");
  }
  if (now >= h.deadline) {
    SetControlWordLocked(0);
    end(CommandState::kError, absl::StrCat("not homed within ", config().timeouts.homing.count(),
                                           " ms, drive in ", StateTextLocked()));
  }
}

// ---------------------------------------------------------------------------------------------
// Status.

std::string LinMotDnDrive::StateTextLocked() const {
  std::vector<std::string> names = Named(WordKind::kStatusLow, sample_.low.raw, 0x0F00);
  if (names.empty()) names.push_back("no state bit");
  return absl::StrCat(JoinNames(names), " (status low ", Hex16(sample_.low.raw), ")");
}

Fault LinMotDnDrive::FaultLocked() const {
  Fault f;
  if (!sample_.valid || !FaultPendingLocked()) return f;
  if (cache_.coded_error && *cache_.coded_error != kCodedNoError) {
    f.code = *cache_.coded_error;
    f.text = CodedErrorText(*cache_.coded_error);
    f.fatal = IsFatalCoded(*cache_.coded_error);
    return f;
  }
  if (cache_.motor_error && *cache_.motor_error != 0) {
    f.code = kFaultMotorError | *cache_.motor_error;
    f.text = absl::StrCat("Motor ", MotorName(options_.motor), ": ",
                          JoinNames(Named(WordKind::kMotorErrorState, *cache_.motor_error)));
    return f;
  }
  if (cache_.system_error && (*cache_.system_error & 0x0FFF) != 0) {
    f.code = kFaultSystemError | *cache_.system_error;
    f.text = JoinNames(Named(WordKind::kSystemErrorState, *cache_.system_error, 0xF000));
    return f;
  }
  f.code = kFaultPendingUnread | sample_.low.raw;
  f.text = "ERROR Pending (details not read yet)";
  return f;
}

std::vector<std::string> LinMotDnDrive::WarningsLocked() const {
  std::vector<std::string> out;
  if (!sample_.valid || !sample_.low.warning_pending()) return out;
  if (cache_.system_warn) {
    // Bits 12-15 only say which motor warns; the motor word names it.
    for (auto& n : Named(WordKind::kSystemWarnState, *cache_.system_warn, 0xF000)) {
      out.push_back(std::move(n));
    }
  }
  if (cache_.motor_warn) {
    for (auto& n : Named(WordKind::kMotorWarnState, *cache_.motor_warn))
      out.push_back(std::move(n));
  }
  if (out.empty()) out.push_back("WARNING Pending");
  return out;
}

bool LinMotDnDrive::FaultDetailsKnownLocked() const {
  if (!cache_.coded_error) return false;
  return *cache_.coded_error != kCodedNoError || (cache_.motor_error && cache_.system_error);
}

bool LinMotDnDrive::MotionActiveLocked() const {
  // Decision 982: no Motion Active bit in this generation. A gateway motion runs until In
  // Position; otherwise (native curves, braking after a RUN loss) the measured speed decides.
  const StatusLowWord low = sample_.low;
  if (!sample_.valid || !low.run_state()) return false;
  if (CurveOpenLocked()) return true;  // decision 987: In Position between legs is not the end
  if (low.in_position(options_.motor)) return false;
  return motion_.has_value() || std::fabs(velocity_mm_s_) > kStandstillMmS;
}

DriveStatus LinMotDnDrive::BuildStatusLocked() const {
  DriveStatus s;
  s.state = MapDnState(OnlineLocked(), sample_.low, options_.motor, MotionActiveLocked());
  if (s.state == DriveState::kEnabled && CurveOpenLocked()) s.state = DriveState::kMoving;  // 987
  if (!sample_.valid) {
    if (!link_reason_.empty()) s.native.text = link_reason_;
    return s;
  }
  const StatusLowWord low = sample_.low;
  // Decision 982: main state = the D-10 controller state, sub state = status high word.
  uint32_t main = 2;  // STOPPED
  if (low.disable_state()) main = 0;
  if (low.init_state()) main = 1;
  if (low.run_state()) main = 3;
  if (low.error_state() || low.error_pending()) main = 4;
  if (low.emergency_stop()) main = 5;
  s.native.main_state = main;
  s.native.sub_state = sample_.high.raw;
  s.native.text = StateTextLocked();
  s.native.status_word = low.raw | (static_cast<uint32_t>(sample_.high.raw) << 16);
  s.native.warn_word = cache_.motor_warn.value_or(0);
  if (cache_.actual_position) s.position_mm = PositionFromDn(*cache_.actual_position);
  if (cache_.setpoint) s.demand_position_mm = PositionFromDn(*cache_.setpoint);
  s.velocity_mm_s = velocity_mm_s_;
  // Homed: initialised, not (re-)initialising, no Home handle still restoring RUN.
  s.homed = low.init_done() && !low.init_state() && !homing_.has_value();
  s.in_target = low.in_position(options_.motor);
  s.motion_active = MotionActiveLocked();
  s.warnings = WarningsLocked();
  s.fault = FaultLocked();
  return s;
}

void LinMotDnDrive::PublishLocked(bool force) {
  DriveStatus s = BuildStatusLocked();
  const TimePoint now = clock_.Now();
  if (WithinHeartbeat(force, published_, published_at_, now) && SameStatus(*published_, s)) {
    return;
  }
  LogStateChange(published_, s, name_, "linmot-devicenet", "status_low",
                 [&] { return Hex16(sample_.low.raw); });
  published_ = s;
  published_at_ = now;
  PublishStatus(std::move(s));
}

// ---------------------------------------------------------------------------------------------
// Waiting and transactions.

template <typename Pred>
LinMotDnDrive::Wait LinMotDnDrive::WaitLocked(std::unique_lock<std::mutex>& lock,
                                              TimePoint deadline, Pred reached) {
  const uint64_t connection = connection_;
  return WaitPeerLocked<Wait>(
      cv_, lock, clock_, deadline, [&] { return active_; }, reached,
      [&] { return link_ == LinkState::kOffline || connection_ != connection; });
}

LinMotDnDrive::Wait LinMotDnDrive::WaitControlWordLocked(std::unique_lock<std::mutex>& lock,
                                                         TimePoint deadline) {
  const uint64_t gen = cw_generation_;
  return WaitLocked(lock, deadline, [&] { return cw_answered_ >= gen; });
}

absl::Status LinMotDnDrive::WaitOnlineLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline,
                                             const char* operation) {
  for (;;) {
    if (!active_) return WaitFailure(Wait::kInactive, operation, "");
    if (OnlineLocked()) return absl::OkStatus();
    const TimePoint now = clock_.Now();
    if (now >= deadline) {
      return absl::UnavailableError(absl::StrCat(
          "drive '", name_, "': ", operation, ": no poll response from ", endpoint(), " (link ",
          ToString(link_), link_reason_.empty() ? "" : ": ", link_reason_, ")"));
    }
    cv_.wait_for(lock, deadline - now);
  }
}

absl::Status LinMotDnDrive::WaitFailure(Wait w, const std::string& operation,
                                        const std::string& detail) const {
  return WaitPeerStatus(
      w, absl::StrCat("drive '", name_, "': ", operation, ": "), detail, endpoint(),
      [&] { return link_reason_.empty() ? std::string() : absl::StrCat(" (", link_reason_, ")"); });
}

absl::StatusOr<CommandInfo> LinMotDnDrive::Finish(uint64_t id, const absl::Status& status) {
  if (!status.ok()) {
    UpdateCommand(id, CommandState::kError, std::string(status.message()));
    return status;
  }
  UpdateCommand(id, CommandState::kDone);
  std::optional<CommandInfo> info = GetCommand(id);
  if (!info) return absl::InternalError(absl::StrCat("drive '", name_, "': command ", id, " lost"));
  return *info;
}

absl::StatusOr<LinMotDnDrive::Transaction> LinMotDnDrive::TransactLocked(
    std::unique_lock<std::mutex>& lock, const Command& command, TimePoint deadline,
    const std::string& what, bool strict) {
  if (!OnlineLocked()) {
    return absl::UnavailableError(
        absl::StrCat("drive '", name_, "': ", what, ": no poll response from ", endpoint()));
  }
  absl::StatusOr<CommandSlot> slot = EncodeCommand(command, Module::kAddressed, strict);
  if (!slot.ok()) {
    return absl::Status(slot.status().code(),
                        absl::StrCat("drive '", name_, "': ", what, ": ", slot.status().message()));
  }
  Transaction t;
  t.serial = ++tx_serial_;
  t.slot = *slot;
  t.spec = FindCommand(command.id);
  t.toggle = t.spec != nullptr && t.spec->toggle;
  t.motor = command.motor;
  t.error_before = sample_.low.error_pending();
  tx_ = t;
  MarkUrgentLocked();
  const uint64_t serial = t.serial;
  const Wait w =
      WaitLocked(lock, deadline, [&] { return tx_ && tx_->serial == serial && tx_->done; });
  if (w != Wait::kReached) {
    // A command that went out in a poll may have been executed: only its echo was lost (issue
    // 11 fault injection, decision 1422). Say so, so that a client does not blindly repeat a
    // relative move.
    const bool on_wire = tx_ && tx_->serial == serial && tx_->first_gen != 0;
    if (tx_ && tx_->serial == serial) tx_.reset();
    return WaitFailure(
        w, what,
        absl::StrFormat("no echo of command word %s within the time-out "
                        "(linmot-devicenet.md §11.4)%s",
                        Hex16(t.slot.word),
                        on_wire ? "; it went out in a poll, so the drive may have executed it: "
                                  "read the status before repeating it"
                                : ""));
  }
  Transaction done = *tx_;
  tx_.reset();  // background reads resume with the next poll (one-shot commands leave, §11.4)
  log::Debug("devicenet_command", log::Fields()
                                      .Add("drive", name_)
                                      .Add("word", Hex16(done.slot.word))
                                      .Add("value", Hex16(done.slot.value))
                                      .Add("response", Hex16(done.response.value)));
  return done;
}

absl::Status LinMotDnDrive::CodedErrorStatus(std::unique_lock<std::mutex>& lock,
                                             const std::string& what, TimePoint deadline) {
  // §11.4: ERROR Pending rose while the command was in flight: the drive refused it; its reason
  // is the coded error (0x0A, §8.6).
  auto code = GetLocked(lock, CommandId::kGetCodedError, std::nullopt, deadline);
  if (!code.ok() || *code == kCodedNoError) {
    return absl::FailedPreconditionError(
        absl::StrCat("drive '", name_, "': ", what, ": the drive reports ERROR Pending",
                     code.ok() ? "" : " (coded error unreadable)"));
  }
  const uint16_t coded = static_cast<uint16_t>(*code);
  absl::Status s(CodeFor(coded), absl::StrCat("drive '", name_, "': ", what,
                                              ": refused by the "
                                              "drive: ",
                                              CodedErrorText(coded)));
  AttachCodedError(s, coded);
  return s;
}

absl::StatusOr<int32_t> LinMotDnDrive::GetLocked(std::unique_lock<std::mutex>& lock, CommandId id,
                                                 std::optional<Motor> motor, TimePoint deadline) {
  const CommandSpec* spec = FindCommand(id);
  const std::string what = absl::StrCat("read ", spec ? spec->name : "?");
  DGW_ASSIGN_OR_RETURN(const Transaction t,
                       TransactLocked(lock, Command{Raw(id), motor, false, 0}, deadline, what));
  // A Get the drive cannot serve (e.g. 0x60 without encoder) answers 0 and raises a coded error.
  if (t.error_rose && id != CommandId::kGetCodedError) {
    return CodedErrorStatus(lock, what, deadline);
  }
  auto r = DecodeResponse(t.response);
  if (!r.ok()) return r.status();
  return r->value;
}

absl::Status LinMotDnDrive::WriteFilterLocked(std::unique_lock<std::mutex>& lock, CommandId id,
                                              uint16_t value, TimePoint deadline,
                                              const std::string& what) {
  std::optional<uint16_t>& cached =
      id == CommandId::kSetFilterMaxSpeed ? cache_.filter_speed : cache_.filter_acceleration;
  if (cached == value) return absl::OkStatus();
  DGW_ASSIGN_OR_RETURN(
      const Transaction t,
      TransactLocked(lock, Command{Raw(id), options_.motor, false, value}, deadline, what));
  if (t.error_rose) return CodedErrorStatus(lock, what, deadline);
  // The cache may have been cleared by a link loss while waiting: only a live connection keeps it.
  if (OnlineLocked()) cached = value;
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Control word sequences (§11.6, D-10).

absl::StatusOr<CommandInfo> LinMotDnDrive::Enable() {
  DGW_RETURN_IF_ERROR(RequireActive("Enable"));
  std::lock_guard op(op_mu_);
  const CommandInfo cmd = StartCommand("Enable", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const TimePoint deadline = clock_.Now() + config().timeouts.request;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Enable"));
    // INIT may move the slider for a while: its own bound (timeouts.homing).
    const TimePoint init_deadline = clock_.Now() + config().timeouts.homing;
    for (;;) {
      const StatusLowWord low = sample_.low;
      if (FaultPendingLocked()) {
        const Fault fault = FaultLocked();
        absl::Status s = absl::FailedPreconditionError(
            absl::StrCat("drive '", name_, "': Enable: drive reports a fault (", fault.text,
                         "); AcknowledgeFault first"));
        if (cache_.coded_error && *cache_.coded_error != 0)
          AttachCodedError(s, *cache_.coded_error);
        return s;
      }
      if (low.emergency_stop()) {
        return absl::FailedPreconditionError(absl::StrCat(
            "drive '", name_, "': Enable: drive is in Emergency Stop; release it first"));
      }
      if (low.run_state()) {
        SetControlWordLocked(kRun);  // take over the request the drive runs with
        return absl::OkStatus();
      }
      Wait w;
      if (low.init_state() || !low.init_done()) {
        // D-10: RUN needs INIT Done; INIT request from DISABLE (or let a running INIT finish).
        // INIT starts on a rising edge of the request: a request left standing is cleared first.
        if (control_word_ == kInit && !low.init_state()) {
          SetControlWordLocked(0);
          if (Wait w0 = WaitControlWordLocked(lock, deadline); w0 != Wait::kReached) {
            return WaitFailure(w0, "Enable", "control word 0x0000 not answered");
          }
        }
        SetControlWordLocked(kInit);
        w = WaitLocked(lock, init_deadline, [&] {
          return cw_answered_ >= cw_generation_ && !sample_.low.init_state() &&
                 (sample_.low.init_done() || FaultPendingLocked());
        });
        if (w != Wait::kReached) {
          return WaitFailure(
              w, "Enable",
              absl::StrCat("motor initialisation (INIT) did not finish within ",
                           config().timeouts.homing.count(), " ms, drive in ", StateTextLocked()));
        }
        continue;
      }
      // Lines 864, 910: RUN is entered on a rising edge of the RUN request.
      if (control_word_ & kRun) {
        SetControlWordLocked(0);
        w = WaitControlWordLocked(lock, deadline);
        if (w != Wait::kReached) {
          return WaitFailure(w, "Enable", "control word 0x0000 not answered");
        }
      }
      SetControlWordLocked(kRun);
      w = WaitLocked(lock, deadline, [&] {
        return cw_answered_ >= cw_generation_ && (sample_.low.run_state() || FaultPendingLocked());
      });
      if (w != Wait::kReached) {
        return WaitFailure(
            w, "Enable",
            absl::StrCat("RUN request not followed within ", config().timeouts.request.count(),
                         " ms, drive in ", StateTextLocked()));
      }
    }
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotDnDrive::Disable() {
  DGW_RETURN_IF_ERROR(RequireActive("Disable"));
  std::lock_guard op(op_mu_);
  const CommandInfo cmd = StartCommand("Disable", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const TimePoint deadline = clock_.Now() + config().timeouts.request;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Disable"));
    // §11.6: STOP request, RUN released; DONE once the drive left RUN (and INIT).
    SetControlWordLocked(kStop);
    const Wait w = WaitLocked(lock, deadline, [&] {
      return cw_answered_ >= cw_generation_ && !sample_.low.run_state() &&
             !sample_.low.init_state();
    });
    if (w != Wait::kReached) {
      return WaitFailure(w, "Disable",
                         absl::StrCat("still in ", StateTextLocked(), " after STOP request"));
    }
    return absl::OkStatus();
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotDnDrive::AcknowledgeFault() {
  DGW_RETURN_IF_ERROR(RequireActive("AcknowledgeFault"));
  std::lock_guard op(op_mu_);
  const CommandInfo cmd = StartCommand("AcknowledgeFault", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const TimePoint deadline = clock_.Now() + config().timeouts.request;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "AcknowledgeFault"));
    const bool fault = FaultPendingLocked();
    const bool warning = sample_.low.warning_pending();
    if (!fault && !warning) return absl::OkStatus();  // nothing pending, drive untouched
    if (fault && !cache_.coded_error) {
      // A fatal coded error must be known before any reset is sent (decision 986).
      DGW_RETURN_IF_ERROR(
          GetLocked(lock, CommandId::kGetCodedError, std::nullopt, deadline).status());
    }
    const Fault f = FaultLocked();
    if (fault && f.fatal) {
      absl::Status s = absl::FailedPreconditionError(absl::StrCat(
          "drive '", name_, "': AcknowledgeFault: ", f.text,
          " cannot be reset (hardware or firmware mismatch, decision 986); fix the cause"));
      AttachCodedError(s, static_cast<uint16_t>(f.code));
      return s;
    }
    // §11.7 step 3: release RUN for an answered poll, reset the latches.
    SetControlWordLocked(0);
    if (Wait w = WaitControlWordLocked(lock, deadline); w != Wait::kReached) {
      return WaitFailure(w, "AcknowledgeFault", "control word 0x0000 not answered");
    }
    auto reset = [&](CommandId id) -> absl::Status {
      const CommandSpec* spec = FindCommand(id);
      return TransactLocked(lock, Command{Raw(id), std::nullopt, false, 0}, deadline,
                            absl::StrCat("AcknowledgeFault: ", spec->name))
          .status();
    };
    if (fault) {
      DGW_RETURN_IF_ERROR(reset(CommandId::kResetCodedError));  // 0x0B
      DGW_RETURN_IF_ERROR(reset(CommandId::kResetErrorState));  // 0x09, all motors (D-22)
    }
    if (warning) DGW_RETURN_IF_ERROR(reset(CommandId::kResetWarnState));  // 0x07
    const uint64_t after = answered_gen_;
    const Wait w = WaitLocked(lock, deadline, [&] {
      return answered_gen_ > after && !FaultPendingLocked() &&
             (!warning || !sample_.low.warning_pending());
    });
    if (w != Wait::kReached) {
      absl::Status s = WaitFailure(
          w, "AcknowledgeFault",
          absl::StrCat("still pending after the resets: ",
                       FaultPendingLocked() ? FaultLocked().text : JoinNames(WarningsLocked()),
                       " (the cause persists)"));
      if (cache_.coded_error && *cache_.coded_error != 0) AttachCodedError(s, *cache_.coded_error);
      return s;
    }
    return absl::OkStatus();
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotDnDrive::Home() {
  DGW_RETURN_IF_ERROR(RequireActive("Home"));
  std::lock_guard op(op_mu_);
  std::unique_lock lock(mu_);
  const TimePoint now = clock_.Now();
  const TimePoint deadline = now + config().timeouts.request;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Home"));
  if (!sample_.low.run_state() || FaultPendingLocked()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "drive '", name_, "': Home needs RUN (ENABLED), drive is in ", StateTextLocked()));
  }
  const CommandInfo cmd = StartCommand("Home", true);
  motion_.reset();  // superseded (StartCommand aborted its handle)
  // §11.10: initialise / home = INIT request; RUN released so that it can rise again after.
  SetControlWordLocked(kInit);
  homing_ =
      HomingTracker{cmd.id, HomingPhase::kStarting, cw_generation_, now + config().timeouts.homing};
  const Wait w = WaitLocked(lock, deadline, [&] {
    return !homing_ || homing_->id != cmd.id || homing_->phase != HomingPhase::kStarting;
  });
  if (w != Wait::kReached) {
    if (homing_ && homing_->id == cmd.id) homing_.reset();
    SetControlWordLocked(0);
    absl::Status s = WaitFailure(
        w, "Home",
        absl::StrCat("the drive did not start INIT within ", config().timeouts.request.count(),
                     " ms, is in ", StateTextLocked()));
    UpdateCommand(cmd.id, CommandState::kError, std::string(s.message()));
    return s;
  }
  return StartedHome(GetCommand(cmd.id), absl::StrCat("drive '", name_, "': Home: "));
}

// ---------------------------------------------------------------------------------------------
// Motion (§11.10: 0x11 absolute, 0x13 relative; filter limits 0x51/0x53, decision 984).

absl::StatusOr<CommandInfo> LinMotDnDrive::Move(const MotionCommand& cmd) {
  DGW_RETURN_IF_ERROR(RequireActive("Move"));
  std::lock_guard op(op_mu_);
  return RunMove(cmd);
}

absl::StatusOr<CommandInfo> LinMotDnDrive::RunMove(const MotionCommand& cmd) {
  const std::string kind = KindName(cmd);
  std::unique_lock lock(mu_);
  auto fail = [&](const absl::Status& s) {
    const std::string prefix = absl::StrCat("drive '", name_, "': ");
    if (absl::StartsWith(s.message(), prefix)) return s;
    return absl::Status(s.code(), absl::StrCat(prefix, s.message()));
  };
  if (!OnlineLocked()) {
    return absl::UnavailableError(absl::StrCat("drive '", name_, "': ", kind,
                                               ": no poll response from ", endpoint(), " (link ",
                                               ToString(link_), ")"));
  }
  // D-10 / §11.6: motion only in RUN; refused here so the drive never raises an error for it.
  if (!sample_.low.run_state() || FaultPendingLocked()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "drive '", name_, "': ", kind, " needs RUN (ENABLED), drive is in ", StateTextLocked()));
  }
  const AxisConfig& axis = config().axis;
  const double actual_mm = cache_.actual_position ? PositionFromDn(*cache_.actual_position) : 0.0;
  const double v0 = velocity_mm_s_;

  // Profile limits: deceleration 0 means = acceleration; the filter has one acceleration limit,
  // the smaller of the two (decision 984).
  struct Plan {
    std::optional<uint16_t> speed;
    uint16_t acceleration = 0;
    Command command;
    int16_t target = 0;
    double v_mm_s = 0;
    double a_mm_s2 = 0;
    double distance_mm = 0;
  };
  auto limits = [&](const std::string& k, double v, double a, double d, Plan& p) -> absl::Status {
    if (d == 0) d = a;
    DGW_RETURN_IF_ERROR(CheckMoveProfile(k, v, a, d, axis));
    DGW_ASSIGN_OR_RETURN(p.speed, SpeedToDn(k + ".velocity_mm_s", v));
    const std::string acc_field = d < a ? k + ".deceleration_mm_s2" : k + ".acceleration_mm_s2";
    DGW_ASSIGN_OR_RETURN(p.acceleration, AccelerationToDn(acc_field, std::min(a, d)));
    p.v_mm_s = *p.speed * kMmSPerSpeedIncrement;
    p.a_mm_s2 = p.acceleration * kMmS2PerAccelerationIncrement;
    return absl::OkStatus();
  };
  const TimePoint request_deadline = clock_.Now() + config().timeouts.request;
  Plan plan;
  absl::Status built = [&]() -> absl::Status {
    if (const auto* m = std::get_if<MoveAbsolute>(&cmd)) {
      DGW_RETURN_IF_ERROR(
          CheckAxisPosition("move_absolute.position_mm", m->position_mm, m->position_mm, axis));
      DGW_RETURN_IF_ERROR(limits("move_absolute", m->velocity_mm_s, m->acceleration_mm_s2,
                                 m->deceleration_mm_s2, plan));
      DGW_ASSIGN_OR_RETURN(plan.target, PositionToDn("move_absolute.position_mm", m->position_mm));
      plan.command =
          Command{Raw(CommandId::kSetPositionSetpoint), options_.motor, false, plan.target};
      plan.distance_mm = PositionFromDn(plan.target) - actual_mm;
      return absl::OkStatus();
    }
    if (const auto* m = std::get_if<MoveRelative>(&cmd)) {
      // Decision 984: 0x13 adds to the position set-point (the target), read fresh here.
      DGW_RETURN_IF_ERROR(limits("move_relative", m->velocity_mm_s, m->acceleration_mm_s2,
                                 m->deceleration_mm_s2, plan));
      if (!std::isfinite(m->distance_mm)) {
        return absl::InvalidArgumentError(
            absl::StrCat("move_relative.distance_mm: ", m->distance_mm, " is not a finite number"));
      }
      DGW_ASSIGN_OR_RETURN(const int16_t increment,
                           PositionToDn("move_relative.distance_mm", m->distance_mm));
      DGW_ASSIGN_OR_RETURN(const int32_t setpoint, GetLocked(lock, CommandId::kGetPositionSetpoint,
                                                             options_.motor, request_deadline));
      const int32_t target = setpoint + increment;
      DGW_RETURN_IF_ERROR(CheckAxisPosition("move_relative.distance_mm", m->distance_mm,
                                            PositionFromDn(target), axis));
      if (target < -kPositionLimit || target > kPositionLimit) {
        return absl::OutOfRangeError(absl::StrCat(
            "move_relative.distance_mm: ", m->distance_mm, " takes the set-point to ", target,
            " increments, beyond ±", kPositionLimit, " (linmot-devicenet.md §8.4)"));
      }
      plan.target = static_cast<int16_t>(target);
      plan.command = Command{Raw(CommandId::kIncrementPositionSetpoint), options_.motor,
                             NextToggle(sample_.high, options_.motor), increment};
      plan.distance_mm = PositionFromDn(target) - actual_mm;
      return absl::OkStatus();
    }
    if (const auto* m = std::get_if<MoveVelocity>(&cmd)) {
      // docs/decisions/005-move-velocity.md: towards the stroke end in the velocity's direction.
      if (!std::isfinite(m->velocity_mm_s) || m->velocity_mm_s == 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            "move_velocity.velocity_mm_s: ", m->velocity_mm_s,
            " must be non-zero (its sign picks the direction; use Stop to stand still)"));
      }
      DGW_RETURN_IF_ERROR(limits("move_velocity", std::fabs(m->velocity_mm_s),
                                 m->acceleration_mm_s2, m->deceleration_mm_s2, plan));
      const double end_mm = m->velocity_mm_s > 0 ? axis.max_mm : axis.min_mm;
      DGW_ASSIGN_OR_RETURN(plan.target, PositionToDn("axis.max_mm/min_mm", end_mm));
      plan.command =
          Command{Raw(CommandId::kSetPositionSetpoint), options_.motor, false, plan.target};
      plan.distance_mm = end_mm - actual_mm;
      return absl::OkStatus();
    }
    const auto& stop = std::get<StopMotion>(cmd);
    // Decision 984: no stop command in this protocol generation; the set-point becomes the
    // stopping point v²/2d ahead with the filter acceleration = d.
    const double d =
        stop.deceleration_mm_s2 == 0 ? axis.max_acceleration_mm_s2 : stop.deceleration_mm_s2;
    DGW_RETURN_IF_ERROR(CheckProfileLimit("stop.deceleration_mm_s2", d, axis.max_acceleration_mm_s2,
                                          "axis.max_acceleration_mm_s2"));
    DGW_ASSIGN_OR_RETURN(plan.acceleration, AccelerationToDn("stop.deceleration_mm_s2", d));
    plan.a_mm_s2 = plan.acceleration * kMmS2PerAccelerationIncrement;
    const double stop_mm = std::clamp(actual_mm + v0 * std::fabs(v0) / (2 * plan.a_mm_s2),
                                      axis.min_mm, axis.max_mm);  // the stroke, not the input
    DGW_ASSIGN_OR_RETURN(plan.target, PositionToDn("stop position", stop_mm));
    plan.command =
        Command{Raw(CommandId::kSetPositionSetpoint), options_.motor, false, plan.target};
    plan.v_mm_s = std::max(std::fabs(v0), 1.0);
    plan.distance_mm = stop_mm - actual_mm;
    return absl::OkStatus();
  }();
  if (!built.ok()) return fail(built);

  const CommandInfo info = StartCommand(kind, true);  // aborts the running motion's handle
  motion_.reset();
  homing_.reset();
  absl::Status sent = [&]() -> absl::Status {
    if (plan.speed) {
      DGW_RETURN_IF_ERROR(WriteFilterLocked(lock, CommandId::kSetFilterMaxSpeed, *plan.speed,
                                            request_deadline,
                                            absl::StrCat(kind, ": Set Filter Max Speed")));
    }
    DGW_RETURN_IF_ERROR(WriteFilterLocked(lock, CommandId::kSetFilterMaxAcceleration,
                                          plan.acceleration, request_deadline,
                                          absl::StrCat(kind, ": Set Filter Max Acceleration")));
    const TimePoint accept_deadline = clock_.Now() + config().timeouts.accept;
    DGW_ASSIGN_OR_RETURN(const Transaction t,
                         TransactLocked(lock, plan.command, accept_deadline, kind));
    if (t.error_rose) return CodedErrorStatus(lock, kind, request_deadline);
    if (!motion_ && GetCommand(info.id) && !IsFinal(GetCommand(info.id)->state)) {
      UpdateCommand(info.id, CommandState::kActive);
      const double planned = PlannedSeconds(plan.distance_mm, v0, plan.v_mm_s, plan.a_mm_s2);
      MotionTracker m;
      m.id = info.id;
      m.kind = kind;
      m.target = plan.target;
      m.accepted_gen = t.response_gen;
      // Like linmot-mc.md D-11: planned duration x 1.5 + 500 ms.
      m.completion_deadline = clock_.Now() + FromSeconds(planned * 1.5 + 0.5);
      motion_ = m;
    }
    return absl::OkStatus();
  }();
  if (!sent.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(sent.message()));
    return sent;
  }
  log::Debug("motion_command", log::Fields()
                                   .Add("drive", name_)
                                   .Add("id", info.id)
                                   .Add("kind", kind)
                                   .Add("target", plan.target));
  std::optional<CommandInfo> result = GetCommand(info.id);
  if (!result) return absl::InternalError(absl::StrCat(kind, ": command lost"));
  return *result;
}

// ---------------------------------------------------------------------------------------------
// Parameters (§8.9) and native commands (§8.4).

namespace {

// §8.9: the Set halves of the parameter pairs a WriteParameter may use.
bool IsWritableParameter(uint8_t set_id) {
  if (set_id >= 0x25 && set_id <= 0x2D) return set_id % 2 == 1;
  if (set_id >= 0x31 && set_id <= 0x53) return set_id % 2 == 1;
  if (set_id >= 0x57 && set_id <= 0x5D) return set_id % 2 == 1;
  return set_id == 0x63 || set_id == 0x67 || set_id == 0x6B || set_id == 0x71 || set_id == 0x73;
}

std::optional<Motor> MotorFor(const CommandSpec& spec, Motor motor) {
  return spec.motor_select == MotorSelect::kRequired ? std::optional<Motor>(motor) : std::nullopt;
}

// The command behind a parameter id, after the checks Read and Write share: no stored (ROM)
// values in this generation (`rom_reason` says why for the operation), ids 0x00-0x7F, and a
// command that §8.4 defines.
absl::StatusOr<const CommandSpec*> ParameterCommand(const ParameterRef& ref,
                                                    const std::string& where,
                                                    const char* rom_reason) {
  if (ref.rom) return absl::InvalidArgumentError(absl::StrCat(where, ".rom: ", rom_reason));
  if (ref.id > 0x7F) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": exceeds the command ID range 0x00-0x7F (linmot-devicenet.md §8.4)"));
  }
  const CommandSpec* spec = FindCommand(static_cast<uint8_t>(ref.id));
  if (spec == nullptr) {
    return absl::NotFoundError(
        absl::StrCat(where, ": not a command of linmot-devicenet.md §8.4 (§8.7)"));
  }
  return spec;
}

}  // namespace

absl::StatusOr<int64_t> LinMotDnDrive::ReadParameter(const ParameterRef& ref) {
  DGW_RETURN_IF_ERROR(RequireActive("ReadParameter"));
  const std::string where = absl::StrFormat("drive '%s': parameter 0x%02X", name_, ref.id);
  DGW_ASSIGN_OR_RETURN(const CommandSpec* spec,
                       ParameterCommand(ref, where,
                                        "LinMot DeviceNet has no stored values, only live ones "
                                        "(linmot-devicenet.md §8.8, D-29)"));
  const CommandSpec* get = spec;
  if (spec->kind == CommandKind::kSet && ref.id > 0) {
    const CommandSpec* pair = FindCommand(static_cast<uint8_t>(ref.id - 1));
    get = pair != nullptr && pair->kind == CommandKind::kGet ? pair : nullptr;
  }
  if (get == nullptr || get->kind != CommandKind::kGet || !get->documented) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, " (", spec->name, "): not readable (no documented Get command)"));
  }
  std::lock_guard op(op_mu_);
  std::unique_lock lock(mu_);
  const TimePoint deadline = clock_.Now() + config().timeouts.request;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "ReadParameter"));
  return GetLocked(lock, static_cast<CommandId>(get->id), MotorFor(*get, options_.motor), deadline);
}

absl::Status LinMotDnDrive::WriteParameter(const ParameterRef& ref, int64_t value) {
  DGW_RETURN_IF_ERROR(RequireActive("WriteParameter"));
  const std::string where = absl::StrFormat("drive '%s': parameter 0x%02X", name_, ref.id);
  DGW_ASSIGN_OR_RETURN(const CommandSpec* spec,
                       ParameterCommand(ref, where,
                                        "LinMot DeviceNet has no stored values; Set commands are "
                                        "volatile (linmot-devicenet.md §8.8, D-29)"));
  const CommandSpec* set = spec->kind == CommandKind::kSet ? spec : FindCommand(ref.id + 1);
  if (set == nullptr || set->kind != CommandKind::kSet || !IsWritableParameter(set->id)) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, " (", spec->name,
        "): not a writable parameter of linmot-devicenet.md §8.9 (motion, control word and I/O "
        "go through Move, Enable/Disable and SendNative)"));
  }
  const std::string field = absl::StrCat(set->key(), ".", set->request.name);
  const int64_t lo = set->request.type == ValueType::kInt16 ? -32768 : 0;
  const int64_t hi = set->request.type == ValueType::kInt16 ? 32767 : 65535;
  if (value < lo || value > hi) {
    return absl::OutOfRangeError(absl::StrCat("drive '", name_, "': ", field, ": ", value,
                                              " does not fit the 16-bit word [", lo, ", ", hi,
                                              "]"));
  }
  if (absl::Status s = CheckRange(*set, static_cast<int32_t>(value)); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat("drive '", name_, "': ", s.message()));
  }
  std::lock_guard op(op_mu_);
  std::unique_lock lock(mu_);
  const TimePoint deadline = clock_.Now() + config().timeouts.request;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "WriteParameter"));
  const std::string what = absl::StrCat("write ", set->name);
  DGW_ASSIGN_OR_RETURN(const Transaction t,
                       TransactLocked(lock,
                                      Command{set->id, MotorFor(*set, options_.motor), false,
                                              static_cast<int32_t>(value)},
                                      deadline, what));
  if (t.error_rose) return CodedErrorStatus(lock, what, deadline);
  if (set->id == Raw(CommandId::kSetFilterMaxSpeed)) cache_.filter_speed = t.slot.value;
  if (set->id == Raw(CommandId::kSetFilterMaxAcceleration)) {
    cache_.filter_acceleration = t.slot.value;
  }
  return absl::OkStatus();
}

absl::StatusOr<NativeReply> LinMotDnDrive::SendNative(const NativeRequest& req) {
  DGW_RETURN_IF_ERROR(RequireActive("SendNative"));
  const std::string where = absl::StrCat("drive '", name_, "': send_native.linmot_devicenet");
  const auto* dn = std::get_if<LinMotDnRequest>(&req);
  if (dn == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("drive '", name_,
                     "': send_native: family linmot-devicenet takes linmot_devicenet commands"));
  }
  if (dn->value < -32768 || dn->value > 65535) {
    return absl::OutOfRangeError(
        absl::StrCat(where, ".value: ", dn->value, " does not fit 16 bits [-32768, 65535]"));
  }
  CommandWord word = CommandWord::FromRaw(dn->command);
  const CommandSpec* spec = FindCommand(word.id);
  if (spec == nullptr) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.command: ID 0x%02X is not in the command table (linmot-devicenet.md §8.7)", where,
        word.id));
  }
  if (!spec->documented) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.command: 0x%02X (%s) is undocumented; the gateway never sends it (D-19)", where,
        word.id, spec->name));
  }
  if (word.reserved != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".command: ", Hex16(dn->command), " sets reserved bits 11..8"));
  }
  if (std::popcount(static_cast<unsigned>(word.motor_mask)) > 1) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".command: ", Hex16(dn->command),
                                                   " selects more than one motor (D-6)"));
  }
  if (word.id == Raw(CommandId::kSetControlWord)) {
    return absl::InvalidArgumentError(
        absl::StrCat(where,
                     ".command: 0x05 Set Control Word: the Control In module owns the control word "
                     "(D-8); use Enable, Disable, Home"));
  }
  std::optional<Motor> motor;
  for (int m = 0; m < 4; ++m) {
    if (word.motor_mask & (1u << m)) motor = static_cast<Motor>(m);
  }
  std::lock_guard op(op_mu_);
  std::unique_lock lock(mu_);
  const TimePoint deadline = clock_.Now() + config().timeouts.request;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "SendNative"));
  // §8.2: the toggle bit of a T-command is the handshake's, never the caller's guess.
  word.toggle =
      spec->toggle ? NextToggle(sample_.high, motor.value_or(options_.motor)) : word.toggle;
  const CommandSlot slot{word.raw(), static_cast<uint16_t>(dn->value)};
  const std::string what = absl::StrCat("native command ", Hex16(slot.word), " (", spec->name, ")");
  const bool moves = (word.id >= 0x11 && word.id <= 0x14) || (word.id >= 0x20 && word.id <= 0x23);
  if (moves && motion_) {
    UpdateCommand(motion_->id, CommandState::kAborted, absl::StrCat("superseded by ", what));
    motion_.reset();
  }
  if (word.id == Raw(CommandId::kResetController)) {
    // §11.4 / D-28: never answered; carried by exactly one poll, then No Command. The drive
    // restarts (OFFLINE, then a new set-up after its duplicate MAC ID check).
    Transaction t;
    t.serial = ++tx_serial_;
    t.slot = slot;
    t.spec = spec;
    t.once = true;
    tx_ = t;
    MarkUrgentLocked();
    const uint64_t serial = t.serial;
    const Wait w = WaitLocked(lock, deadline,
                              [&] { return !tx_ || tx_->serial != serial || tx_->first_gen != 0; });
    if (tx_ && tx_->serial == serial) tx_.reset();
    if (w != Wait::kReached && w != Wait::kOffline) return WaitFailure(w, what, "not sent");
    log::Info("drive_reset", log::Fields().Add("drive", name_).Add("endpoint", endpoint()));
    NativeReply out;
    out.word2 = slot.word;
    return out;
  }
  // Raw word as given: bypasses the strict table checks (the drive answers with its coded error).
  Transaction t;
  t.serial = ++tx_serial_;
  t.slot = slot;
  t.spec = spec;
  t.toggle = spec->toggle;
  t.motor = motor;
  t.error_before = sample_.low.error_pending();
  tx_ = t;
  MarkUrgentLocked();
  const uint64_t serial = t.serial;
  const Wait w =
      WaitLocked(lock, deadline, [&] { return tx_ && tx_->serial == serial && tx_->done; });
  if (w != Wait::kReached) {
    if (tx_ && tx_->serial == serial) tx_.reset();
    return WaitFailure(w, what, "no echo within the time-out (linmot-devicenet.md §11.4)");
  }
  const Transaction done = *tx_;
  tx_.reset();
  NativeReply out;
  out.word2 = done.response.word;
  out.word3 = done.response.value;
  out.word4 = done.low_at_response.raw;
  if (done.error_rose) {
    auto code = GetLocked(lock, CommandId::kGetCodedError, std::nullopt, deadline);
    if (code.ok()) out.status = static_cast<uint32_t>(*code);
  }
  if (word.id == Raw(CommandId::kSetFilterMaxSpeed)) cache_.filter_speed.reset();
  if (word.id == Raw(CommandId::kSetFilterMaxAcceleration)) cache_.filter_acceleration.reset();
  return out;
}

}  // namespace drivegw::linmot::devicenet
