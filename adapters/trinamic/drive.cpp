// TrinamicDrive: one SIXpack/QUADpack motor behind the Drive API (drive.h; decisions 1081-1099).
#include "adapters/trinamic/drive.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "adapters/core/motion_limits.h"
#include "adapters/core/status.h"

namespace drivegw::trinamic {
namespace {

using std::chrono::milliseconds;
using Updates = std::vector<std::pair<uint64_t, std::pair<CommandState, std::string>>>;

// Decision 1087: the warning after a detected controller reset, until the next Enable.
constexpr char kResetWarning[] = "controller reset: parameters re-applied, re-enable and re-home";
// A duplicate-address fault can be acknowledged once no second answer came for this long.
constexpr milliseconds kDuplicateQuiet{1000};

std::string Num(double v) { return absl::StrCat(v); }

absl::Status Prefixed(const std::string& prefix, const absl::Status& s) {
  return absl::Status(s.code(), absl::StrCat(prefix, s.message()));
}

}  // namespace

std::string ActionText(uint8_t action) {
  switch (action) {
    case kActionInactive:
      return "inactive";
    case kActionRamp:
      return "ramp";
    case kActionPi:
      return "PI control";
    case kActionRotation:
      return "rotation";
    case 30:
      return "mechanical reference";
    default:
      break;
  }
  if (action >= 20 && action <= 29) {
    return absl::StrCat("reference search (phase ", std::to_string(action), ")");
  }
  return absl::StrCat("action ", std::to_string(action));
}

TrinamicDrive::TrinamicDrive(DriveConfig config, const Clock& clock, ParameterShadow shadow)
    : DriveBase(std::move(config)),
      clock_(clock),
      name_(this->config().name),
      axis_(this->config().trinamic->axis),
      mpu_(this->config().trinamic->microsteps_per_unit),
      shadow_(std::move(shadow)) {
  (void)clock_;
}

TrinamicDrive::~TrinamicDrive() { Deactivate(); }

std::string TrinamicDrive::endpoint() const {
  return absl::StrCat("trinamic://", Pack::KeyOf(*config().trinamic), "/motor/",
                      std::to_string(axis_));
}

std::string TrinamicDrive::Prefix(const std::string& what) const {
  return absl::StrCat("drive '", name_, "': ", what, ": ");
}

// ---------------------------------------------------------------------------------------------
// Lifecycle.

absl::Status TrinamicDrive::DoActivate() {
  auto pack = Pack::Acquire(*config().trinamic, absl::StrCat("drive '", name_, "'"));
  if (!pack.ok()) return pack.status();
  {
    std::lock_guard lock(mu_);
    pack_ = *pack;
    link_ = LinkState::kUnknown;
    link_reason_.clear();
    sample_.reset();
    enabled_ = false;
    homed_ = false;
    stop_fault_ = duplicate_fault_ = reset_warning_ = false;
    tracker_.reset();
  }
  // Registration queues this axis's configuration words ($11 all 8 included: the axis starts
  // DISABLED, decision 1082); they go out before its first motion word (Pack::EnsureApplied).
  if (auto s = (*pack)->Register(axis_, this, config().trinamic->poll_period); !s.ok()) {
    std::lock_guard lock(mu_);
    pack_.reset();
    return s;
  }
  {
    std::lock_guard lock(mu_);
    registered_ = true;
  }
  // OFFLINE after Activate is a state, not a failure (drive.h).
  if (auto s = (*pack)->Probe(); !s.ok()) {
    log::Info("trinamic_offline_at_activate",
              log::Fields().Add("drive", name_).Add("reason", std::string(s.message())));
  }
  std::lock_guard lock(mu_);
  if (pack_->link_state() == LinkState::kOnline) link_ = LinkState::kOnline;
  // The controller's health so far (decision 1431); later changes come through OnHealth.
  SetHealth(pack_->health());
  PublishLocked();
  return absl::OkStatus();
}

void TrinamicDrive::DoDeactivate() {
  StopCurveRunner();  // it sends words through the Pack: gone before the Pack is released
  std::shared_ptr<Pack> pack;
  {
    std::lock_guard lock(mu_);
    pack = pack_;
  }
  if (pack && registered_) pack->Unregister(axis_);
  if (pack) pack->SetWireTrace(config().name, false);  // a shared Pack outlives this axis
  std::lock_guard lock(mu_);
  registered_ = false;
  if (tracker_) {
    UpdateCommand(tracker_->id, CommandState::kAborted, "drive deactivated");
    tracker_.reset();
  }
  pack_.reset();
  link_ = LinkState::kUnknown;
  sample_.reset();
  PublishLocked();
  cv_.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Pack callbacks (poll thread).

std::vector<Command> TrinamicDrive::ApplyCommands(bool controller) const {
  std::lock_guard lock(mu_);
  std::vector<Command> words = shadow_.ApplyCommands(config().trinamic->address, controller);
  // The configured currents wait for Enable: after activation and after every reset the axis is
  // DISABLED = all current indices 8 (decision 1082; the PACK's own default, §5.12, is I1 50 %).
  auto off = CurrentsWord(false);
  bool replaced = false;
  for (Command& w : words) {
    if (w.opcode == Opcode::kCurrentControl && off.ok()) {
      w = *off;
      replaced = true;
    }
  }
  if (!replaced && off.ok()) words.push_back(*off);
  return words;
}

void TrinamicDrive::AbsorbWord(const Command& word) noexcept {
  std::lock_guard lock(mu_);
  // Decision 1082: this axis's `$11` in the shadow is the configured currents; the PACK may hold
  // the current-off word meanwhile, so the drive records its own `$11` itself (1092).
  if (word.opcode == Opcode::kCurrentControl && word.values[0] == axis_) return;
  shadow_.Absorb(word);
}

absl::Status TrinamicDrive::CheckShared(uint32_t id, int64_t value, int baud) const {
  std::lock_guard lock(mu_);
  absl::Status s = shadow_.Validate(id, value, baud);
  if (s.ok()) return s;
  return absl::InvalidArgumentError(absl::StrCat(
      "drive '", name_, "' (motor ", std::to_string(axis_), ") would break: ", s.message()));
}

int TrinamicDrive::LineBaud() const {
  std::shared_ptr<Pack> pack;
  {
    std::lock_guard lock(mu_);
    pack = pack_;
  }
  if (pack) {
    if (auto b = pack->line_baud()) return *b;
  }
  const auto& tc = *config().trinamic;
  return tc.serial ? tc.serial->baud : kResetBaud;
}

std::optional<int> TrinamicDrive::can_bit_rate() const {
  std::lock_guard lock(mu_);
  if (!pack_) return std::nullopt;
  return pack_->can_bit_rate();
}

void TrinamicDrive::EvaluateLocked(Updates& out) {
  if (!sample_ || !tracker_) return;
  const AxisSample& s = *sample_;
  Tracker& t = *tracker_;
  if (s.sent <= t.sent) return;  // the sample's query left before the word completed
  auto finish = [&](CommandState st, std::string msg) {
    out.push_back({t.id, {st, std::move(msg)}});
    tracker_.reset();
  };
  if (stop_fault_) {
    finish(CommandState::kError,
           absl::StrCat("stop condition (stop switch / analogue limit), $20 P6, at ",
                        std::to_string(s.posact), " microsteps"));
    return;
  }
  switch (t.track) {
    case TrackKind::kMove:
    case TrackKind::kCoordinated:
      if (!t.accepted && (s.action != kActionInactive || s.posact == t.target)) {
        t.accepted = true;
        out.push_back({t.id, {CommandState::kActive, ""}});
      }
      if (t.accepted && s.action == kActionInactive) {
        if (s.posact == t.target) {
          finish(CommandState::kDone, "");
        } else {
          finish(CommandState::kAborted,
                 absl::StrCat("motion ended at ", std::to_string(s.posact), " microsteps, target ",
                              std::to_string(t.target)));
        }
      }
      return;
    case TrackKind::kStop:
      if (!t.accepted) {
        t.accepted = true;
        out.push_back({t.id, {CommandState::kActive, ""}});
      }
      if (s.action == kActionInactive) finish(CommandState::kDone, "");
      return;
    case TrackKind::kRotation:
      if (!t.accepted && s.action == kActionRotation) {
        t.accepted = true;
        out.push_back({t.id, {CommandState::kActive, ""}});
      } else if (t.accepted && s.action != kActionRotation) {
        finish(CommandState::kAborted, absl::StrCat("rotation ended (", ActionText(s.action), ")"));
      }
      return;
    case TrackKind::kCurve:
      // Acceptance of the first leg only: the motor stands between legs, the runner decides the
      // end (decision 1232).
      if (!t.accepted && (s.action != kActionInactive || s.posact == t.target)) {
        t.accepted = true;
        out.push_back({t.id, {CommandState::kActive, ""}});
      }
      return;
    case TrackKind::kHome:
      if (IsReferenceAction(s.action)) {
        t.homing_seen = true;
        if (!t.accepted) {
          t.accepted = true;
          out.push_back({t.id, {CommandState::kActive, ""}});
        }
      }
      if (t.homing_seen && s.action == kActionInactive) {
        homed_ = true;
        finish(CommandState::kDone, "");
      }
      return;
  }
}

void TrinamicDrive::OnSample(const AxisSample& sample) noexcept {
  bool abort_homing = false;
  {
    std::lock_guard lock(mu_);
    ++counters_.samples;
    sample_ = sample;
    if (pack_ && pack_->link_state() == LinkState::kOnline) link_ = LinkState::kOnline;
    if (sample.stop_flag) {
      // Cleared by the PACK on read (L663): the drive latches it until AcknowledgeFault.
      stop_fault_ = true;
      ++counters_.stop_conditions;
    }
    Updates updates;
    EvaluateLocked(updates);
    if (tracker_ && tracker_->track == TrackKind::kHome &&
        SessionClock::now() > tracker_->deadline) {
      // G-13: abort a reference search with `$25 0` and report the time-out.
      updates.push_back({tracker_->id,
                         {CommandState::kError,
                          absl::StrCat("reference search did not finish within ",
                                       std::to_string(config().timeouts.homing.count()), " ms")}});
      tracker_.reset();
      abort_homing = true;
    }
    // The snapshot first: a client woken by the command's end reads the sample that ended it.
    PublishLocked();
    for (const auto& [id, u] : updates) UpdateCommand(id, u.first, u.second);
  }
  cv_.notify_all();
  if (abort_homing) (void)SendWord(Word(Opcode::kStartRotation, {axis_, 0}));
}

void TrinamicDrive::OnLink(LinkState state, const std::string& reason) noexcept {
  {
    std::lock_guard lock(mu_);
    link_ = state;
    link_reason_ = reason;
    std::optional<uint64_t> open;
    if (state != LinkState::kOnline) {
      sample_.reset();
      if (tracker_) open = tracker_->id;
      tracker_.reset();
    }
    PublishLocked();
    if (open) {
      UpdateCommand(*open, CommandState::kError,
                    absl::StrCat("drive '", name_, "': link lost: ", reason));
    }
  }
  cv_.notify_all();
}

void TrinamicDrive::OnControllerReset() noexcept {
  {
    std::lock_guard lock(mu_);
    ++counters_.resets;
    // Decision 1087 (like 983): no automatic re-enable, the reference is gone.
    enabled_ = false;
    homed_ = false;
    reset_warning_ = true;
    PublishLocked();
    if (tracker_) {
      UpdateCommand(tracker_->id, CommandState::kError,
                    "controller reset: every parameter back at its default (L853, G-24)");
      tracker_.reset();
    }
  }
  cv_.notify_all();
}

void TrinamicDrive::OnDuplicateAddress(const std::string& detail) noexcept {
  {
    std::lock_guard lock(mu_);
    duplicate_fault_ = true;
    duplicate_detail_ = detail;
    duplicate_seen_ = SessionClock::now();
    PublishLocked();
    if (tracker_) {
      UpdateCommand(tracker_->id, CommandState::kError, detail);
      tracker_.reset();
    }
  }
  cv_.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Status.

DriveStatus TrinamicDrive::BuildStatusLocked() const {
  DriveStatus s;
  const uint8_t action = ActionLocked();
  if (duplicate_fault_) {
    s.state = DriveState::kFault;
  } else if (!OnlineLocked()) {
    s.state = DriveState::kOffline;
  } else if (stop_fault_) {
    s.state = DriveState::kFault;
  } else if (IsReferenceAction(action)) {
    s.state = DriveState::kHoming;
  } else if (action != kActionInactive ||
             (tracker_ && (tracker_->track == TrackKind::kCoordinated ||
                           tracker_->track == TrackKind::kCurve))) {
    s.state = DriveState::kMoving;
  } else {
    s.state = enabled_ ? DriveState::kEnabled : DriveState::kDisabled;
  }
  s.native.main_state = action;
  s.native.text = sample_ ? ActionText(action) : std::string("no sample");
  s.native.status_word = stop_fault_ ? 1 : 0;
  s.homed = homed_;
  if (sample_) {
    s.position_mm = sample_->posact / mpu_;
    const VelocityScale scale{shadow_.clkdiv(), shadow_.div()};
    auto v = VelocityToMmPerSecond(sample_->vact, scale, mpu_);
    s.velocity_mm_s = v.ok() ? *v : 0;
    s.motion_active = action != kActionInactive;
    const bool tracks_target = tracker_ && (tracker_->track == TrackKind::kMove ||
                                            tracker_->track == TrackKind::kCoordinated ||
                                            tracker_->track == TrackKind::kCurve);
    s.demand_position_mm = tracks_target ? tracker_->target / mpu_ : s.position_mm;
    s.in_target =
        action == kActionInactive && (!tracks_target || sample_->posact == tracker_->target);
  }
  if (reset_warning_) s.warnings.push_back(kResetWarning);
  if (link_ == LinkState::kOffline) {
    s.warnings.push_back(absl::StrCat("drive '", name_, "' OFFLINE: ", link_reason_));
  }
  if (duplicate_fault_) {
    s.fault = Fault{
        kFaultDuplicateAddress,
        absl::StrCat("another controller answers at address ",
                     std::to_string(config().trinamic->address), " (", duplicate_detail_, ")"),
        true};
  } else if (stop_fault_) {
    s.fault =
        Fault{kFaultStopCondition, "stop condition (stop switch / analogue limit), $20 P6", false};
  }
  return s;
}

void TrinamicDrive::PublishLocked() { PublishStatus(BuildStatusLocked()); }

absl::Status TrinamicDrive::RequireOnlineLocked(const std::string& what) const {
  if (OnlineLocked()) return absl::OkStatus();
  return absl::UnavailableError(
      absl::StrCat(Prefix(what), "controller OFFLINE (",
                   link_reason_.empty() ? std::string("no sample yet") : link_reason_, ")"));
}

absl::Status TrinamicDrive::RequireOperationalLocked(const std::string& what) const {
  if (duplicate_fault_ || stop_fault_) {
    return absl::FailedPreconditionError(absl::StrCat(Prefix(what), "drive is in FAULT (",
                                                      BuildStatusLocked().fault.text,
                                                      "); AcknowledgeFault first"));
  }
  DGW_RETURN_IF_ERROR(RequireOnlineLocked(what));
  if (!enabled_) {
    return absl::FailedPreconditionError(
        absl::StrCat(Prefix(what), "needs state ENABLED, drive is DISABLED (motor current off)"));
  }
  return absl::OkStatus();
}

template <typename Pred>
TrinamicDrive::Wait TrinamicDrive::WaitLocked(std::unique_lock<std::mutex>& lock,
                                              SessionClock::time_point deadline, Pred pred) {
  for (;;) {
    if (pred()) return Wait::kReached;
    if (!registered_) return Wait::kInactive;
    if (link_ == LinkState::kOffline) return Wait::kOffline;
    if (cv_.wait_until(lock, deadline) == std::cv_status::timeout) {
      return pred() ? Wait::kReached : Wait::kDeadline;
    }
  }
}

TrinamicDrive::Wait TrinamicDrive::WaitSampleLocked(
    std::unique_lock<std::mutex>& lock, SessionClock::time_point after,
    SessionClock::time_point deadline, const std::function<bool(const AxisSample&)>& pred) {
  return WaitLocked(lock, deadline,
                    [&] { return sample_ && sample_->sent > after && pred(*sample_); });
}

// ---------------------------------------------------------------------------------------------
// Words.

Command TrinamicDrive::Word(Opcode opcode, std::initializer_list<int64_t> values) const {
  Command c;
  c.address = config().trinamic->address;
  c.opcode = opcode;
  size_t i = 0;
  for (int64_t v : values) c.values[i++] = v;
  return c;
}

absl::StatusOr<Command> TrinamicDrive::CurrentsWord(bool on) const {
  // `$11` (L514-528): on = the configured I0..I3 from the shadow, off = all indices 8 (0 %).
  const int64_t t0 = shadow_.Get(Opcode::kCurrentControl, "t0");
  if (!on) return Word(Opcode::kCurrentControl, {axis_, 8, 8, 8, 8, t0 == 0 ? 500 : t0});
  return Word(
      Opcode::kCurrentControl,
      {axis_, shadow_.Get(Opcode::kCurrentControl, "i0"),
       shadow_.Get(Opcode::kCurrentControl, "i1"), shadow_.Get(Opcode::kCurrentControl, "i2"),
       shadow_.Get(Opcode::kCurrentControl, "i3"), t0 == 0 ? 500 : t0});
}

absl::StatusOr<std::optional<Reply>> TrinamicDrive::SendWord(const Command& command) {
  std::shared_ptr<Pack> pack;
  {
    std::lock_guard lock(mu_);
    pack = pack_;
    ++counters_.words;
  }
  const std::string what = SpecOf(command.opcode).name;
  if (!pack) {
    return absl::FailedPreconditionError(absl::StrCat(Prefix(what), "drive not active"));
  }
  auto r = pack->Send(command, SessionClock::now() + config().trinamic->reply_timeout);
  if (!r.ok()) return Prefixed(Prefix(what), r.status());
  return r;
}

void TrinamicDrive::PollSoon() {
  std::shared_ptr<Pack> pack;
  {
    std::lock_guard lock(mu_);
    pack = pack_;
  }
  if (pack) pack->PollSoon(axis_);
}

absl::Status TrinamicDrive::SendAll(const std::vector<Command>& commands) {
  for (const Command& c : commands) {
    auto r = SendWord(c);
    if (!r.ok()) return r.status();
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Enable / Disable / AcknowledgeFault.

absl::StatusOr<CommandInfo> TrinamicDrive::Enable() {
  DGW_RETURN_IF_ERROR(RequireActive("Enable"));
  std::lock_guard op(op_mu_);
  absl::StatusOr<Command> word = absl::UnknownError("");
  {
    std::lock_guard lock(mu_);
    if (duplicate_fault_ || stop_fault_) {
      return absl::FailedPreconditionError(absl::StrCat(Prefix("Enable"), "drive is in FAULT (",
                                                        BuildStatusLocked().fault.text,
                                                        "); AcknowledgeFault first"));
    }
    DGW_RETURN_IF_ERROR(RequireOnlineLocked("Enable"));
    word = CurrentsWord(true);
  }
  if (!word.ok()) return Prefixed(Prefix("Enable"), word.status());
  const CommandInfo info = StartCommand("Enable", false);
  if (auto r = SendWord(*word); !r.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(r.status().message()));
    return r.status();
  }
  {
    std::lock_guard lock(mu_);
    enabled_ = true;
    reset_warning_ = false;
    PublishLocked();
  }
  UpdateCommand(info.id, CommandState::kDone);
  return *GetCommand(info.id);
}

absl::Status TrinamicDrive::SendAndAwaitSample(
    const Command& word, const std::function<bool(const AxisSample&)>& reached,
    const std::function<absl::Status()>& timed_out) {
  auto sent = SendWord(word);
  if (!sent.ok()) return sent.status();
  const auto after = SessionClock::now();
  PollSoon();
  std::unique_lock lock(mu_);
  const Wait w = WaitSampleLocked(lock, after, after + config().timeouts.request, reached);
  if (w == Wait::kReached) return absl::OkStatus();
  return timed_out();
}

absl::Status TrinamicDrive::StopAndWait(const std::string& what) {
  return SendAndAwaitSample(
      Word(Opcode::kStopMotors, {1 << axis_}),  // `$2A` (L765-771)
      [](const AxisSample& s) { return s.action == kActionInactive; },
      [&] {
        return absl::DeadlineExceededError(absl::StrCat(
            Prefix(what), "motor ", std::to_string(axis_), " still ",
            sample_ ? ActionText(sample_->action) : std::string("without sample"), " after ",
            std::to_string(config().timeouts.request.count()), " ms (stop_motors)"));
      });
}

absl::StatusOr<CommandInfo> TrinamicDrive::Disable() {
  DGW_RETURN_IF_ERROR(RequireActive("Disable"));
  std::lock_guard op(op_mu_);
  bool active = false;
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireOnlineLocked("Disable"));
    active = ActionLocked() != kActionInactive;
  }
  const CommandInfo info = StartCommand("Disable", true);  // interrupts a running motion
  {
    std::lock_guard lock(mu_);
    tracker_.reset();
  }
  if (active) {
    if (auto s = StopAndWait("Disable"); !s.ok()) {
      UpdateCommand(info.id, CommandState::kError, std::string(s.message()));
      return s;
    }
  }
  absl::StatusOr<Command> off = absl::UnknownError("");
  {
    std::lock_guard lock(mu_);
    off = CurrentsWord(false);
  }
  if (!off.ok()) return off.status();
  if (auto r = SendWord(*off); !r.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(r.status().message()));
    return r.status();
  }
  {
    std::lock_guard lock(mu_);
    enabled_ = false;
    PublishLocked();
  }
  UpdateCommand(info.id, CommandState::kDone);
  return *GetCommand(info.id);
}

absl::StatusOr<CommandInfo> TrinamicDrive::AcknowledgeFault() {
  DGW_RETURN_IF_ERROR(RequireActive("AcknowledgeFault"));
  std::lock_guard op(op_mu_);
  {
    std::lock_guard lock(mu_);
    if (duplicate_fault_ && SessionClock::now() - duplicate_seen_ < kDuplicateQuiet) {
      return absl::FailedPreconditionError(
          absl::StrCat(Prefix("AcknowledgeFault"), "another controller still answers at address ",
                       std::to_string(config().trinamic->address), " (", duplicate_detail_,
                       "); fix the address switches first"));
    }
  }
  const CommandInfo info = StartCommand("AcknowledgeFault", false);
  {
    std::lock_guard lock(mu_);
    stop_fault_ = false;
    duplicate_fault_ = false;
    duplicate_detail_.clear();
    PublishLocked();
  }
  UpdateCommand(info.id, CommandState::kDone);
  return *GetCommand(info.id);
}

// ---------------------------------------------------------------------------------------------
// Motion.

absl::StatusOr<TrinamicDrive::Ramp> TrinamicDrive::RampFor(const std::string& kind,
                                                           double velocity_mm_s,
                                                           double acceleration_mm_s2,
                                                           double deceleration_mm_s2) const {
  const AxisConfig& axis = config().axis;
  const double d = deceleration_mm_s2 == 0 ? acceleration_mm_s2 : deceleration_mm_s2;
  DGW_RETURN_IF_ERROR(CheckMoveProfile(kind, velocity_mm_s, acceleration_mm_s2, d, axis));
  // §5.4: one amax for both ramp halves; the smaller of the two keeps both limits (1088).
  const double a = std::min(acceleration_mm_s2, d);
  const VelocityScale scale{shadow_.clkdiv(), shadow_.div()};
  Ramp r;
  auto v = MmPerSecondToVelocity(velocity_mm_s, scale, mpu_);
  if (!v.ok()) return Prefixed(kind + ".velocity_mm_s: ", v.status());
  r.vmax = std::max(1, *v);  // below one velocity unit: the slowest the PACK runs
  DGW_ASSIGN_OR_RETURN(r.amax, AmaxFor(kind + ".acceleration_mm_s2", a));
  return r;
}

absl::StatusOr<int> TrinamicDrive::AmaxFor(const std::string& field, double a) const {
  const VelocityScale scale{shadow_.clkdiv(), shadow_.div()};
  auto amax = MmPerSecond2ToAmax(a, scale, mpu_);
  if (!amax.ok()) return Prefixed(field + ": ", amax.status());
  const int64_t vstart = shadow_.Get(Opcode::kStartingVelocity, "vstart");
  const int64_t limit = std::max<int64_t>(1, vstart) * 64;
  if (*amax > limit) {
    auto limit_mm =
        AmaxToMmPerSecond2(static_cast<int>(std::min<int64_t>(limit, 32767)), scale, mpu_);
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": ", Num(a), " exceeds the PACK's limit ", Num(limit_mm.ok() ? *limit_mm : 0),
        " mm/s² (amax <= vstart x 64 = ", std::to_string(limit), ", L556; raise $13.vstart)"));
  }
  return *amax;
}

absl::StatusOr<int32_t> TrinamicDrive::TargetFor(const std::string& field, double mm) const {
  const AxisConfig& axis = config().axis;
  if (!std::isfinite(mm)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", Num(mm), " is not a finite number"));
  }
  if (mm < axis.min_mm || mm > axis.max_mm) {
    return absl::OutOfRangeError(absl::StrCat(field, ": ", Num(mm), " is outside the axis range [",
                                              Num(axis.min_mm), ", ", Num(axis.max_mm), "]"));
  }
  auto t = MmToMicrosteps(mm, mpu_);
  if (!t.ok()) return Prefixed(field + ": ", t.status());
  return *t;
}

absl::Status TrinamicDrive::WriteRamp(const Ramp& ramp) {
  Command word;
  {
    std::lock_guard lock(mu_);
    if (shadow_.Get(Opcode::kSetRamp, "amax") == ramp.amax &&
        shadow_.Get(Opcode::kSetRamp, "vmax") == ramp.vmax) {
      return absl::OkStatus();
    }
    word = Word(Opcode::kSetRamp, {axis_, ramp.amax, ramp.vmax});  // `$14` (L550-561)
  }
  auto r = SendWord(word);
  if (!r.ok()) return r.status();
  std::lock_guard lock(mu_);
  shadow_.Absorb(word);
  return absl::OkStatus();
}

absl::Status TrinamicDrive::StartRampTo(int32_t target) {
  uint8_t action = 0;
  {
    std::lock_guard lock(mu_);
    action = ActionLocked();
  }
  if (action != kActionInactive && action != kActionRamp) {
    // `$23` only stops a rotation (L693, CT-27) and is ignored in any other active mode (L691):
    // `$25 0` ends rotation, PI control and a reference search (G-13, G-36), then the ramp.
    DGW_RETURN_IF_ERROR(SendAndAwaitSample(
        Word(Opcode::kStartRotation, {axis_, 0}), [](const AxisSample& s) { return s.action == 0; },
        [&] {
          return absl::DeadlineExceededError(absl::StrCat(
              "start_rotation 0: motor ", std::to_string(axis_), " did not stand still within ",
              std::to_string(config().timeouts.request.count()), " ms"));
        }));
    action = 0;
  }
  if (action == kActionRamp) {
    // L691/L722: `$26` changes the running ramp's target; the following `$23` with the same
    // target starts the motor if the ramp ended meanwhile (ignored while active, CT-23, CT-26).
    auto r = SendWord(Word(Opcode::kSetTarget, {axis_, target}));
    if (!r.ok()) return r.status();
  }
  auto r = SendWord(Word(Opcode::kStartRamp, {axis_, target}));
  return r.ok() ? absl::OkStatus() : r.status();
}

absl::StatusOr<CommandInfo> TrinamicDrive::AwaitAcceptance(uint64_t id, const std::string& kind) {
  const auto& tc = *config().trinamic;
  const auto deadline =
      SessionClock::now() + config().timeouts.accept + 2 * tc.poll_period + 2 * tc.reply_timeout;
  std::unique_lock lock(mu_);
  const Wait w = WaitLocked(lock, deadline, [&] {
    auto info = GetCommand(id);
    return !info || info->state != CommandState::kBusy;
  });
  if (w != Wait::kReached) {
    auto info = GetCommand(id);
    if (info && info->state == CommandState::kBusy) {
      ++counters_.accept_failures;
      if (tracker_ && tracker_->id == id) tracker_.reset();
      const auto window = config().timeouts.accept + 2 * tc.poll_period + 2 * tc.reply_timeout;
      const std::string msg =
          absl::StrCat(Prefix(kind), "not confirmed: no $20 after the word showed motor ",
                       std::to_string(axis_), " active or at its target within ",
                       std::to_string(window.count()), " ms (no acknowledgements exist, G-06)");
      UpdateCommand(id, CommandState::kError, msg);
      return absl::DeadlineExceededError(msg);
    }
  }
  auto info = GetCommand(id);
  if (!info) return absl::InternalError(absl::StrCat(Prefix(kind), "command lost"));
  if (info->state == CommandState::kError) {
    return absl::AbortedError(absl::StrCat(Prefix(kind), info->message));
  }
  return *info;
}

CommandInfo TrinamicDrive::BeginTracker(const std::string& kind, TrackKind track, int32_t target,
                                        SessionClock::time_point sent,
                                        SessionClock::time_point deadline) {
  const CommandInfo info = StartCommand(kind, true);
  std::lock_guard lock(mu_);
  Tracker t;
  t.id = info.id;
  t.kind = kind;
  t.track = track;
  t.target = target;
  t.sent = sent;
  t.deadline = deadline;
  tracker_ = t;
  return info;
}

absl::StatusOr<CommandInfo> TrinamicDrive::Move(const MotionCommand& cmd) {
  DGW_RETURN_IF_ERROR(RequireActive("Move"));
  std::lock_guard op(op_mu_);
  auto r = RunMotion(cmd);
  if (!r.ok() && r.status().message().find("drive '") == std::string::npos) {
    return Prefixed(Prefix(KindName(cmd)), r.status());
  }
  return r;
}

absl::StatusOr<CommandInfo> TrinamicDrive::RunMotion(const MotionCommand& cmd) {
  const std::string kind = KindName(cmd);
  const AxisConfig& axis = config().axis;
  int32_t posact = 0;
  int32_t base = 0;
  {
    std::lock_guard lock(mu_);
    if (std::holds_alternative<StopMotion>(cmd)) {
      DGW_RETURN_IF_ERROR(RequireOnlineLocked(kind));
    } else {
      DGW_RETURN_IF_ERROR(RequireOperationalLocked(kind));
    }
    posact = sample_->posact;
    // Decision 1090: a relative move counts from the running ramp's target, else from posact.
    base = (tracker_ && tracker_->track == TrackKind::kMove && sample_->action == kActionRamp)
               ? tracker_->target
               : posact;
  }
  if (const auto* s = std::get_if<StopMotion>(&cmd)) {
    // Decision 1088: deceleration 0 keeps the running amax; a given one becomes `$14.amax`,
    // clamped to the PACK's limit (vstart x 64, L556) — a Stop never fails for being too hard.
    const double d = s->deceleration_mm_s2;
    if (!std::isfinite(d) || d < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("stop.deceleration_mm_s2: ", Num(d), " must not be negative"));
    }
    Ramp ramp;
    {
      std::lock_guard lock(mu_);
      ramp.vmax = static_cast<int>(shadow_.Get(Opcode::kSetRamp, "vmax"));
      ramp.amax = static_cast<int>(shadow_.Get(Opcode::kSetRamp, "amax"));
    }
    if (d > 0) {
      const VelocityScale scale{shadow_.clkdiv(), shadow_.div()};
      auto amax = MmPerSecond2ToAmax(d, scale, mpu_);
      const int64_t limit = std::min<int64_t>(
          32767, std::max<int64_t>(1, shadow_.Get(Opcode::kStartingVelocity, "vstart")) * 64);
      if (amax.ok()) {
        ramp.amax = static_cast<int>(std::min<int64_t>(*amax, limit));
      } else {
        // Below one amax unit: the gentlest ramp; above 32767: the hardest allowed.
        auto one = AmaxToMmPerSecond2(1, scale, mpu_);
        ramp.amax = (one.ok() && d < *one) ? 1 : static_cast<int>(limit);
      }
    }
    const CommandInfo info = StartCommand(kind, true);
    {
      std::lock_guard lock(mu_);
      tracker_.reset();
    }
    absl::Status s1 = WriteRamp(ramp);
    absl::StatusOr<std::optional<Reply>> s2 =
        s1.ok() ? SendWord(Word(Opcode::kStopMotors, {1 << axis_})) : s1;
    if (!s2.ok()) {
      UpdateCommand(info.id, CommandState::kError, std::string(s2.status().message()));
      return s2.status();
    }
    const auto sent = SessionClock::now();
    {
      std::lock_guard lock(mu_);
      Tracker t;
      t.id = info.id;
      t.kind = kind;
      t.track = TrackKind::kStop;
      t.sent = sent;
      tracker_ = t;
    }
    PollSoon();
    return AwaitAcceptance(info.id, kind);
  }

  int32_t target = 0;
  Ramp ramp;
  TrackKind track = TrackKind::kMove;
  int rotation_velocity = 0;
  if (const auto* m = std::get_if<MoveAbsolute>(&cmd)) {
    DGW_ASSIGN_OR_RETURN(target, TargetFor("move_absolute.position_mm", m->position_mm));
    DGW_ASSIGN_OR_RETURN(ramp, RampFor("move_absolute", m->velocity_mm_s, m->acceleration_mm_s2,
                                       m->deceleration_mm_s2));
  } else if (const auto* m = std::get_if<MoveRelative>(&cmd)) {
    if (!std::isfinite(m->distance_mm)) {
      return absl::InvalidArgumentError(
          absl::StrCat("move_relative.distance_mm: ", Num(m->distance_mm), " is not finite"));
    }
    const double end_mm = base / mpu_ + m->distance_mm;
    if (end_mm < axis.min_mm || end_mm > axis.max_mm) {
      return absl::OutOfRangeError(absl::StrCat("move_relative.distance_mm: ", Num(m->distance_mm),
                                                " from ", Num(base / mpu_), " mm ends at ",
                                                Num(end_mm), " mm, outside the axis range [",
                                                Num(axis.min_mm), ", ", Num(axis.max_mm), "]"));
    }
    DGW_ASSIGN_OR_RETURN(const int32_t steps, MmToMicrosteps(m->distance_mm, mpu_));
    const int64_t t = int64_t{base} + steps;
    if (t < std::numeric_limits<int32_t>::min() || t > std::numeric_limits<int32_t>::max()) {
      return absl::OutOfRangeError("move_relative.distance_mm: target outside int32 microsteps");
    }
    target = static_cast<int32_t>(t);
    DGW_ASSIGN_OR_RETURN(ramp, RampFor("move_relative", m->velocity_mm_s, m->acceleration_mm_s2,
                                       m->deceleration_mm_s2));
  } else {
    const auto& mv = std::get<MoveVelocity>(cmd);
    if (!std::isfinite(mv.velocity_mm_s) || mv.velocity_mm_s == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("move_velocity.velocity_mm_s: ", Num(mv.velocity_mm_s),
                       " must be non-zero (its sign picks the direction; use Stop)"));
    }
    DGW_ASSIGN_OR_RETURN(ramp, RampFor("move_velocity", std::fabs(mv.velocity_mm_s),
                                       mv.acceleration_mm_s2, mv.deceleration_mm_s2));
    if (axis.kind == AxisKind::kRotary) {
      // `$25` rotation (L711-718): a rotary axis has no end to run to.
      track = TrackKind::kRotation;
      rotation_velocity = mv.velocity_mm_s > 0 ? ramp.vmax : -ramp.vmax;
    } else {
      // Decision 005: a ramp to the axis end in the velocity's direction at vmax = |v|.
      DGW_ASSIGN_OR_RETURN(target, TargetFor("move_velocity (axis end)",
                                             mv.velocity_mm_s > 0 ? axis.max_mm : axis.min_mm));
    }
  }

  const CommandInfo info = StartCommand(kind, true);  // supersedes the running motion (PLCopen)
  {
    std::lock_guard lock(mu_);
    tracker_.reset();
  }
  absl::Status sent = WriteRamp(ramp);
  if (sent.ok()) {
    if (track == TrackKind::kRotation) {
      auto r = SendWord(Word(Opcode::kStartRotation, {axis_, rotation_velocity}));
      sent = r.ok() ? absl::OkStatus() : r.status();
    } else {
      sent = StartRampTo(target);
    }
  }
  if (!sent.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(sent.message()));
    return sent;
  }
  const auto now = SessionClock::now();
  {
    std::lock_guard lock(mu_);
    Tracker t;
    t.id = info.id;
    t.kind = kind;
    t.track = track;
    t.target = target;
    t.sent = now;
    tracker_ = t;
  }
  PollSoon();
  return AwaitAcceptance(info.id, kind);
}

absl::StatusOr<CommandInfo> TrinamicDrive::Home() {
  DGW_RETURN_IF_ERROR(RequireActive("Home"));
  std::lock_guard op(op_mu_);
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireOperationalLocked("Home"));
  }
  const CommandInfo info = StartCommand("Home", true);
  {
    std::lock_guard lock(mu_);
    tracker_.reset();
    homed_ = false;
  }
  // `$22` (L678-685): the PACK runs the whole search (§5.7) and reports 20..29 / 30 meanwhile.
  if (auto r = SendWord(Word(Opcode::kStartReferenceSearch, {axis_})); !r.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(r.status().message()));
    return r.status();
  }
  const auto now = SessionClock::now();
  {
    std::lock_guard lock(mu_);
    Tracker t;
    t.id = info.id;
    t.kind = "Home";
    t.track = TrackKind::kHome;
    t.sent = now;
    t.deadline = now + config().timeouts.homing;
    tracker_ = t;
  }
  PollSoon();
  return AwaitAcceptance(info.id, "Home");
}

absl::StatusOr<std::vector<CommandInfo>> TrinamicDrive::MoveCoordinated(
    const CoordinatedMove& move, std::span<Drive* const> group) {
  DGW_RETURN_IF_ERROR(RequireActive("MoveCoordinated"));
  const std::string kind = "MoveCoordinated";
  if (group.empty() || group[0] != this) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix(kind), "the group must start with this drive"));
  }
  if (move.positions_mm.size() != group.size()) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix(kind), "positions_mm has ",
                                                   move.positions_mm.size(), " entries for ",
                                                   group.size(), " drives"));
  }
  std::vector<TrinamicDrive*> members;
  uint8_t mask = 0;
  for (Drive* d : group) {
    auto* t = dynamic_cast<TrinamicDrive*>(d);
    if (t == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat(
          Prefix(kind), "drive '", d ? d->config().name : std::string("null"),
          "' is not a trinamic drive (coordinated moves need one SIXpack/QUADpack, §5.5)"));
    }
    std::shared_ptr<Pack> their;
    {
      std::lock_guard lock(t->mu_);
      their = t->pack_;
    }
    if (!their || their != pack_) {
      return absl::InvalidArgumentError(
          absl::StrCat(Prefix(kind), "drive '", t->name_, "' is not active on controller ",
                       pack_ ? pack_->key() : std::string("?"), " ($50 interpolates one PACK)"));
    }
    if (mask & (1 << t->axis_)) {
      return absl::InvalidArgumentError(absl::StrCat(
          Prefix(kind), "motor ", std::to_string(t->axis_), " appears twice in the group"));
    }
    mask |= static_cast<uint8_t>(1 << t->axis_);
    members.push_back(t);
  }
  std::lock_guard op(op_mu_);
  // Targets and the master (longest path in microsteps, like the PACK, §5.5).
  std::vector<int32_t> targets;
  size_t master = 0;
  int64_t longest = -1;
  for (size_t i = 0; i < members.size(); ++i) {
    TrinamicDrive* t = members[i];
    int32_t posact = 0;
    {
      std::lock_guard lock(t->mu_);
      auto s = t->RequireOperationalLocked(kind);
      if (!s.ok()) return s;
      if (t->ActionLocked() != kActionInactive) {
        return absl::FailedPreconditionError(
            absl::StrCat(t->Prefix(kind), "motor ", std::to_string(t->axis_), " is active (",
                         ActionText(t->ActionLocked()), "); $50 needs standing motors (L908)"));
      }
      posact = t->sample_->posact;
    }
    auto target = t->TargetFor(absl::StrCat("positions_mm[", i, "]"), move.positions_mm[i]);
    if (!target.ok()) return Prefixed(t->Prefix(kind), target.status());
    targets.push_back(*target);
    const int64_t dist = std::llabs(int64_t{*target} - posact);
    if (dist > longest) {
      longest = dist;
      master = i;
    }
  }
  TrinamicDrive* m = members[master];
  auto ramp = m->RampFor("move_coordinated", move.velocity_mm_s, move.acceleration_mm_s2, 0);
  if (!ramp.ok()) return Prefixed(m->Prefix(kind), ramp.status());

  std::vector<CommandInfo> infos;
  for (TrinamicDrive* t : members) {
    infos.push_back(
        t->BeginTracker(kind, TrackKind::kCoordinated, 0, SessionClock::time_point::max(), {}));
  }
  auto fail = [&](const absl::Status& s) {
    for (size_t i = 0; i < members.size(); ++i) {
      std::lock_guard lock(members[i]->mu_);
      members[i]->tracker_.reset();
      members[i]->UpdateCommand(infos[i].id, CommandState::kError, std::string(s.message()));
    }
    return s;
  };
  // §5.5/G-16: only the master's `$14` matters, the PACK scales the others.
  if (auto s = m->WriteRamp(*ramp); !s.ok()) return fail(s);
  // Chapter 7 example (L443-469, CT-31): `$26` per motor, then `$50` with the mask.
  for (size_t i = 0; i < members.size(); ++i) {
    auto r = SendWord(Word(Opcode::kSetTarget, {members[i]->axis_, targets[i]}));
    if (!r.ok()) return fail(r.status());
  }
  if (auto r = SendWord(Word(Opcode::kInterpolate, {mask})); !r.ok()) return fail(r.status());
  const auto sent = SessionClock::now();
  for (size_t i = 0; i < members.size(); ++i) {
    TrinamicDrive* t = members[i];
    {
      std::lock_guard lock(t->mu_);
      if (t->tracker_ && t->tracker_->id == infos[i].id) {
        t->tracker_->target = targets[i];
        t->tracker_->sent = sent;
      }
    }
    t->PollSoon();
  }
  std::vector<CommandInfo> out;
  for (size_t i = 0; i < members.size(); ++i) {
    auto r = members[i]->AwaitAcceptance(infos[i].id, kind);
    if (!r.ok()) return r.status();
    out.push_back(*r);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Parameters and native access.

absl::StatusOr<int64_t> TrinamicDrive::ReadParameter(const ParameterRef& ref) {
  DGW_RETURN_IF_ERROR(RequireActive("ReadParameter"));
  if (ref.rom) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix("ReadParameter"), "no stored values (G-24: the PACK keeps nothing)"));
  }
  auto def = FindParameter(ref.id);
  if (!def.ok()) return Prefixed(Prefix("ReadParameter"), def.status());
  std::lock_guard lock(mu_);
  // No read-back exists (G-24): the shadow is what the gateway wrote (decision 1091).
  return shadow_.Get(ref.id);
}

absl::Status TrinamicDrive::WriteParameter(const ParameterRef& ref, int64_t value) {
  DGW_RETURN_IF_ERROR(RequireActive("WriteParameter"));
  const std::string what = "WriteParameter";
  if (ref.rom) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix(what), "no stored values (G-24: the PACK keeps nothing)"));
  }
  auto def = FindParameter(ref.id);
  if (!def.ok()) return Prefixed(Prefix(what), def.status());
  const auto& tc = *config().trinamic;
  const int baud = LineBaud();
  std::lock_guard op(op_mu_);
  absl::StatusOr<Command> word = absl::UnknownError("");
  bool currents_off = false;
  {
    std::lock_guard lock(mu_);
    // CT-55: validated before anything goes out.
    if (auto s = shadow_.Validate(ref.id, value, baud); !s.ok()) return Prefixed(Prefix(what), s);
    if ((*def)->rule == WriteRule::kAxisStopped && sample_ && sample_->action != kActionInactive) {
      return absl::FailedPreconditionError(absl::StrCat(
          Prefix(what), (*def)->name, " changes only while motor ", std::to_string(axis_),
          " stands still (L539, L609, CT-56); it is active: ", ActionText(sample_->action)));
    }
    word = shadow_.WriteCommand(tc.address, ref.id, value, baud);
    currents_off = (*def)->opcode == Opcode::kCurrentControl && !enabled_;
  }
  if (!word.ok()) return Prefixed(Prefix(what), word.status());
  if ((*def)->scope == ParameterScope::kController) {
    // Decision 1098 (CT-55, L497): a controller-wide value must suit every axis of the PACK;
    // each shadow knows only its own velocities.
    std::shared_ptr<Pack> pack;
    {
      std::lock_guard lock(mu_);
      pack = pack_;
    }
    if (pack) {
      if (auto s = pack->CheckShared(ref.id, value, baud); !s.ok()) {
        return Prefixed(Prefix(what), s);
      }
    }
  }
  if ((*def)->rule == WriteRule::kAllStopped) {
    // L532: `$12` only while every motor stands: ask the PACK (`$28`, mask 0) and the samples.
    Command q = Word(Opcode::kQueryActivities, {tc.response_address, 0});
    auto r = SendWord(q);
    if (!r.ok()) return r.status();
    std::vector<std::string> active;
    if (r->has_value()) {
      for (int m = 0; m < tc.axes; ++m) {
        if ((**r).values[m] != 0) active.push_back(std::to_string(m));
      }
    }
    std::shared_ptr<Pack> pack;
    {
      std::lock_guard lock(mu_);
      pack = pack_;
    }
    if (pack) {
      for (const auto& [n, s] : pack->samples()) {
        const std::string mn = std::to_string(n);
        if (s.action != 0 && std::find(active.begin(), active.end(), mn) == active.end()) {
          active.push_back(mn);
        }
      }
    }
    if (!active.empty()) {
      std::string list;
      for (const auto& a : active) list += (list.empty() ? "" : ", ") + a;
      return absl::FailedPreconditionError(
          absl::StrCat(Prefix(what), (*def)->name,
                       " changes only while every motor stands still (L532, CT-56); active: "
                       "motor ",
                       list));
    }
  }
  if (!currents_off) {
    // Decision 1092: `$11` of a DISABLED axis is only recorded; Enable sends it.
    auto r = SendWord(*word);
    if (!r.ok()) return r.status();
  }
  std::lock_guard lock(mu_);
  shadow_.Absorb(*word);
  return absl::OkStatus();
}

absl::StatusOr<NativeReply> TrinamicDrive::SendNative(const NativeRequest& req) {
  DGW_RETURN_IF_ERROR(RequireActive("SendNative"));
  const auto& tc = *config().trinamic;
  if (const auto* tun = std::get_if<TrinamicTunnelRequest>(&req)) {
    std::shared_ptr<Pack> pack;
    {
      std::lock_guard lock(mu_);
      pack = pack_;
    }
    if (!pack) return absl::FailedPreconditionError(Prefix("SendNative") + "not active");
    if (!tc.can) {
      return absl::FailedPreconditionError(
          absl::StrCat(Prefix("rs232_tunnel"), "tunnel needs CAN (§3.5); this drive is serial"));
    }
    if (auto s = pack->SendTunnel(tun->data); !s.ok()) {
      return Prefixed(Prefix("rs232_tunnel"), s);
    }
    return NativeReply{};
  }
  const auto* tr = std::get_if<TrinamicRequest>(&req);
  if (tr == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix("SendNative"),
                                                   "not a Trinamic request (TrinamicRequest / "
                                                   "TrinamicTunnelRequest)"));
  }
  if (tr->opcode >= 0xF2 && tr->opcode <= 0xF7) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix("SendNative"),
                     "service opcodes $F2..$F7 are refused (L918: misuse can damage the "
                     "unit permanently)"));
  }
  if (tr->opcode == static_cast<uint8_t>(Opcode::kQueryActivities) && tr->params[1] != 0) {
    // Decision 1099 (G-41, CT-17): the session never leaves a reply outstanding; a delayed `$28`
    // would block the line until the masked motors stop (L740, L357).
    return absl::InvalidArgumentError(absl::StrCat(
        Prefix("SendNative"), "query_activities ($28) with delay mask ",
        std::to_string(tr->params[1]),
        " is refused (G-41: the gateway never has a delayed reply outstanding); send mask 0 and "
        "poll until the motors are inactive"));
  }
  auto spec = FindOpcode(tr->opcode);
  if (!spec.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix("SendNative"), "opcode ",
                                                   std::to_string(tr->opcode),
                                                   " is not in the instruction table (§4.1)"));
  }
  std::vector<uint8_t> bytes{tc.address, tr->opcode};
  bytes.insert(bytes.end(), tr->params.begin(), tr->params.end());
  auto command = DecodeCommand(bytes);
  if (!command.ok()) return Prefixed(Prefix("SendNative"), command.status());
  // Replies must come back to the session's RA (§2.4, decision 1093).
  if ((*spec)->response_address_field >= 0) {
    command->values[(*spec)->response_address_field] = tc.response_address;
  }
  if (auto s = ValidateCommand(*command); !s.ok()) return Prefixed(Prefix("SendNative"), s);
  std::lock_guard op(op_mu_);
  auto r = SendWord(*command);
  if (!r.ok()) return r.status();
  {
    // Configuration opcodes are remembered so that a reset re-applies them (G-24).
    std::lock_guard lock(mu_);
    shadow_.Absorb(*command);
  }
  NativeReply out;
  if (r->has_value()) {
    auto body = EncodeReply(**r, ReplyFraming::kR8);
    if (!body.ok()) return Prefixed(Prefix("SendNative"), body.status());
    out.data = std::move(*body);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Diagnostics.

TrinamicDriveCounters TrinamicDrive::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

absl::Status TrinamicDrive::SetWireTrace(bool on) {
  std::lock_guard lock(mu_);
  if (!pack_) {
    return absl::FailedPreconditionError(
        absl::StrCat("drive '", config().name, "': SetWireTrace needs state ACTIVE"));
  }
  pack_->SetWireTrace(config().name, on);
  return absl::OkStatus();
}

std::optional<PackCounters> TrinamicDrive::pack_counters() const {
  std::lock_guard lock(mu_);
  if (!pack_) return std::nullopt;
  return pack_->counters();
}

std::optional<SessionCounters> TrinamicDrive::session_counters() const {
  std::lock_guard lock(mu_);
  if (!pack_) return std::nullopt;
  return pack_->session_counters();
}

ParameterShadow TrinamicDrive::shadow() const {
  std::lock_guard lock(mu_);
  return shadow_;
}

}  // namespace drivegw::trinamic
