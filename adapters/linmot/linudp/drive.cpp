// LinMotUdpDrive: control word sequences, MC count handshake, RTC transactions, status mapping.
#include "adapters/linmot/linudp/drive.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/log.h"
#include "adapters/core/motion_limits.h"
#include "adapters/core/status.h"
#include "adapters/core/units.h"
#include "adapters/linmot/common/command_status.h"
#include "adapters/linmot/common/session_peer.h"
#include "adapters/linmot/common/status_publish.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/linudp/rtc_error.h"
#include "adapters/linmot/mc/control_word.h"
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/warn_word.h"

namespace drivegw::linmot::linudp {
namespace {

using mc::MainState;

constexpr uint8_t kState(MainState s) { return static_cast<uint8_t>(s); }

// linmot-mc.md §2.2: states in which an error is pending (14 quick-stops into 4).
bool IsFaultState(uint8_t ms) {
  return ms == kState(MainState::kSetupError) || ms == kState(MainState::kError) ||
         ms == kState(MainState::kErrorBehaviourQuickStop);
}
// States with the power stage off (0-4): the end of Disable.
bool IsPowerOff(uint8_t ms) { return ms <= kState(MainState::kError); }

// The count nibble of an MC block's header (linmot-linudp.md §3.4: byte 0 = sub ID << 4 | count).
uint8_t BlockCount(const mc::McBlock& block) {
  return mc::Header::FromRaw(static_cast<uint16_t>(block[0] | (block[1] << 8))).count;
}

// Velocity from positions at least this far apart (decision 703).
constexpr Duration kMinVelocityWindow = std::chrono::milliseconds(20);

// A-09 time-outs of RTC commands that take long on a real drive.
Duration RtcTimeout(uint8_t command_id, Duration normal) {
  if (command_id >= 0x30 && command_id <= 0x36) return std::chrono::seconds(45);
  if (command_id == 0x40 || command_id == 0x80) return std::chrono::seconds(120);
  return normal;
}

double PositionFromWire(int64_t v) { return static_cast<double>(v) / units::kPositionPerMm; }

std::string Hex16(uint16_t v) { return absl::StrFormat("0x%04X", v); }

// Profile limits are checked as in every family (motion_limits.h); LinUDP's "must be positive"
// cites D-42: the gateway never sends a zero limit.
constexpr char kD42Note[] = " (linmot-mc.md D-42)";

// Time from rest over `distance` with a trapezoid or triangle (linmot-mc.md §6.1 step 5, u = 0).
double TrapezoidSeconds(double distance, double vmax, double acc, double dec) {
  if (distance <= 0) return 0;
  const double ramps = vmax * vmax / (2 * acc) + vmax * vmax / (2 * dec);
  if (distance >= ramps) return vmax / acc + vmax / dec + (distance - ramps) / vmax;
  const double vp = std::sqrt(2 * acc * dec * distance / (acc + dec));
  return vp / acc + vp / dec;
}

}  // namespace

DriveState MapLinMotState(bool online, mc::StateVar sv, mc::StatusWord sw) {
  if (!online) return DriveState::kOffline;
  switch (static_cast<MainState>(sv.main_state)) {
    case MainState::kNotReadyToSwitchOn:
    case MainState::kSwitchOnDisabled:
      return DriveState::kDisabled;
    case MainState::kReadyToSwitchOn:
    case MainState::kHwTests:
    case MainState::kReadyToOperate:
    case MainState::kBrakeReleaseDelay:
    case MainState::kBrakeSetDelay:
      return DriveState::kReady;
    case MainState::kSetupError:
    case MainState::kError:
    case MainState::kErrorBehaviourQuickStop:
      return DriveState::kFault;
    case MainState::kOperationEnabled:
      return sv.motion_active() ? DriveState::kMoving : DriveState::kEnabled;
    case MainState::kHoming:
    case MainState::kClearanceCheck:
      return DriveState::kHoming;
    case MainState::kAborting:
    case MainState::kFreezing:
      return sw.motion_active() ? DriveState::kMoving : DriveState::kReady;
    case MainState::kGoingToInitialPosition:
    case MainState::kGoingToPosition:
    case MainState::kJoggingPlus:
    case MainState::kJoggingMinus:
    case MainState::kLinearizing:
    case MainState::kPhaseSearching:
    case MainState::kSpecialMode:
      return DriveState::kMoving;
  }
  return DriveState::kDisabled;  // main state >= 22: not in the manual
}

Duration PlannedVaiDuration(double distance_mm, double v0_mm_s, double vmax_mm_s, double acc_mm_s2,
                            double dec_mm_s2) {
  if (vmax_mm_s <= 0 || acc_mm_s2 <= 0 || dec_mm_s2 <= 0) return Duration::zero();
  const double v0 = std::fabs(v0_mm_s);
  // Conservative: stop first (as if reversing, §6.1 step 2), then travel the rest from rest.
  const double stop_s = v0 / dec_mm_s2;
  const double stop_mm = v0 * v0 / (2 * dec_mm_s2);
  return FromSeconds(
      stop_s + TrapezoidSeconds(std::fabs(distance_mm) + stop_mm, vmax_mm_s, acc_mm_s2, dec_mm_s2));
}

LinMotUdpDrive::LinMotUdpDrive(DriveConfig config, const Clock& clock)
    : DriveBase(std::move(config)),
      clock_(clock),
      name_(this->config().name),
      endpoint_(this->config().linudp ? absl::StrCat("udp://", this->config().linudp->host, ":",
                                                     this->config().linudp->port)
                                      : "udp://?") {}

LinMotUdpDrive::~LinMotUdpDrive() { Deactivate(); }

std::string LinMotUdpDrive::endpoint() const { return endpoint_; }

// ---------------------------------------------------------------------------------------------
// Lifecycle.

absl::Status LinMotUdpDrive::DoActivate() {
  const LinUdpConfig& c = *config().linudp;
  // A host name is resolved at every activation: a drive (or container) may change address.
  auto remote = transport::Endpoint::Resolve(c.host, c.port);
  if (!remote.ok()) {
    return absl::Status(remote.status().code(),
                        absl::StrCat("linudp.host: ", remote.status().message()));
  }
  auto local = transport::Endpoint::Parse(c.bind_host, c.master_port);
  if (!local.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("linudp.bind_host: ", local.status().message()));
  }
  transport::ThreadScheduling scheduling;
  scheduling.fifo_priority = c.io_priority;
  scheduling.cpus = c.io_cpus;
  auto session = SessionPool::Instance().Acquire(*local, clock_, scheduling);
  if (!session.ok()) return session.status();
  {
    std::lock_guard lock(mu_);
    active_ = true;
    link_ = LinkState::kUnknown;
    sample_ = Sample{};
    history_.clear();
    velocity_mm_s_ = demand_velocity_mm_s_ = 0;
    // linmot-linudp.md §6.8: no control word until an operation sets one, so that connecting
    // never changes the drive's state.
    control_word_.reset();
    mc_block_.reset();
    mc_guard_.Reset();  // the drive may have been commanded by anyone meanwhile
    rtc_block_.reset();
    motion_.reset();
    homing_.reset();
    published_.reset();
    verified_curves_.clear();
    ++curve_epoch_;
  }
  PeerOptions options;
  options.name = name_;
  options.remote = *remote;
  options.cycle = c.cycle;
  options.reply_timeout = c.reply_timeout;
  // Decision 1431: drives[i].health overrides the family defaults (lost_after_timeouts, probe
  // every cycle); the factory validated the result.
  const HealthConfig health = LinUdpHealthConfig(config());
  options.lost_after_timeouts = health.down_after_failures;
  options.probe_backoff_min = health.backoff_min;
  options.probe_backoff_max = health.backoff_max;
  options.up_after = health.up_after;
  options.wire_trace = wire_trace_;
  absl::StatusOr<PeerId> id = (*session)->Register(options, this);
  std::lock_guard lock(mu_);
  if (!id.ok()) {
    active_ = false;
    return id.status();
  }
  session_ = *session;
  peer_id_ = *id;
  PublishLocked(true);
  return absl::OkStatus();
}

void LinMotUdpDrive::DoDeactivate() {
  // Unregisters outside mu_; no callback runs after this returns.
  std::shared_ptr<Session> session = DetachSessionPeer(mu_, session_, peer_id_, active_);
  {
    std::lock_guard lock(mu_);
    if (motion_) UpdateCommand(motion_->id, CommandState::kAborted, "drive deactivated");
    if (homing_) UpdateCommand(homing_->id, CommandState::kAborted, "drive deactivated");
    motion_.reset();
    homing_.reset();
    rtc_block_.reset();
    link_ = LinkState::kUnknown;
    PublishLocked(true);
    ResolveAsyncAcceptLocked(clock_.Now());  // active_ is false: "drive deactivated"
    cv_.notify_all();
  }
  session.reset();  // the last drive of a session closes its socket here, outside mu_
}

std::optional<ExchangeCounters> LinMotUdpDrive::exchange_counters() const {
  return SessionPeerCounters(mu_, session_, peer_id_);
}

std::optional<SessionCounters> LinMotUdpDrive::session_counters() const {
  return SessionCountersOf(mu_, session_);
}

uint64_t LinMotUdpDrive::stale_motion_commands() const {
  std::lock_guard lock(mu_);
  return stale_motion_commands_;
}

std::optional<transport::Endpoint> LinMotUdpDrive::local_endpoint() const {
  std::lock_guard lock(mu_);
  if (!session_) return std::nullopt;
  return session_->local_endpoint();
}

// ---------------------------------------------------------------------------------------------
// I/O thread side.

Request LinMotUdpDrive::BuildRequest() noexcept {
  std::lock_guard lock(mu_);
  Request r;
  // Standard status blocks plus the RTC reply, so that every reply shows the RTC count echo
  // that seeds the next RTC command (A-08; docs/decisions/702-linudp-telegram-content.md).
  r.response_definition = kRespStandard | kRespRtc;
  r.control_word = control_word_;
  r.motion_command = mc_block_;
  r.rtc = rtc_block_;  // the identical block every telegram while a transaction is open
  cw_in_flight_ = cw_generation_;
  rtc_in_flight_ = rtc_generation_;
  urgent_ = false;
  return r;
}

bool LinMotUdpDrive::HasUrgentRequest() noexcept {
  std::lock_guard lock(mu_);
  return urgent_;
}

void LinMotUdpDrive::MarkUrgentLocked() {
  urgent_ = true;
  if (session_) session_->Expedite(peer_id_);
}

void LinMotUdpDrive::OnReply(const Reply& reply, TimePoint received) noexcept {
  std::lock_guard lock(mu_);
  if (!active_) return;
  Sample& s = sample_;
  s.valid = true;
  s.received = received;
  if (reply.status_word) s.status_word = mc::StatusWord{*reply.status_word};
  if (reply.state_var) s.state_var = mc::StateVar::FromRaw(*reply.state_var);
  if (reply.warn_word) s.warn_word = *reply.warn_word;
  if (reply.error_code) s.error_code = *reply.error_code;
  if (reply.actual_position) s.actual_position = *reply.actual_position;
  if (reply.demand_position) s.demand_position = *reply.demand_position;
  if (reply.rtc) s.rtc = *reply.rtc;
  cw_answered_ = cw_in_flight_;
  rtc_answered_ = rtc_in_flight_;
  ++replies_;

  // Velocity: difference quotient over the newest sample at least one window old (decision 703).
  const Duration window = std::max(kMinVelocityWindow, 4 * Duration(config().linudp->cycle));
  history_.push_back({received, s.actual_position, s.demand_position});
  while (history_.size() >= 2 && received - history_[1].t >= window) history_.pop_front();
  const PositionSample& ref = history_.front();
  const double dt = ToSeconds(received - ref.t);
  if (dt > 0) {
    velocity_mm_s_ = PositionFromWire(int64_t{s.actual_position} - ref.actual) / dt;
    demand_velocity_mm_s_ = PositionFromWire(int64_t{s.demand_position} - ref.demand) / dt;
  } else if (history_.size() == 1) {
    velocity_mm_s_ = demand_velocity_mm_s_ = 0;
  }

  CheckCountEchoLocked();
  // Status first: a handle that ends on this reply is then republished with this very sample.
  PublishLocked(false);
  // Twice, to decide as the blocking waiter would: a deadline that passed before this reply
  // first (its timer would have woken it), then what this reply settled.
  ResolveAsyncAcceptLocked(received);
  EvaluateTrackersLocked(received);
  ResolveAsyncAcceptLocked(received);
  cv_.notify_all();
}

void LinMotUdpDrive::OnTimeout() noexcept {
  std::lock_guard lock(mu_);
  if (!active_) return;
  ++timeouts_;
  // Only deadlines advance without a reply; state-based decisions need a fresh sample.
  const TimePoint now = clock_.Now();
  ResolveAsyncAcceptLocked(now);  // a passed acceptance deadline, as the blocking waiter sees it
  if (motion_) {
    const MotionTracker& m = *motion_;
    if (!m.accepted && now >= m.accept_deadline) {
      UpdateCommand(m.id, CommandState::kError,
                    absl::StrCat("not accepted within ", config().timeouts.accept.count(),
                                 " ms: no reply from the drive (linmot-mc.md D-11)"));
      DisarmMcBlockLocked(m.count);
      motion_.reset();
    } else if (m.completion_deadline && now >= *m.completion_deadline) {
      UpdateCommand(m.id, CommandState::kError,
                    "completion time-out: no reply from the drive (linmot-mc.md D-11)");
      motion_.reset();
    }
  }
  if (homing_ && now >= homing_->deadline) {
    UpdateCommand(homing_->id, CommandState::kError,
                  absl::StrCat("not homed within ", config().timeouts.homing.count(),
                               " ms: no reply from the drive"));
    homing_.reset();
  }
  ResolveAsyncAcceptLocked(now);
  cv_.notify_all();
}

void LinMotUdpDrive::OnLinkChange(LinkState state) noexcept {
  std::lock_guard lock(mu_);
  if (!active_) return;
  link_ = state;
  if (state == LinkState::kOffline && motion_ && !motion_->accepted) {
    // Decided here, before the session builds the next telegram, so that no telegram built after
    // the handle ended still carries the command (DisarmMcBlockLocked).
    UpdateCommand(motion_->id, CommandState::kError,
                  absl::StrCat("not accepted: link to ", endpoint(), " lost"));
    DisarmMcBlockLocked(motion_->count);
    motion_.reset();
  }
  if (state == LinkState::kOffline) {
    // A drive that went silent may have rebooted: its curves are no longer known (decision 707).
    verified_curves_.clear();
    ++curve_epoch_;
  }
  if (state != LinkState::kOnline) {
    history_.clear();
    velocity_mm_s_ = demand_velocity_mm_s_ = 0;
    PublishLocked(true);
  }
  ResolveAsyncAcceptLocked(clock_.Now());
  cv_.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Trackers (evaluated on every reply).

void LinMotUdpDrive::EvaluateTrackersLocked(TimePoint now) {
  EvaluateMotionLocked(now);
  EvaluateHomingLocked(now);
}

void LinMotUdpDrive::EvaluateMotionLocked(TimePoint now) {
  if (!motion_) return;
  MotionTracker& m = *motion_;
  const mc::StateVar sv = sample_.state_var;
  const uint8_t ms = sv.main_state;
  auto end = [&](CommandState st, const std::string& message) {
    UpdateCommand(m.id, st, message);
    if (!m.accepted) DisarmMcBlockLocked(m.count);
    motion_.reset();
  };
  if (!m.accepted) {
    // linmot-mc.md §4.4 step 3: accepted <=> state 8 and the echo equals the count sent.
    if (sv.operation_enabled() && sv.count_echo() == m.count) {
      m.accepted = true;
      accepted_id_ = m.id;
      UpdateCommand(m.id, CommandState::kActive);
      if (m.curve) m.curve->started = now;
      if (m.planned) {
        // D-11: planned duration x 1.5 + 500 ms.
        m.completion_deadline = now + *m.planned + *m.planned / 2 + std::chrono::milliseconds(500);
      }
    } else if (IsFaultState(ms)) {
      return end(CommandState::kError,
                 absl::StrCat("drive fault before acceptance: ", FaultLocked().text));
    } else if (!sv.operation_enabled()) {
      return end(CommandState::kAborted,
                 absl::StrCat("drive left Operation Enabled before accepting, now in ",
                              StateTextLocked()));
    } else if (now >= m.accept_deadline) {
      return end(
          CommandState::kError,
          absl::StrCat("not accepted within ", config().timeouts.accept.count(), " ms (count ",
                       m.count, ", echo ", sv.count_echo(), ", linmot-mc.md D-11)"));
    } else {
      return;
    }
  }
  // linmot-mc.md §4.4 steps 4 and 5.
  if (sv.operation_enabled()) {
    if (sv.count_echo() != m.count) {
      return end(CommandState::kAborted, absl::StrCat("superseded on the drive (count echo ",
                                                      sv.count_echo(), ", sent ", m.count, ")"));
    }
    const bool finished = !sv.motion_active() && (!m.needs_in_target || sv.in_target_position());
    if (m.curve) {
      if (auto e = EvaluateCurveLocked(m, now, finished)) return end(e->first, e->second);
    } else if (finished) {
      return end(CommandState::kDone, "");
    }
    if (m.completion_deadline && now >= *m.completion_deadline) {
      return end(
          CommandState::kError,
          absl::StrFormat("completion time-out after %.0f ms (planned %.0f ms, "
                          "linmot-mc.md D-11)",
                          ToSeconds(*m.planned * 3 / 2 + std::chrono::milliseconds(500)) * 1000,
                          ToSeconds(*m.planned) * 1000));
    }
    return;
  }
  if (IsFaultState(ms))
    return end(CommandState::kError, absl::StrCat("drive fault: ", FaultLocked().text));
  end(CommandState::kAborted,
      absl::StrCat("interrupted: drive left Operation Enabled, now in ", StateTextLocked()));
}

void LinMotUdpDrive::CheckCountEchoLocked() {
  const mc::StateVar sv = sample_.state_var;
  // linmot-mc.md §2.1: the count echo is defined in main state 8 only.
  if (!sv.operation_enabled()) return;
  const std::optional<uint8_t> current = mc_guard_.current();
  switch (mc_guard_.OnEcho(sv.count_echo())) {
    case McCountGuard::Verdict::kNone:
      return;
    case McCountGuard::Verdict::kEcho:
      // Decision 1461: the drive interpreted the count, so the block is no longer needed (the
      // drive remembers its count, §4.3); from the next telegram on it is omitted (request bit
      // 1 clear, linmot-linudp.md §3.1), so no telegram sent from now on can re-execute it.
      if (mc_block_ && BlockCount(*mc_block_) == sv.count_echo()) mc_block_.reset();
      return;
    case McCountGuard::Verdict::kStale:
      return OnStaleMotionLocked(current.value_or(0), sv.count_echo());
  }
}

void LinMotUdpDrive::OnStaleMotionLocked(uint8_t from, uint8_t echo) {
  ++stale_motion_commands_;
  const std::string message = absl::StrCat(
      "stale motion command re-executed (network reordering): the count echo went back from ", from,
      " to ", echo,
      ", a command superseded earlier (linmot-mc.md §4.3); axis halted with "
      "/Abort, AcknowledgeFault releases it (decision 1461)");
  log::Error("linudp_stale_motion_command", log::Fields()
                                                .Add("drive", name_)
                                                .Add("from_count", int{from})
                                                .Add("echo", int{echo})
                                                .Add("state_var", Hex16(sample_.state_var.raw())));
  stale_fault_ = message;
  // Halt first. /Abort (control word bit 4 = 0, linmot-mc.md T13): quick stop, the motor stays
  // position-controlled, and setting the bit again holds the position until a new motion
  // command (T14) — unlike /Quick Stop (OFF3), which ends with the power stage off.
  SetControlWordLocked(control_word_.value_or(mc::kOperational) & ~mc::kAbortN);
  // Nothing of ours is pending any more: a waiting command ends ERROR (its block, if any, is
  // dropped rather than disarmed: a NOP with its count would itself look stale once echoed).
  mc_block_.reset();
  if (motion_) {
    UpdateCommand(motion_->id, CommandState::kError, message);
    motion_.reset();
  }
  PublishLocked(true);
}

void LinMotUdpDrive::EvaluateHomingLocked(TimePoint now) {
  if (!homing_) return;
  HomingTracker& h = *homing_;
  const uint8_t ms = MainStateLocked();
  const uint8_t homing = kState(MainState::kHoming);
  auto end = [&](CommandState st, const std::string& message) {
    UpdateCommand(h.id, st, message);
    homing_.reset();
    // Release bit 11 whatever happened (linmot-mc.md §2.7 step 3, D-06).
    if (control_word_ && (*control_word_ & mc::kHome)) {
      SetControlWordLocked(*control_word_ & ~mc::kHome);
    }
  };
  if (IsFaultState(ms))
    return end(CommandState::kError, absl::StrCat("drive fault: ", FaultLocked().text));
  if (h.phase == HomingPhase::kStarting) {
    if (ms == homing) {
      h.phase = HomingPhase::kRunning;
      UpdateCommand(h.id, CommandState::kActive);
    } else if (ms != kState(MainState::kOperationEnabled)) {
      return end(CommandState::kAborted,
                 absl::StrCat("interrupted before homing started, drive in ", StateTextLocked()));
    }
  }
  if (h.phase == HomingPhase::kRunning) {
    if (ms == homing && sample_.state_var.sub_state == mc::kSubStateFinished) {
      // Sub state 0Fh = Homing Finished: release bit 11, the drive returns to 8 (D-06).
      SetControlWordLocked(*control_word_ & ~mc::kHome);
      h.phase = HomingPhase::kReleasing;
    } else if (ms != homing) {
      return end(CommandState::kAborted,
                 absl::StrCat("homing stopped before it finished, drive in ", StateTextLocked()));
    }
  }
  if (h.phase == HomingPhase::kReleasing) {
    if (ms == kState(MainState::kOperationEnabled)) {
      if (sample_.status_word.homed()) return end(CommandState::kDone, "");
      return end(CommandState::kError, "homing finished but the drive reports Homed = 0");
    }
    if (ms != homing) {
      return end(CommandState::kAborted,
                 absl::StrCat("interrupted after homing, drive in ", StateTextLocked()));
    }
  }
  if (now >= h.deadline) {
    end(CommandState::kError, absl::StrCat("not homed within ", config().timeouts.homing.count(),
                                           " ms, drive in ", StateTextLocked()));
  }
}

// ---------------------------------------------------------------------------------------------
// Status.

std::string LinMotUdpDrive::StateTextLocked() const {
  const uint8_t ms = MainStateLocked();
  return absl::StrCat("main state ", ms, " (", mc::MainStateName(ms), ")");
}

Fault LinMotUdpDrive::FaultLocked() const {
  Fault f;
  const uint8_t ms = MainStateLocked();
  if (!sample_.valid || (!IsFaultState(ms) && !sample_.status_word.error())) return f;
  uint16_t code = sample_.error_code;
  // linmot-mc.md §2.6: in states 3/4 the sub state carries the code's low byte.
  if (code == 0 && ms != kState(MainState::kErrorBehaviourQuickStop))
    code = sample_.state_var.sub_state;
  f.code = code;
  f.text = mc::ErrorText(code);
  f.fatal = sample_.status_word.fatal_error();
  return f;
}

DriveStatus LinMotUdpDrive::BuildStatusLocked() const {
  DriveStatus s;
  s.state = MapLinMotState(OnlineLocked(), sample_.state_var, sample_.status_word);
  if (!sample_.valid) return s;
  const uint8_t ms = MainStateLocked();
  s.native.main_state = ms;
  s.native.sub_state = sample_.state_var.sub_state;
  s.native.text = mc::MainStateName(ms);
  s.native.status_word = sample_.status_word.raw;
  s.native.warn_word = sample_.warn_word;
  s.position_mm = PositionFromWire(sample_.actual_position);
  s.demand_position_mm = PositionFromWire(sample_.demand_position);
  s.velocity_mm_s = velocity_mm_s_;
  s.homed = sample_.status_word.homed();
  s.in_target = sample_.status_word.in_target_position();
  s.motion_active = sample_.status_word.motion_active();
  s.warnings = mc::WarnWord{sample_.warn_word}.SetBitNames();
  s.fault = FaultLocked();
  if (stale_fault_) {
    // Decision 1461: a gateway-side fault, latched until AcknowledgeFault.
    s.state = DriveState::kFault;
    s.fault = Fault{kFaultStaleMotionCommand, *stale_fault_, false};
  }
  return s;
}

LinMotUdpDrive::StatusInputs LinMotUdpDrive::StatusInputsLocked() const {
  return StatusInputs{OnlineLocked(),          sample_.valid,           sample_.state_var.raw(),
                      sample_.status_word.raw, sample_.warn_word,       sample_.error_code,
                      sample_.actual_position, sample_.demand_position, velocity_mm_s_,
                      stale_fault_.has_value()};
}

void LinMotUdpDrive::PublishLocked(bool force) {
  const TimePoint now = clock_.Now();
  const StatusInputs inputs = StatusInputsLocked();
  if (published_inputs_ == inputs && WithinHeartbeat(force, published_, published_at_, now)) {
    return;  // BuildStatusLocked would give the very status published last (SameStatus)
  }
  published_inputs_ = inputs;
  DriveStatus s = BuildStatusLocked();
  if (WithinHeartbeat(force, published_, published_at_, now) && SameStatus(*published_, s)) {
    return;
  }
  LogStateChange(published_, s, name_, "linmot", "main_state", [&] { return s.native.main_state; });
  published_ = s;
  published_at_ = now;
  PublishStatus(std::move(s));
}

// ---------------------------------------------------------------------------------------------
// Waiting.

void LinMotUdpDrive::DisarmMcBlockLocked(uint8_t count) {
  // A command that was reported ERROR/ABORTED before the drive accepted it must not run later
  // (e.g. after a link hiccup): the same count with No Operation replaces it. A drive that did
  // take the count ignores the NOP (same count, §4.3); one that did not executes the NOP.
  if (!mc_block_ || BlockCount(*mc_block_) != count) return;
  if (auto nop = mc::EncodeMotionCommand(mc::NoOperation(), count); nop.ok()) {
    mc_block_ = *nop;
    MarkUrgentLocked();
  }
}

void LinMotUdpDrive::SetControlWordLocked(uint16_t cw) {
  if (control_word_ == cw) return;
  control_word_ = cw;
  ++cw_generation_;
  MarkUrgentLocked();
  log::Debug("control_word", log::Fields().Add("drive", name_).Add("cw", Hex16(cw)));
}

template <typename Pred>
LinMotUdpDrive::Wait LinMotUdpDrive::WaitLocked(std::unique_lock<std::mutex>& lock,
                                                TimePoint deadline, Pred reached,
                                                bool tolerate_offline) {
  return WaitPeerLocked<Wait>(
      cv_, lock, clock_, deadline, [&] { return active_; }, reached,
      [&] { return link_ == LinkState::kOffline && !tolerate_offline; });
}

LinMotUdpDrive::Wait LinMotUdpDrive::WaitControlWordLocked(std::unique_lock<std::mutex>& lock,
                                                           TimePoint deadline) {
  const uint64_t gen = cw_generation_;
  return WaitLocked(lock, deadline, [&] { return cw_answered_ >= gen; });
}

absl::Status LinMotUdpDrive::WaitOnlineLocked(std::unique_lock<std::mutex>& lock,
                                              TimePoint deadline, const char* operation) {
  for (;;) {
    if (!active_) return WaitFailure(Wait::kInactive, operation, "");
    if (OnlineLocked()) return absl::OkStatus();
    const TimePoint now = clock_.Now();
    if (now >= deadline) {
      return absl::UnavailableError(absl::StrCat("drive '", name_, "': ", operation,
                                                 ": no reply from ", endpoint(), " (link ",
                                                 ToString(link_), ")"));
    }
    cv_.wait_for(lock, deadline - now);
  }
}

absl::Status LinMotUdpDrive::WaitFailure(Wait w, const char* operation,
                                         const std::string& detail) const {
  return WaitPeerStatus(w, absl::StrCat("drive '", name_, "': ", operation, ": "), detail,
                        endpoint(), [&] { return absl::StrCat(" (", detail, ")"); });
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::Finish(uint64_t id, const absl::Status& status) {
  if (status.ok()) {
    UpdateCommand(id, CommandState::kDone);
  } else {
    UpdateCommand(id, CommandState::kError, std::string(status.message()));
    return status;
  }
  std::optional<CommandInfo> info = GetCommand(id);
  if (!info) return absl::InternalError(absl::StrCat("drive '", name_, "': command ", id, " lost"));
  return *info;
}

// ---------------------------------------------------------------------------------------------
// Control word sequences (linmot-mc.md §2.7).

absl::StatusOr<CommandInfo> LinMotUdpDrive::Enable() {
  DGW_RETURN_IF_ERROR(RequireActive("Enable"));
  std::unique_lock op = LockOperation();
  const CommandInfo cmd = StartCommand("Enable", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const auto timeout = config().timeouts.request;
    const TimePoint deadline = clock_.Now() + timeout;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Enable"));
    if (stale_fault_) {
      // Enabling would release the /Abort halt (decision 1461): acknowledging is the user's call.
      return absl::FailedPreconditionError(
          absl::StrCat("drive '", name_, "': Enable: ", *stale_fault_, "; AcknowledgeFault first"));
    }
    for (;;) {
      const uint8_t ms = MainStateLocked();
      if (ms == kState(MainState::kOperationEnabled)) {
        SetControlWordLocked(mc::kOperational);  // take over the word the drive runs with
        return absl::OkStatus();
      }
      if (IsFaultState(ms)) {
        const Fault fault = FaultLocked();
        absl::Status s = absl::FailedPreconditionError(
            absl::StrCat("drive '", name_, "': Enable: drive reports a fault in ",
                         StateTextLocked(), ": ", fault.text, "; AcknowledgeFault first"));
        if (fault.code != 0) mc::AttachErrorCode(s, static_cast<uint16_t>(fault.code));
        return s;
      }
      // §2.7 steps 1-2: release the anti-restart lock (0 -> 1), then 1 -> 2, then switch on.
      uint16_t cw = mc::kOperational;
      if (ms == kState(MainState::kNotReadyToSwitchOn)) cw = mc::kAllOff;
      if (ms == kState(MainState::kSwitchOnDisabled)) cw = mc::kSwitchedOff;
      SetControlWordLocked(cw);
      const Wait w = WaitLocked(lock, deadline, [&] {
        return cw_answered_ >= cw_generation_ && MainStateLocked() != ms;
      });
      if (w != Wait::kReached) {
        return WaitFailure(w, "Enable",
                           absl::StrCat("stuck in ", StateTextLocked(), " with control word ",
                                        Hex16(cw), " after ", timeout.count(), " ms"));
      }
    }
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::Disable() {
  DGW_RETURN_IF_ERROR(RequireActive("Disable"));
  std::unique_lock op = LockOperation();
  const CommandInfo cmd = StartCommand("Disable", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const auto timeout = config().timeouts.request;
    const TimePoint deadline = clock_.Now() + timeout;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Disable"));
    // §2.7 step 7: clear Switch On (OFF1) -> (21) -> 2.
    SetControlWordLocked(mc::kSwitchedOff);
    const Wait w = WaitLocked(lock, deadline, [&] {
      return cw_answered_ >= cw_generation_ && IsPowerOff(MainStateLocked());
    });
    if (w != Wait::kReached) {
      return WaitFailure(w, "Disable",
                         absl::StrCat("stuck in ", StateTextLocked(),
                                      " with control word 0x003E after ", timeout.count(), " ms"));
    }
    return absl::OkStatus();
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::AcknowledgeFault() {
  DGW_RETURN_IF_ERROR(RequireActive("AcknowledgeFault"));
  std::unique_lock op = LockOperation();
  const CommandInfo cmd = StartCommand("AcknowledgeFault", false);
  absl::Status result = [&]() -> absl::Status {
    std::unique_lock lock(mu_);
    const auto timeout = config().timeouts.request;
    const TimePoint deadline = clock_.Now() + timeout;
    DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "AcknowledgeFault"));
    if (stale_fault_) {
      // Decision 1461: release the /Abort halt; the drive returns to state 8 and holds its
      // position until a new motion command (linmot-mc.md T14).
      if (control_word_ && (*control_word_ & mc::kAbortN) == 0) {
        SetControlWordLocked(*control_word_ | mc::kAbortN);
        const Wait w = WaitLocked(lock, deadline, [&] {
          return cw_answered_ >= cw_generation_ &&
                 MainStateLocked() != kState(MainState::kAborting);
        });
        if (w != Wait::kReached) {
          return WaitFailure(w, "AcknowledgeFault",
                             absl::StrCat("/Abort released, drive still in ", StateTextLocked()));
        }
      }
      log::Info("linudp_stale_motion_acknowledged", log::Fields().Add("drive", name_));
      stale_fault_.reset();
      PublishLocked(true);
    }
    bool acknowledged = false;
    for (;;) {
      const uint8_t ms = MainStateLocked();
      uint16_t cw = 0;
      if (ms == kState(MainState::kErrorBehaviourQuickStop)) {
        // The quick stop ends in state 4 by itself (linmot-mc.md T26).
        const Wait w = WaitLocked(lock, deadline, [&] { return MainStateLocked() != ms; });
        if (w != Wait::kReached) {
          return WaitFailure(w, "AcknowledgeFault", absl::StrCat("still in ", StateTextLocked()));
        }
        continue;
      } else if (ms == kState(MainState::kSetupError)) {
        cw = mc::kOperational;  // D-03: Switch On takes 3 -> 4, where the code is logged
      } else if (ms == kState(MainState::kError)) {
        const Fault fault = FaultLocked();
        if (fault.fatal) {
          absl::Status s = absl::FailedPreconditionError(absl::StrCat(
              "drive '", name_, "': AcknowledgeFault: fatal error ", fault.text,
              " cannot be acknowledged (status word bit 12); fix the cause, then reset or "
              "power-cycle the drive"));
          mc::AttachErrorCode(s, static_cast<uint16_t>(fault.code));
          return s;
        }
        // §2.4: bit 7 acts on a rising edge, so the drive must see it 0 first.
        SetControlWordLocked(control_word_.value_or(mc::kOperational) & ~mc::kErrorAcknowledge);
        Wait w = WaitControlWordLocked(lock, deadline);
        if (w == Wait::kReached) {
          SetControlWordLocked(mc::kAcknowledge);
          w = WaitLocked(lock, deadline,
                         [&] { return cw_answered_ >= cw_generation_ && MainStateLocked() != ms; });
        }
        if (w != Wait::kReached) {
          absl::Status s =
              WaitFailure(w, "AcknowledgeFault",
                          absl::StrCat("fault ", fault.text, " still pending in ",
                                       StateTextLocked(), " after ", timeout.count(), " ms"));
          mc::AttachErrorCode(s, static_cast<uint16_t>(fault.code));
          SetControlWordLocked(mc::kOperational);
          return s;
        }
        acknowledged = true;
        continue;
      } else if (!acknowledged) {
        return absl::OkStatus();  // nothing pending
      } else if (ms == kState(MainState::kNotReadyToSwitchOn)) {
        cw = mc::kAllOff;  // D-04: the acknowledge lands in 0 (Switch On Locked): release it
      } else if (ms == kState(MainState::kSwitchOnDisabled)) {
        cw = mc::kSwitchedOff;
      } else {
        SetControlWordLocked(mc::kSwitchedOff);  // bit 7 low again, power stays off
        return absl::OkStatus();
      }
      SetControlWordLocked(cw);
      const Wait w = WaitLocked(lock, deadline, [&] {
        return cw_answered_ >= cw_generation_ && MainStateLocked() != ms;
      });
      if (w != Wait::kReached) {
        return WaitFailure(w, "AcknowledgeFault",
                           absl::StrCat("stuck in ", StateTextLocked(), " with control word ",
                                        Hex16(cw), " after ", timeout.count(), " ms"));
      }
    }
  }();
  return Finish(cmd.id, result);
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::Home() {
  DGW_RETURN_IF_ERROR(RequireActive("Home"));
  std::unique_lock op = LockOperation();
  std::unique_lock lock(mu_);
  const TimePoint now = clock_.Now();
  const TimePoint deadline = now + config().timeouts.request;
  if (!OnlineLocked()) DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, "Home"));
  if (MainStateLocked() != kState(MainState::kOperationEnabled)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "drive '", name_, "': Home needs main state 8 (Operation Enabled), drive is in ",
        StateTextLocked()));
  }
  const CommandInfo cmd = StartCommand("Home", true);
  motion_.reset();  // superseded (StartCommand aborted its handle)
  homing_ = HomingTracker{cmd.id, HomingPhase::kStarting, now + config().timeouts.homing};
  // §2.7 step 3: bit 11 held until sub state 0Fh (EvaluateHomingLocked releases it).
  SetControlWordLocked(control_word_.value_or(mc::kOperational) | mc::kHome);
  const Wait w = WaitLocked(lock, deadline, [&] {
    return !homing_ || homing_->id != cmd.id || homing_->phase != HomingPhase::kStarting;
  });
  if (w != Wait::kReached) {
    if (homing_ && homing_->id == cmd.id) homing_.reset();
    if (control_word_) SetControlWordLocked(*control_word_ & ~mc::kHome);
    absl::Status s = WaitFailure(
        w, "Home",
        absl::StrCat("drive did not enter main state 9 (Homing) within ",
                     config().timeouts.request.count(), " ms, is in ", StateTextLocked()));
    UpdateCommand(cmd.id, CommandState::kError, std::string(s.message()));
    return s;
  }
  return StartedHome(GetCommand(cmd.id), absl::StrCat("drive '", name_, "': Home: "));
}

// ---------------------------------------------------------------------------------------------
// Motion commands (linmot-mc.md §4.4).

absl::StatusOr<mc::McCommand> LinMotUdpDrive::BuildMotion(const MotionCommand& cmd,
                                                          bool& needs_in_target,
                                                          Duration& planned) {
  const AxisConfig& axis = config().axis;
  const double demand_mm = PositionFromWire(sample_.demand_position);
  const double v0 = demand_velocity_mm_s_;
  struct Profile {
    uint32_t v, a, d;
    double v_mm_s, a_mm_s2, d_mm_s2;
  };
  // Deceleration 0 means "= acceleration" (command.h contract); zero limits never go out (D-42).
  auto profile = [&](const std::string& kind, double v, double a,
                     double d) -> absl::StatusOr<Profile> {
    if (d == 0) d = a;
    DGW_RETURN_IF_ERROR(CheckMoveProfile(kind, v, a, d, axis, kD42Note));
    Profile p{0, 0, 0, v, a, d};
    DGW_ASSIGN_OR_RETURN(p.v, units::VelocityToWire(kind + ".velocity_mm_s", v));
    DGW_ASSIGN_OR_RETURN(p.a, units::AccelerationToWire(kind + ".acceleration_mm_s2", a));
    DGW_ASSIGN_OR_RETURN(p.d, units::AccelerationToWire(kind + ".deceleration_mm_s2", d));
    return p;
  };

  if (const auto* m = std::get_if<MoveAbsolute>(&cmd)) {
    DGW_RETURN_IF_ERROR(
        CheckAxisPosition("move_absolute.position_mm", m->position_mm, m->position_mm, axis));
    DGW_ASSIGN_OR_RETURN(const Profile p, profile("move_absolute", m->velocity_mm_s,
                                                  m->acceleration_mm_s2, m->deceleration_mm_s2));
    DGW_ASSIGN_OR_RETURN(const int32_t target,
                         units::PositionToWire("move_absolute.position_mm", m->position_mm));
    needs_in_target = true;
    planned = PlannedVaiDuration(m->position_mm - demand_mm, v0, p.v_mm_s, p.a_mm_s2, p.d_mm_s2);
    return mc::VaiGoToPos(target, p.v, p.a, p.d);
  }
  if (const auto* m = std::get_if<MoveRelative>(&cmd)) {
    // Decision 704: 011x Increment Dem Pos, the target is the demand position now + distance.
    DGW_RETURN_IF_ERROR(CheckAxisPosition("move_relative.distance_mm", m->distance_mm,
                                          demand_mm + m->distance_mm, axis));
    DGW_ASSIGN_OR_RETURN(const Profile p, profile("move_relative", m->velocity_mm_s,
                                                  m->acceleration_mm_s2, m->deceleration_mm_s2));
    DGW_ASSIGN_OR_RETURN(const int32_t increment,
                         units::PositionToWire("move_relative.distance_mm", m->distance_mm));
    needs_in_target = true;
    planned = PlannedVaiDuration(m->distance_mm, v0, p.v_mm_s, p.a_mm_s2, p.d_mm_s2);
    return mc::VaiIncrementDemPos(increment, p.v, p.a, p.d);
  }
  if (const auto* m = std::get_if<MoveVelocity>(&cmd)) {
    // docs/decisions/005-move-velocity.md: VAI Go To Pos towards the stroke end in the
    // velocity's direction, at that speed.
    if (!std::isfinite(m->velocity_mm_s) || m->velocity_mm_s == 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "move_velocity.velocity_mm_s: ", m->velocity_mm_s,
          " must be non-zero (its sign picks the direction; use Stop to stand still)"));
    }
    DGW_ASSIGN_OR_RETURN(const Profile p, profile("move_velocity", std::fabs(m->velocity_mm_s),
                                                  m->acceleration_mm_s2, m->deceleration_mm_s2));
    const double end_mm = m->velocity_mm_s > 0 ? axis.max_mm : axis.min_mm;
    DGW_ASSIGN_OR_RETURN(const int32_t target, units::PositionToWire("axis.max_mm/min_mm", end_mm));
    needs_in_target = true;
    planned = PlannedVaiDuration(end_mm - demand_mm, v0, p.v_mm_s, p.a_mm_s2, p.d_mm_s2);
    return mc::VaiGoToPos(target, p.v, p.a, p.d);
  }
  const auto& stop = std::get<StopMotion>(cmd);
  // Stop has no acceleration to fall back on: 0 means the axis' maximal acceleration.
  const double d =
      stop.deceleration_mm_s2 == 0 ? axis.max_acceleration_mm_s2 : stop.deceleration_mm_s2;
  DGW_RETURN_IF_ERROR(CheckProfileLimit("stop.deceleration_mm_s2", d, axis.max_acceleration_mm_s2,
                                        "axis.max_acceleration_mm_s2", kD42Note));
  DGW_ASSIGN_OR_RETURN(const uint32_t dec, units::AccelerationToWire("stop.deceleration_mm_s2", d));
  needs_in_target = false;  // a stop ends where it ends: Motion Active = 0 is enough (§4.4)
  planned = FromSeconds(std::fabs(v0) / d);
  return mc::VaiStop(dec);
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::Move(const MotionCommand& cmd) {
  DGW_RETURN_IF_ERROR(RequireActive("Move"));
  std::unique_lock op = LockOperation();
  std::unique_lock lock(mu_);
  bool needs_in_target = true;
  Duration planned{};
  absl::StatusOr<mc::McCommand> mcc = BuildMoveLocked(cmd, needs_in_target, planned);
  if (!mcc.ok()) return mcc.status();
  lock.unlock();
  return RunMotion(KindName(cmd), *mcc, needs_in_target, planned);
}

absl::StatusOr<mc::McCommand> LinMotUdpDrive::BuildMoveLocked(const MotionCommand& cmd,
                                                              bool& needs_in_target,
                                                              Duration& planned) {
  if (!OnlineLocked()) {
    return absl::UnavailableError(absl::StrCat("drive '", name_, "': ", KindName(cmd),
                                               ": no reply from ", endpoint(), " (link ",
                                               ToString(link_), ")"));
  }
  absl::StatusOr<mc::McCommand> mcc = BuildMotion(cmd, needs_in_target, planned);
  if (!mcc.ok()) {
    return absl::Status(mcc.status().code(),
                        absl::StrCat("drive '", name_, "': ", mcc.status().message()));
  }
  return mcc;
}

void LinMotUdpDrive::MoveAsync(const MotionCommand& cmd, Executor& blocking,
                               CommandCompletion done) {
  auto fail = [&blocking, &done](absl::Status s) {
    blocking.Post([done = std::move(done), s = std::move(s)] { done(s); });
  };
  if (absl::Status s = RequireActive("Move"); !s.ok()) return fail(std::move(s));
  // One operation at a time, as Move: while another one runs (or an earlier asynchronous move
  // waits for its count echo) this move takes the synchronous path on `blocking` and waits its
  // turn there (LockOperation), so the caller's thread never blocks.
  std::unique_lock op(op_mu_, std::try_to_lock);
  std::shared_ptr<Session> session;
  PeerId peer = 0;
  {
    std::unique_lock lock(mu_);
    if (!op.owns_lock() || async_accept_) {
      lock.unlock();
      if (op.owns_lock()) op.unlock();
      return Drive::MoveAsync(cmd, blocking, std::move(done));
    }
    bool needs_in_target = true;
    Duration planned{};
    absl::StatusOr<mc::McCommand> mcc = BuildMoveLocked(cmd, needs_in_target, planned);
    if (!mcc.ok()) return fail(mcc.status());
    const std::string kind = KindName(cmd);
    absl::StatusOr<MotionTracker> m =
        StartMotionLocked(kind, *mcc, needs_in_target, planned, std::nullopt, /*wake=*/false);
    if (!m.ok()) return fail(m.status());
    async_accept_ =
        AsyncAccept{m->id, kind, m->count, m->accept_deadline, &blocking, std::move(done)};
    session = session_;
    peer = peer_id_;
  }
  // Decision 1301: the telegram leaves from this thread when the line to the drive is free
  // one outstanding request); otherwise the I/O thread sends it as before (decision 006).
  if (session && !session->SendUrgentNow(peer)) session->Expedite(peer);
}

absl::StatusOr<LinMotUdpDrive::MotionTracker> LinMotUdpDrive::StartMotionLocked(
    const std::string& kind, const mc::McCommand& cmd, bool needs_in_target,
    std::optional<Duration> planned, std::optional<CurveTrack> curve, bool wake) {
  if (!OnlineLocked()) {
    return absl::UnavailableError(absl::StrCat("drive '", name_, "': ", kind, ": no reply from ",
                                               endpoint(), " (link ", ToString(link_), ")"));
  }
  // Decision 1461: halted by the gateway (state 12) until acknowledged.
  if (stale_fault_) {
    return absl::FailedPreconditionError(absl::StrCat("drive '", name_, "': ", kind,
                                                      ": drive is in FAULT (", *stale_fault_,
                                                      "); AcknowledgeFault first"));
  }
  // D-36: outside state 8 the drive would raise 0086h (or ignore the command): refuse here.
  if (MainStateLocked() != kState(MainState::kOperationEnabled)) {
    return absl::FailedPreconditionError(
        absl::StrCat("drive '", name_, "': ", kind,
                     " needs main state 8 (Operation Enabled), drive is in ", StateTextLocked()));
  }
  // D-09 / A-08: next count of the 1..15 ring, seeded from the echo.
  const uint8_t count = mc::NextCount(sample_.state_var.count_echo());
  absl::StatusOr<mc::McBlock> block = mc::EncodeMotionCommand(cmd, count);
  if (!block.ok()) {
    return absl::Status(block.status().code(), absl::StrCat("drive '", name_, "': ", kind, ": ",
                                                            block.status().message()));
  }
  const CommandInfo info = StartCommand(kind, true);  // aborts the running motion's handle
  homing_.reset();
  mc_block_ = *block;
  mc_guard_.Arm(count, sample_.state_var.count_echo());  // state 8 checked above
  if (wake) {
    MarkUrgentLocked();
  } else {
    urgent_ = true;  // the caller sends it (Session::SendUrgentNow) once mu_ is released
  }
  const TimePoint now = clock_.Now();
  MotionTracker m;
  m.id = info.id;
  m.kind = kind;
  m.count = count;
  m.needs_in_target = needs_in_target;
  m.accept_deadline = now + config().timeouts.accept;
  m.planned = planned;
  m.curve = curve;
  motion_ = m;
  log::Debug("motion_command",
             log::Fields()
                 .Add("drive", name_)
                 .Add("id", info.id)
                 .Add("kind", kind)
                 .Add("header", Hex16(mc::Header{cmd.master_id, cmd.sub_id, count}.raw())));
  return m;
}

bool LinMotUdpDrive::AcceptSettledLocked(uint64_t id) const {
  return !motion_ || motion_->id != id || motion_->accepted;
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::AcceptResultLocked(Wait w, uint64_t id,
                                                               const std::string& kind,
                                                               uint8_t count) {
  if (w != Wait::kReached) {
    absl::Status s = WaitFailure(
        w, kind.c_str(),
        absl::StrCat("not accepted within ", config().timeouts.accept.count(), " ms (count ", count,
                     ", echo ", sample_.state_var.count_echo(), ", linmot-mc.md D-11)"));
    if (motion_ && motion_->id == id) motion_.reset();
    DisarmMcBlockLocked(count);
    UpdateCommand(id, CommandState::kError, std::string(s.message()));
    return s;
  }
  std::optional<CommandInfo> result = GetCommand(id);
  if (!result) return absl::InternalError(absl::StrCat(kind, ": command lost"));
  if (accepted_id_ != id) {
    // Ended before the drive accepted it: refused (fault) or interrupted.
    const Fault fault = FaultLocked();
    const std::string message = absl::StrCat("drive '", name_, "': ", kind, ": ", result->message);
    absl::Status s = link_ == LinkState::kOffline ? absl::UnavailableError(message)
                     : result->state == CommandState::kError
                         ? absl::FailedPreconditionError(message)
                         : absl::AbortedError(message);
    if (fault.code != 0) mc::AttachErrorCode(s, static_cast<uint16_t>(fault.code));
    return s;
  }
  return *result;
}

void LinMotUdpDrive::ResolveAsyncAcceptLocked(TimePoint now) {
  if (!async_accept_) return;
  const AsyncAccept& a = *async_accept_;
  // The order WaitLocked decides in (WaitPeerLocked): inactive, reached, offline, deadline.
  Wait w;
  if (!active_) {
    w = Wait::kInactive;
  } else if (AcceptSettledLocked(a.id)) {
    w = Wait::kReached;
  } else if (link_ == LinkState::kOffline) {
    w = Wait::kOffline;
  } else if (now >= a.deadline) {
    w = Wait::kDeadline;
  } else {
    return;
  }
  absl::StatusOr<CommandInfo> result = AcceptResultLocked(w, a.id, a.kind, a.count);
  // Completed on the caller's executor: this is the session's I/O thread (or a deactivating one),
  // which must not run the caller's audit append (decision 1301).
  a.executor->Post(
      [done = std::move(async_accept_->done), result = std::move(result)] { done(result); });
  async_accept_.reset();
  cv_.notify_all();  // LockOperation waits for the line to be free
}

std::unique_lock<std::mutex> LinMotUdpDrive::LockOperation() {
  std::unique_lock op(op_mu_);
  std::unique_lock lock(mu_);
  // An asynchronous move holds the operation until its count echo settles (at most the
  // acceptance time-out D-11 plus one reply or time-out, or until deactivation).
  cv_.wait(lock, [&] { return !async_accept_; });
  return op;
}

absl::StatusOr<CommandInfo> LinMotUdpDrive::RunMotion(const std::string& kind,
                                                      const mc::McCommand& cmd,
                                                      bool needs_in_target,
                                                      std::optional<Duration> planned,
                                                      std::optional<CurveTrack> curve) {
  std::unique_lock lock(mu_);
  absl::StatusOr<MotionTracker> m =
      StartMotionLocked(kind, cmd, needs_in_target, planned, std::move(curve), /*wake=*/true);
  if (!m.ok()) return m.status();
  const uint64_t id = m->id;
  const Wait w = WaitLocked(lock, m->accept_deadline, [&] { return AcceptSettledLocked(id); });
  return AcceptResultLocked(w, id, kind, m->count);
}

// ---------------------------------------------------------------------------------------------
// RTC (linmot-linudp.md §5, A-08, A-09, A-14).

absl::StatusOr<RtcReply> LinMotUdpDrive::RtcTransact(uint8_t command_id, uint16_t word2,
                                                     uint16_t word3, uint16_t word4,
                                                     Duration timeout, const std::string& what) {
  std::lock_guard rtc(rtc_mu_);
  std::unique_lock lock(mu_);
  const TimePoint deadline = clock_.Now() + timeout;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, what.c_str()));
  return RtcTransactLocked(lock, command_id, word2, word3, word4, deadline, timeout, what);
}

absl::StatusOr<RtcReply> LinMotUdpDrive::RtcTransactLocked(std::unique_lock<std::mutex>& lock,
                                                           uint8_t command_id, uint16_t word2,
                                                           uint16_t word3, uint16_t word4,
                                                           TimePoint deadline, Duration timeout,
                                                           const std::string& what) {
  // the count follows the echo of the newest reply (1..15 ring, never 0).
  const uint8_t echo = sample_.rtc ? (sample_.rtc->count & 0x0F) : 0;
  const uint8_t count = mc::NextCount(echo);
  rtc_block_ = RtcRequest{count, command_id, word2, word3, word4};
  MarkUrgentLocked();
  const uint64_t gen = ++rtc_generation_;
  // done when the echo equals the count and the status is no longer busy.
  const Wait w = WaitLocked(lock, deadline, [&] {
    return rtc_answered_ >= gen && sample_.rtc && (sample_.rtc->count & 0x0F) == count &&
           !IsRtcBusy(sample_.rtc->status);
  });
  rtc_block_.reset();
  if (w != Wait::kReached) {
    const RtcReply last = sample_.rtc.value_or(RtcReply{});
    return WaitFailure(
        w, what.c_str(),
        absl::StrFormat("no RTC answer within %d ms (count %d, echo %d, status "
                        "0x%02X, linmot-linudp.md A-09)",
                        std::chrono::duration_cast<std::chrono::milliseconds>(timeout).count(),
                        count, last.count & 0x0F, last.status));
  }
  log::Debug("rtc", log::Fields()
                        .Add("drive", name_)
                        .Add("command", absl::StrFormat("0x%02X", command_id))
                        .Add("count", static_cast<int>(count))
                        .Add("status", absl::StrFormat("0x%02X", sample_.rtc->status)));
  return *sample_.rtc;
}

absl::StatusOr<RtcReply> LinMotUdpDrive::RtcRestart(Duration timeout) {
  const std::string what = "RTC command 0x30 (Restart Drive)";
  std::lock_guard rtc(rtc_mu_);
  std::unique_lock lock(mu_);
  const TimePoint deadline = clock_.Now() + timeout;
  DGW_RETURN_IF_ERROR(WaitOnlineLocked(lock, deadline, what.c_str()));
  // 0x30 goes with count 0; if the echo is 0 already, a NOP with count 1 first makes 0 a
  // change.
  if (!sample_.rtc || (sample_.rtc->count & 0x0F) == 0) {
    DGW_RETURN_IF_ERROR(RtcTransactLocked(lock, static_cast<uint8_t>(RtcCommand::kNoOperation), 0,
                                          0, 0, deadline, timeout, what + ": NOP before restart")
                            .status());
  }
  rtc_block_ = RtcRequest{0, static_cast<uint8_t>(RtcCommand::kRestartDrive), 0, 0, 0};
  MarkUrgentLocked();
  const uint64_t gen = ++rtc_generation_;
  const uint64_t timeouts_before = timeouts_;
  std::optional<uint64_t> replies_at_silence;
  log::Info("drive_restart", log::Fields().Add("drive", name_).Add("endpoint", endpoint()));
  // complete on the first reply with echo 0 and status 0 that follows at least one
  // unanswered telegram. The link goes OFFLINE meanwhile (the drive is really silent), so the
  // wait tolerates it.
  const Wait w = WaitLocked(
      lock, deadline,
      [&] {
        if (!replies_at_silence && timeouts_ > timeouts_before) replies_at_silence = replies_;
        return replies_at_silence && replies_ > *replies_at_silence && rtc_answered_ >= gen &&
               sample_.rtc && (sample_.rtc->count & 0x0F) == 0 &&
               sample_.rtc->status == kRtcStatusDone;
      },
      /*tolerate_offline=*/true);
  rtc_block_.reset();
  if (w != Wait::kReached) {
    return WaitFailure(
        w, what.c_str(),
        absl::StrCat(replies_at_silence ? "the drive went silent but did not come back"
                                        : "the drive never went silent",
                     " within ",
                     std::chrono::duration_cast<std::chrono::milliseconds>(timeout).count(),
                     " ms (linmot-linudp.md A-11)"));
  }
  log::Info("drive_restarted", log::Fields().Add("drive", name_).Add("state", StateTextLocked()));
  return *sample_.rtc;
}

absl::StatusOr<int64_t> LinMotUdpDrive::ReadParameter(const ParameterRef& ref) {
  DGW_RETURN_IF_ERROR(RequireActive("ReadParameter"));
  if (ref.id > 0xFFFF) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "drive '%s': parameter.id: 0x%X exceeds the UPID range 0x0000-0xFFFF", name_, ref.id));
  }
  const std::string what =
      absl::StrFormat("read %s value of UPID 0x%04X", ref.rom ? "ROM" : "RAM", ref.id);
  const RtcCommand command =
      ref.rom ? RtcCommand::kReadRomValueByUpid : RtcCommand::kReadRamValueByUpid;
  DGW_ASSIGN_OR_RETURN(const RtcReply r,
                       RtcTransact(static_cast<uint8_t>(command), static_cast<uint16_t>(ref.id), 0,
                                   0, config().timeouts.request, what));
  if (IsRtcError(r.status)) return RtcStatusError(name_, what, r.status);
  // linmot-linudp.md §3.5: words 3-4 are one little-endian Int32.
  const uint32_t raw = static_cast<uint32_t>(r.word3) | (static_cast<uint32_t>(r.word4) << 16);
  return static_cast<int64_t>(static_cast<int32_t>(raw));
}

absl::Status LinMotUdpDrive::WriteParameter(const ParameterRef& ref, int64_t value) {
  DGW_RETURN_IF_ERROR(RequireActive("WriteParameter"));
  if (ref.id > 0xFFFF) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "drive '%s': parameter.id: 0x%X exceeds the UPID range 0x0000-0xFFFF", name_, ref.id));
  }
  // 32 bits travel; UInt32 parameters above 7FFF'FFFFh may be given unsigned (decision 705).
  if (value < std::numeric_limits<int32_t>::min() ||
      value > static_cast<int64_t>(std::numeric_limits<uint32_t>::max())) {
    return absl::OutOfRangeError(absl::StrFormat(
        "drive '%s': parameter 0x%04X value: %d does not fit 32 bits [-2147483648, 4294967295]",
        name_, ref.id, value));
  }
  const uint32_t raw = static_cast<uint32_t>(value);
  const std::string what =
      absl::StrFormat("write %s value of UPID 0x%04X", ref.rom ? "ROM" : "RAM", ref.id);
  const RtcCommand command =
      ref.rom ? RtcCommand::kWriteRomValueByUpid : RtcCommand::kWriteRamValueByUpid;
  DGW_ASSIGN_OR_RETURN(
      const RtcReply r,
      RtcTransact(static_cast<uint8_t>(command), static_cast<uint16_t>(ref.id),
                  static_cast<uint16_t>(raw & 0xFFFF), static_cast<uint16_t>(raw >> 16),
                  config().timeouts.request, what));
  if (IsRtcError(r.status)) return RtcStatusError(name_, what, r.status);
  return absl::OkStatus();
}

absl::StatusOr<NativeReply> LinMotUdpDrive::SendNative(const NativeRequest& req) {
  DGW_RETURN_IF_ERROR(RequireActive("SendNative"));
  if (const auto* rtc = std::get_if<LinMotRtcRequest>(&req)) {
    const std::string what = absl::StrFormat("RTC command 0x%02X", rtc->command_id);
    if (rtc->command_id == static_cast<uint8_t>(RtcCommand::kRestartDrive) ||
        rtc->command_id == static_cast<uint8_t>(RtcCommand::kDeleteAllCurves) ||
        (rtc->command_id >= static_cast<uint8_t>(RtcCommand::kStartAddingCurve) &&
         rtc->command_id <= static_cast<uint8_t>(RtcCommand::kModifyCurveData))) {
      // The caller changes curves behind the curve service's back (decision 707).
      std::lock_guard lock(mu_);
      verified_curves_.clear();
      ++curve_epoch_;
    }
    const Duration timeout = RtcTimeout(rtc->command_id, config().timeouts.request);
    DGW_ASSIGN_OR_RETURN(
        const RtcReply r,
        rtc->command_id == static_cast<uint8_t>(RtcCommand::kRestartDrive)
            ? RtcRestart(timeout)
            : RtcTransact(rtc->command_id, rtc->word2, rtc->word3, rtc->word4, timeout, what));
    NativeReply out;
    out.status = r.status;
    out.word2 = r.word2;
    out.word3 = r.word3;
    out.word4 = r.word4;
    return out;
  }
  const auto* mp = std::get_if<LinMotMcRequest>(&req);
  if (mp == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        "drive '", name_, "': send_native: family linmot takes linmot_motion or linmot_rtc"));
  }
  const LinMotMcRequest& m = *mp;
  const std::string where = absl::StrCat("drive '", name_, "': send_native.mc");
  if (m.sub_id > 0x0F) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".sub_id: ", m.sub_id, " exceeds 15"));
  }
  if (m.parameters.size() > mc::kMcBlockSize - 2) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".parameters: ", m.parameters.size(),
                                                   " bytes exceed 30 (linmot-mc.md D-02)"));
  }
  const mc::CommandSpec* spec = mc::FindCommand(m.master_id, m.sub_id);
  if (spec == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: command %02X%Xxh is not in the catalogue (linmot-mc.md §5.19, D-20)",
                        where, m.master_id, m.sub_id));
  }
  if (mc::CommandId{m.master_id, m.sub_id} == mc::kReset) {
    return absl::InvalidArgumentError(
        absl::StrCat(where,
                     ": Reset (00Fxh) needs count 0 (linmot-mc.md §4.3 rule 4); not sent by the "
                     "count handshake"));
  }
  if (m.parameters.size() + 2 < spec->size()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".parameters: ", m.parameters.size(),
                                                   " bytes, ", spec->key(), " needs ",
                                                   spec->size() - 2));
  }
  mc::McBlock block{};
  block[0] = static_cast<uint8_t>(m.sub_id << 4);
  block[1] = m.master_id;
  std::copy(m.parameters.begin(), m.parameters.end(), block.begin() + 2);
  absl::StatusOr<mc::DecodedMotionCommand> decoded = mc::DecodeMotionCommand(block);
  if (!decoded.ok()) {
    return absl::Status(decoded.status().code(),
                        absl::StrCat(where, ": ", decoded.status().message()));
  }
  std::unique_lock op = LockOperation();
  DGW_ASSIGN_OR_RETURN(const CommandInfo info,
                       RunMotion(absl::StrCat("Native ", spec->name), decoded->command,
                                 /*needs_in_target=*/false, std::nullopt));
  std::lock_guard lock(mu_);
  NativeReply out;
  out.command_id = info.id;
  out.word2 = sample_.state_var.raw();
  out.word3 = sample_.status_word.raw;
  out.word4 = sample_.warn_word;
  return out;
}

}  // namespace drivegw::linmot::linudp
