// StoberDrive: CiA 402 power state machine and the STOBER motion core over CANopen
// (stober-motion.md §1-§4; CiA 301 v4.2.0; CiA 402-2 §6.2). Gap choices: decisions 1191-1219.
#include "adapters/stober/drive.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/master_pool.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/stober/factory.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::stober {
namespace {

using namespace std::chrono_literals;
namespace co = drivegw::canopen;

constexpr Duration kWorkerTick = 20ms;
constexpr Duration kStatusRefresh = 100ms;  // TPDO1 event timer (object_map.cpp MakeLayout)
constexpr int kDoneRepeats = 3;             // decision 1484
constexpr double kIncrement = 0.001;      // one wire increment of a position (object_map.cpp kUPos)
constexpr Duration kMinExecuteLow = 3ms;  // decision 1197 (1179: ≥ one A150 cycle)
constexpr Duration kEdgeFallback = 10ms;
constexpr int kAcceptCycles = 4;  // decision 1207: A150/SYNC periods added to timeouts.accept
constexpr Duration kResetRetry = 100ms;      // a fault reset edge not taken is repeated     // the
                                             // simulated node advances at least every 5 ms
constexpr double kJerkPerAcceleration = 10;  // jerk = 10/s × acceleration (decision 1198)

uint16_t Cw(const RpdoImage& i) {
  return static_cast<uint16_t>((i.control_word & ~control::kExecute) |
                               (i.execute ? control::kExecute : 0));
}

absl::Status Annotate(const absl::Status& s, const std::string& prefix) {
  return absl::Status(s.code(), absl::StrCat(prefix, s.message()));
}

// Commands that can be a subsequent (buffered) block: their Done rows say "buffered: only at the
// end of the subsequent block" (stober-motion.md §2.7 L292; decision 1162).
bool Bufferable(uint8_t command) {
  return (command >= mc::kMoveAbsolute && command <= mc::kStop) || command == mc::kMoveSpeed ||
         command == mc::kHalt;
}

// Running blocks whose end the node hands over at (decision 1162): a handle of one of them that
// a buffered block follows has completed when the take-over comes; others were cancelled.
bool ChainsToSuccessor(uint8_t command) {
  return (command >= mc::kMoveAbsolute && command <= mc::kMoveVelocity) ||
         command == mc::kMoveSpeed || command == mc::kHalt;
}

}  // namespace

StoberDrive::StoberDrive(DriveConfig config, const Clock& clock)
    : DriveBase(std::move(config)), clock_(clock), node_(this->config().node_id.value_or(1)) {}

StoberDrive::~StoberDrive() { Deactivate(); }

std::string StoberDrive::endpoint() const {
  return absl::StrCat("canopen://", config().can ? transport::CanSpecString(*config().can) : "?",
                      "/node/", std::to_string(node_));
}

std::string StoberDrive::Prefix(const std::string& what) const {
  return absl::StrCat("drive '", config().name, "' (node ", std::to_string(node_), ") ", what,
                      ": ");
}

TimePoint StoberDrive::Deadline() const { return clock_.Now() + config().timeouts.request; }

Duration StoberDrive::CycleTime() const { return cycle_; }

bool StoberDrive::SyncRpdos() const {
  return config().canopen.rpdo_transmission_type <= co::kTransmissionSyncEveryMax;
}

co::PdoCommParams StoberDrive::RpdoComm(const PdoLayout& layout) const {
  co::PdoCommParams comm = layout.comm;
  if (layout.kind == co::PdoKind::kRpdo) {
    comm.transmission_type = config().canopen.rpdo_transmission_type;
  }
  return comm;
}

StoberDriveCounters StoberDrive::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

std::optional<co::MasterCounters> StoberDrive::master_counters() const {
  std::lock_guard lock(mu_);
  if (!master_) return std::nullopt;
  return master_->counters();
}

absl::Status StoberDrive::SetWireTrace(bool on) {
  std::lock_guard lock(mu_);
  if (!master_) return absl::FailedPreconditionError(Prefix("SetWireTrace") + "needs state ACTIVE");
  master_->SetNodeTrace(node_, on ? config().name : std::string());
  return absl::OkStatus();
}

// ---------------------------------------------------------------- lifecycle

absl::Status StoberDrive::DoActivate() {
  if (!config().can) {
    return absl::InvalidArgumentError(Prefix("Activate") + "no can bus configured");
  }
  co::MasterOptions options;
  options.sdo_timeout = config().canopen.sdo_timeout;
  options.sdo_retries = config().canopen.sdo_retries;
  options.clock = &clock_;
  auto master = co::CanopenMasterPool::Instance().Acquire(*config().can, options);
  if (!master.ok()) return Annotate(master.status(), Prefix("Activate"));
  auto id = (*master)->AddNodeObserver(node_, this);
  if (!id.ok()) return Annotate(id.status(), Prefix("Activate"));
  (*master)->SetNodeLabel(node_, config().family, config().name);  // SDO round-trip metrics
  {
    std::lock_guard lock(mu_);
    master_ = *master;
    observer_ = *id;
    stop_ = false;
    need_config_ = true;
    configured_ = false;
    link_ok_ = true;
    status_.reset();
    offline_reason_ = "configuring the node";
    health_.emplace(StoberHealthConfig(config()), clock_);
    PublishHealthLocked();
    PublishLocked();
  }
  worker_ = std::thread([this] { RunWorker(); });
  // The first configuration usually completes at once; a missing node is a state (OFFLINE), the
  // worker keeps probing (drive.h: Activate may return with the drive OFFLINE).
  std::unique_lock lock(mu_);
  WaitLocked(lock, Deadline(), [&] { return configured_ || counters_.configure_failures > 0; });
  return absl::OkStatus();
}

void StoberDrive::DoDeactivate() {
  StopCurveRunner();  // before the stream is detached: the runner owns a stream
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  DetachStream();
  std::shared_ptr<co::CanopenMaster> master;
  std::optional<co::ObserverId> observer;
  {
    std::lock_guard lock(mu_);
    master = master_;
    observer = observer_;
    observer_.reset();
  }
  if (master && observer) master->RemoveNodeObserver(*observer);
  if (master) {  // the bus master outlives this drive
    master->SetNodeTrace(node_, "");
    master->SetNodeLabel(node_, "", "");
  }
  std::lock_guard lock(mu_);
  EndTrackerLocked(CommandState::kAborted, "drive deactivated");
  configured_ = false;
  offline_reason_ = "deactivated";
  master_.reset();
  PublishLocked();
}

void StoberDrive::RunWorker() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    const TimePoint now = clock_.Now();
    if (need_config_ && now >= next_try_) {
      const uint64_t gen = config_gen_;
      configuring_ = true;
      lock.unlock();
      const absl::Status s = Configure();
      lock.lock();
      configuring_ = false;
      if (s.ok() && gen == config_gen_) {
        need_config_ = false;
        configured_ = true;
        link_ok_ = true;
        ++counters_.configurations;
        log::Info("stober_configured", log::Fields().Add("drive", config().name));
        // DOWN -> DEMOTED (recovering); status TPDOs and heartbeats make it UP after the hold
        // (health.up_after_ms, decision 1432).
        health_->RecordSuccess();
        PublishHealthLocked();
      } else if (!s.ok()) {
        ++counters_.configure_failures;
        offline_reason_ = std::string(s.message());
        // Decision 1431: the shared model counts the failure and sets the back-off (default
        // 500 ms, constant: health.backoff_*_ms, StoberHealthConfig, decision 1194).
        health_->RecordFailure("configuration failures");
        PublishHealthLocked();
        next_try_ = health_->state() == HealthState::kDown
                        ? health_->next_probe()
                        : clock_.Now() + health_->config().backoff_min;
      }
      PublishLocked();
      cv_.notify_all();
      continue;
    }
    if (tracker_ && tracker_->deadline && now > *tracker_->deadline) {
      EndTrackerLocked(CommandState::kError,
                       absl::StrCat(tracker_->kind, " did not finish within timeouts.homing (",
                                    config().timeouts.homing.count(), " ms)"));
      PublishLocked();
    }
    cv_.wait_for(lock, kWorkerTick);
  }
}

// The drive-side watchdog (decision 1483): the master produces its own heartbeat, the node
// consumes it (1016h:01) and reacts to its loss with 6007h = quick stop, so a killed gateway
// does not leave a move running. Both written idempotently and read back.
absl::Status StoberDrive::ConfigureMasterWatchdog(co::CanopenMaster& m,
                                                  const std::function<TimePoint()>& deadline) {
  const auto& c = config().canopen;
  const std::string prefix = Prefix("configure");
  auto step = [&](absl::Status s, const char* what) -> absl::Status {
    if (s.ok()) return s;
    return Annotate(s, absl::StrCat(prefix, what, ": "));
  };
  if (c.master_node_id == 0) {
    // No master heartbeat: a consumer left by an earlier commissioning would stop the axis.
    return step(m.ConfigureHeartbeatConsumer(node_, 0, 0, deadline()), "1016h:01 cleared");
  }
  DGW_RETURN_IF_ERROR(step(m.StartOwnHeartbeat(c.master_node_id, c.heartbeat), "master heartbeat"));
  DGW_RETURN_IF_ERROR(step(
      m.ConfigureHeartbeatConsumer(node_, c.master_node_id,
                                   static_cast<uint16_t>(c.heartbeat_timeout.count()), deadline()),
      "1016h:01 master heartbeat consumer"));
  // CiA 402 6007h abort connection option code (INTEGER16): 3 = quick stop command.
  DGW_RETURN_IF_ERROR(step(m.WriteU16(node_, kAbortConnectionOption, 0, kAbortQuickStop, deadline(),
                                      co::SdoRetry::kIdempotent),
                           "6007h abort connection option"));
  auto back = m.ReadU16(node_, kAbortConnectionOption, 0, deadline());
  if (!back.ok()) return step(back.status(), "6007h read back");
  if (*back != kAbortQuickStop) {
    return absl::FailedPreconditionError(absl::StrCat(
        prefix, "6007h abort connection option: wrote ", kAbortQuickStop, ", reads back ", *back));
  }
  return absl::OkStatus();
}

// CiA 301 start-up of one node (decision 1194): probe 6041h, pre-operational, heartbeat producer
// and consumer, 1029h, the default PDO layout, the RPDO images and the status read back, start.
absl::Status StoberDrive::Configure() {
  std::shared_ptr<co::CanopenMaster> m;
  {
    std::lock_guard lock(mu_);
    m = master_;
  }
  if (!m) return absl::FailedPreconditionError("no master");
  // Each step's own budget: timeouts.request plus every try of one transfer (decision 1481). One
  // deadline for all ~30 transfers would run out under loss, where several of them need a retry.
  const auto& c = config().canopen;
  const Duration budget = config().timeouts.request + (1 + c.sdo_retries) * c.sdo_timeout;
  auto deadline = [&] { return clock_.Now() + budget; };
  const std::string prefix = Prefix("configure");
  auto sw = m->ReadU16(node_, 0x6041, 0, deadline());
  if (!sw.ok()) return Annotate(sw.status(), prefix + "node absent? ");
  auto step = [&](absl::Status s, const char* what) -> absl::Status {
    if (s.ok()) return s;
    return Annotate(s, absl::StrCat(prefix, what, ": "));
  };
  DGW_RETURN_IF_ERROR(step(m->SendNmt(co::NmtCommand::kEnterPreOperational, node_), "NMT"));
  DGW_RETURN_IF_ERROR(step(
      m->ConfigureHeartbeatProducer(node_, static_cast<uint16_t>(c.heartbeat.count()), deadline()),
      "1017h heartbeat producer"));
  // 1029h: a communication error takes the node to pre-operational, so no stale RPDO is applied
  // while the master is gone (decision 1194).
  DGW_RETURN_IF_ERROR(
      step(m->ConfigureErrorBehaviour(node_, co::ErrorBehaviour::kPreOperational, deadline()),
           "1029h error behaviour"));
  DGW_RETURN_IF_ERROR(ConfigureMasterWatchdog(*m, deadline));
  for (const PdoLayout& layout : DefaultPdoLayout()) {
    const co::PdoMapping mapping = layout.Mapping();
    DGW_RETURN_IF_ERROR(step(
        m->ConfigurePdo(node_, layout.kind, layout.number, RpdoComm(layout), mapping, deadline()),
        layout.kind == co::PdoKind::kRpdo ? "RPDO" : "TPDO"));
  }
  // Synchronous RPDOs act only on SYNC: the bus's producer runs from now on (decision 1119).
  if (SyncRpdos() && !m->sync_running()) {
    DGW_RETURN_IF_ERROR(step(m->StartSync(c.sync_period), "SYNC producer"));
  }
  auto read = [&](CanOpenAddress a) -> absl::StatusOr<double> {
    auto b = FindBinding(a);
    if (!b.ok()) return b.status();
    auto bytes = m->Upload(node_, a.index, a.sub_index, deadline());
    if (!bytes.ok()) return bytes.status();
    return Decode(*b, *bytes);
  };
  auto param = [&](const char* id) { return read(*ToCanOpen(P(id))); };
  RpdoImage image;
  MotionStatus status;
  ActualValues actual;
  double cycle_ms = 1;
  double travel = 0;
  uint8_t command_mode = 0;
  double end_velocity = 0;
  double position_window = 0;
  double velocity_window = 0;
  {
    DGW_ASSIGN_OR_RETURN(double cw, read({0x6040, 0}));
    image.control_word = static_cast<uint16_t>(cw);
    DGW_ASSIGN_OR_RETURN(double v, param("I401"));
    image.command = static_cast<uint8_t>(v);
    DGW_ASSIGN_OR_RETURN(image.position, param("I403"));
    DGW_ASSIGN_OR_RETURN(double ex, param("I402"));
    image.execute = ex != 0;
    DGW_ASSIGN_OR_RETURN(image.velocity, param("I404"));
    DGW_ASSIGN_OR_RETURN(image.acceleration, param("I405"));
    DGW_ASSIGN_OR_RETURN(image.deceleration, param("I406"));
    DGW_ASSIGN_OR_RETURN(image.jerk, param("I407"));
    DGW_ASSIGN_OR_RETURN(image.override_percent, param("I230"));
    DGW_ASSIGN_OR_RETURN(double dir, param("I411"));
    image.direction = static_cast<int>(dir);
    DGW_ASSIGN_OR_RETURN(double brake, param("I410"));
    image.brake_at_end = brake != 0;
    DGW_ASSIGN_OR_RETURN(double mid, param("I400"));
    image.motion_id = static_cast<uint32_t>(mid);
    DGW_ASSIGN_OR_RETURN(double mode, param("I409"));
    command_mode = static_cast<uint8_t>(mode);
    DGW_ASSIGN_OR_RETURN(end_velocity, param("I429"));
    DGW_ASSIGN_OR_RETURN(cycle_ms, param("A150"));
    DGW_ASSIGN_OR_RETURN(travel, param("I00"));
    DGW_ASSIGN_OR_RETURN(position_window, param("I22"));
    DGW_ASSIGN_OR_RETURN(velocity_window, param("C40"));
    DGW_ASSIGN_OR_RETURN(double plc, param("I89"));
    DGW_ASSIGN_OR_RETURN(double cause, param("I90"));
    auto flags = m->ReadU32(node_, kStatusFlagsIndex, kStatusFlagsSub, deadline());
    if (!flags.ok()) return flags.status();
    DGW_ASSIGN_OR_RETURN(actual.position, read({0x6064, 0}));
    DGW_ASSIGN_OR_RETURN(actual.velocity, read({0x606C, 0}));
    auto sw2 = m->ReadU16(node_, 0x6041, 0, deadline());
    if (!sw2.ok()) return sw2.status();
    status.status_word = *sw2;
    status.plc_state = static_cast<int>(plc);
    status.cause = static_cast<int>(cause);
    status.flags = *flags;
  }
  DGW_RETURN_IF_ERROR(step(m->SetHeartbeatConsumer(node_, c.heartbeat_timeout), "heartbeat"));
  uint64_t beats = 0;
  {
    std::lock_guard lock(mu_);
    image_ = image;
    command_mode_ = command_mode;
    end_velocity_ = end_velocity;
    status_ = status;
    status_at_ = clock_.Now();
    actual_ = actual;
    actual_at_ = clock_.Now();
    position_window_ = position_window;
    velocity_window_ = velocity_window;
    cycle_ = std::chrono::duration_cast<Duration>(
        std::chrono::duration<double, std::milli>(std::max(cycle_ms, 0.125)));
    if (SyncRpdos()) cycle_ += c.sync_period;  // an RPDO acts at the next SYNC (decision 1119)
    endless_ = travel != 0;
    execute_low_at_ = clock_.Now();
    beats = heartbeats_;
  }
  // Online only with a heartbeat reporting OPERATIONAL after the start (decision 1194): the
  // master's supervision starts with the first heartbeat, and one sent before the start was
  // handled must not look like "left OPERATIONAL". NMT is unconfirmed (CiA 301 §7.2.8.3.1) and
  // "start" in OPERATIONAL changes nothing, so a start that brought no such heartbeat is sent
  // again, canopen.sdo_retries times at most (decision 1481).
  for (int tries = 1;; ++tries) {
    DGW_RETURN_IF_ERROR(step(m->SendNmt(co::NmtCommand::kStart, node_), "NMT start"));
    std::unique_lock lock(mu_);
    const TimePoint hb_deadline = clock_.Now() + c.heartbeat_timeout;
    if (WaitLocked(lock, hb_deadline, [&] {
          return heartbeats_ > beats && heartbeat_state_ == co::NmtState::kOperational;
        })) {
      return absl::OkStatus();
    }
    if (tries > c.sdo_retries) {
      return absl::UnavailableError(absl::StrCat(
          prefix, "no OPERATIONAL heartbeat within ", c.heartbeat_timeout.count(),
          " ms (canopen.heartbeat_timeout)",
          tries > 1 ? absl::StrCat(" after each of ", tries, " NMT starts") : std::string()));
    }
  }
}

// ---------------------------------------------------------------- observer

void StoberDrive::OnHeartbeat(uint8_t, co::NmtState state, TimePoint) noexcept {
  std::lock_guard lock(mu_);
  ++heartbeats_;
  heartbeat_state_ = state;
  cv_.notify_all();
  // A heartbeat of the configured, OPERATIONAL node is a success of the shared model (decision
  // 1431): it comes every canopen.heartbeat, also while no status TPDO changes.
  if (configured_ && !configuring_ && link_ok_ && state == co::NmtState::kOperational && health_ &&
      health_->RecordSuccess()) {
    PublishHealthLocked();
  }
  if (configured_ && !configuring_ && state != co::NmtState::kOperational) {
    // 1029h or another master moved the node: PDOs stopped, configure it again.
    configured_ = false;
    need_config_ = true;
    ++config_gen_;
    GoOfflineLocked(
        absl::StrCat("node left OPERATIONAL (", std::string(co::NmtStateName(state)), ")"), false);
  }
}

void StoberDrive::OnBootUp(const co::NodeEventInfo&) noexcept {
  std::lock_guard lock(mu_);
  if (counters_.configurations > 0) ++counters_.bootups;
  configured_ = false;
  need_config_ = true;
  next_try_ = TimePoint{};  // the node is there now: configure at once
  ++config_gen_;
  emcy_code_ = 0;
  emcy_text_.clear();
  // decision 1199: the node lost its configuration and any motion; nothing is replayed.
  GoOfflineLocked("node rebooted", true);
}

void StoberDrive::OnEmcy(const co::EmcyEvent& event) noexcept {
  std::lock_guard lock(mu_);
  ++counters_.emcy;
  if (event.emcy.error_code == 0) {
    emcy_code_ = 0;
    emcy_text_.clear();
  } else {
    emcy_code_ = event.emcy.error_code;
    emcy_text_ = event.name;
  }
  PublishLocked();
}

void StoberDrive::OnTpdo(const co::TpdoEvent& event) noexcept {
  std::lock_guard lock(mu_);
  if (event.number == 1) {
    auto s = DecodeStatusTpdo(event.payload());
    if (!s.ok()) {
      ++counters_.malformed_tpdos;
      return;
    }
    status_ = *s;
    status_at_ = clock_.Now();
    ++status_seq_;
    ++counters_.status_tpdos;
    if (tracker_ && tracker_->done_withheld) {
      // Decision 1484: a status without Done after a withheld one shows the command running; the
      // withheld Done was stale. Done frames in a row are the node's own refreshes.
      if (s->done()) {
        ++tracker_->done_frames;
      } else {
        tracker_->done_withheld = false;
        tracker_->done_frames = 0;
      }
    }
    EvaluateTrackerLocked(clock_.Now());
  } else if (event.number == 2) {
    auto a = DecodeActualTpdo(event.payload());
    if (!a.ok()) {
      ++counters_.malformed_tpdos;
      return;
    }
    actual_ = *a;
    actual_at_ = clock_.Now();
    ++counters_.actual_tpdos;
    // Decision 1485: the axis left the start position after the edge, so the node took it.
    bool moved_now = false;
    if (tracker_ && tracker_->target && tracker_->start_position && !endless_ && !tracker_->moved &&
        actual_at_ >= tracker_->edge_sent + cycle_ &&
        std::abs(actual_.position - *tracker_->start_position) > position_window_ + kIncrement) {
      tracker_->moved = moved_now = true;
    }
    // A Done held back for want of this witness is decided now (decision 1484).
    if (tracker_ && (tracker_->done_withheld || moved_now)) EvaluateTrackerLocked(actual_at_);
  } else {
    return;
  }
  if (configured_ && link_ok_ && health_ && health_->RecordSuccess()) PublishHealthLocked();
  PublishLocked();
  cv_.notify_all();
}

void StoberDrive::OnLinkEvent(const co::NodeEventInfo& event) noexcept {
  std::lock_guard lock(mu_);
  switch (event.event) {
    case co::NodeEvent::kHeartbeatLost:
      ++counters_.heartbeat_losses;
      link_ok_ = false;
      GoOfflineLocked(absl::StrCat("heartbeat lost: ", event.reason), false);
      break;
    case co::NodeEvent::kBusOff:
    case co::NodeEvent::kLinkLost:
      link_ok_ = false;
      GoOfflineLocked(absl::StrCat(co::NodeEventName(event.event), ": ", event.reason), false);
      break;
    case co::NodeEvent::kHeartbeatResumed:
    case co::NodeEvent::kLinkRestored:
      // Re-read the node (it may have changed while unheard) before it counts as online again
      // (decision 1200); nothing the gateway sent earlier is repeated.
      link_ok_ = true;
      configured_ = false;
      need_config_ = true;
      next_try_ = TimePoint{};
      ++config_gen_;
      offline_reason_ = "re-configuring after the link came back";
      PublishLocked();
      break;
    default:
      break;
  }
  cv_.notify_all();
}

void StoberDrive::PublishHealthLocked() {
  if (health_) SetHealth(health_->info());
}

void StoberDrive::GoOfflineLocked(const std::string& reason, bool node_reset) {
  offline_reason_ = reason;
  // Every cause here is an immediate loss (heartbeat, bus-off, reboot, left OPERATIONAL).
  if (health_) {
    health_->ForceDown(reason);
    PublishHealthLocked();
  }
  EndTrackerLocked(CommandState::kError, reason);
  if (node_reset) status_.reset();
  PublishLocked();
  cv_.notify_all();
}

// ---------------------------------------------------------------- status

bool StoberDrive::OnlineLocked() const {
  return master_ != nullptr && configured_ && link_ok_ && status_.has_value();
}

DriveStatus StoberDrive::BuildStatusLocked() const {
  DriveStatus st;
  st.position_mm = actual_.position;
  st.velocity_mm_s = actual_.velocity;
  st.demand_position_mm = demand_reached_ && demand_target_ ? *demand_target_ : actual_.position;
  if (!OnlineLocked()) {
    st.state = DriveState::kOffline;
    st.native.text = offline_reason_;
    return st;
  }
  const MotionStatus& s = *status_;
  const PowerState p = DecodePowerState(s.status_word);
  st.state = MapState(s);
  st.native.status_word = s.status_word;
  st.native.main_state = static_cast<uint32_t>(s.plc_state);
  st.native.sub_state = static_cast<uint32_t>(s.cause);
  st.native.warn_word = s.flags;
  st.native.text = absl::StrCat(ToString(p), ", I89 ", PlcStateText(s.plc_state));
  if (s.cause != 0) absl::StrAppend(&st.native.text, ", I90 ", s.cause, ": ", CauseText(s.cause));
  st.homed = (s.flags & status_bit::kInReference) != 0;
  st.in_target = (s.flags & status_bit::kInWindow) != 0;
  st.motion_active =
      IsMotionPlcState(s.plc_state) || s.plc_state == kPlcHoming || s.command_state() != 0 ||
      p == PowerState::kQuickStopActive ||
      (p == PowerState::kOperationEnabled && (s.flags & status_bit::kStandstill) == 0);
  if (s.flags & status_bit::kPositiveLimitSwitch) {
    st.warnings.push_back("positive limit switch active (I441)");
  }
  if (s.flags & status_bit::kNegativeLimitSwitch) {
    st.warnings.push_back("negative limit switch active (I442)");
  }
  if (s.flags & status_bit::kVelocityLimit) st.warnings.push_back("velocity limited to I10 (I190)");
  if (s.flags & status_bit::kDynamicsLimit) {
    st.warnings.push_back("acceleration or jerk limited to I11/I16 (I191)");
  }
  if (IsFaultState(p)) {
    st.fault.code = emcy_code_ != 0 ? emcy_code_ : 0x1000;  // 1000h: generic error (CiA 301)
    st.fault.text = emcy_text_.empty()
                        ? absl::StrCat("CiA 402 ", ToString(p), " (6041h = ", s.status_word, ")")
                        : emcy_text_;
  } else if (s.plc_state == kPlcErrorStop) {
    // decision 1192: the motion core's error stop is a FAULT, acknowledged with bit 7.
    st.fault.code = 0xFF00u + static_cast<uint32_t>(s.cause);  // as EMCY FF00h + I90 (1178)
    st.fault.text = absl::StrCat("I89 7: Error stop, I90 ", s.cause, ": ", CauseText(s.cause));
  } else if (!emcy_text_.empty()) {
    st.warnings.push_back(emcy_text_);
  }
  return st;
}

void StoberDrive::PublishLocked() { PublishStatus(BuildStatusLocked()); }

void StoberDrive::EndTrackerLocked(CommandState state, const std::string& message) {
  // A buffered handle ends with a running one that fails or is aborted (decision 1210); after a
  // DONE (a status from before the buffered edge) it waits for its own take-over.
  std::optional<uint64_t> pending;
  if (pending_ && state != CommandState::kDone) {
    pending = pending_->id;
    pending_.reset();
  }
  if (!tracker_ && !pending) return;
  // The status that ended the command is published first: whoever wakes on the final handle
  // reads a status that already shows its outcome.
  std::optional<uint64_t> id;
  if (tracker_) id = tracker_->id;
  tracker_.reset();
  PublishLocked();
  if (id) UpdateCommand(*id, state, message);
  if (pending) UpdateCommand(*pending, state, message);
}

// Decision 1210: the buffered handle after its edge counts. I83 = 2 (decision 1163): queued
// behind the running block, which stays ACTIVE. I83 ≠ 2 without error: the node has taken it
// over (or started it at once because the running block had already ended): the running handle
// is DONE if its block hands over at its end, else ABORTED, and the buffered one becomes the
// tracked command. I91 = 1: the chain failed; the one status set (§2.3) cannot say which block,
// so both end ERROR with the cause.
bool StoberDrive::EvaluatePendingLocked(TimePoint now) {
  Tracker& p = *pending_;
  if (!p.counted) {
    if (now < p.edge_sent + cycle_) return false;  // produced before the edge was applied
    p.counted = true;
  }
  const MotionStatus& s = *status_;
  if (!s.done() && !s.error()) p.progress.reset_seen = true;
  if (!p.progress.reset_seen) return true;  // the edge's forced-0 cycle not seen yet
  if (s.error()) {
    const std::string message =
        absl::StrCat(CommandName(p.progress.command),
                     " (buffered) or the block before it denied or cancelled "
                     "by the motion core: I90 ",
                     s.cause, ": ", CauseText(s.cause));
    EndTrackerLocked(CommandState::kError, message);
    return true;
  }
  if (s.command_state() == 2) {
    p.buffered_seen = true;
    if (tracker_) UpdateCommand(tracker_->id, CommandState::kActive);
    return true;
  }
  // The successor is ACTIVE before its predecessor ends: whoever wakes on the first handle's
  // DONE finds the second one running.
  std::optional<Tracker> previous = std::move(tracker_);
  tracker_ = std::move(p);
  pending_.reset();
  tracker_->progress.active_seen = true;
  UpdateCommand(tracker_->id, CommandState::kActive);
  if (previous) {
    const bool completed = ChainsToSuccessor(previous->progress.command);
    UpdateCommand(previous->id, completed ? CommandState::kDone : CommandState::kAborted,
                  completed ? "" : absl::StrCat("superseded by ", tracker_->kind));
  }
  return false;
}

// §2.15: DONE = I92 of the latest command (after its forced-0 cycle, §2.7), ERROR = I91 with
// the I90 cause, ACTIVE = I83/I89 show it running; leaving Operation enabled ends it.
void StoberDrive::EvaluateTrackerLocked(TimePoint now) {
  if ((!tracker_ && !pending_) || !status_) return;
  const MotionStatus& s = *status_;
  const PowerState p = DecodePowerState(s.status_word);
  if (p != PowerState::kOperationEnabled && p != PowerState::kQuickStopActive) {
    if (IsFaultState(p)) {
      EndTrackerLocked(CommandState::kError,
                       absl::StrCat("drive fault: ",
                                    emcy_text_.empty() ? std::string(ToString(p)) : emcy_text_));
    } else if (disabling_) {
      EndTrackerLocked(CommandState::kAborted, "aborted by Disable");
    } else {
      EndTrackerLocked(CommandState::kError,
                       absl::StrCat("axis left operation enabled (", ToString(p), ")"));
    }
    return;
  }
  if (pending_ && EvaluatePendingLocked(now)) return;
  if (!tracker_) return;
  if (!tracker_->counted) {
    if (now < tracker_->edge_sent + cycle_) {
      // Produced before the edge was applied, or after it when the node's cycle began just
      // after the RPDO arrived. Only the edge's forced-0 cycle (I92 = 0, I91 = 0) is kept from
      // it: when the status at the edge showed Done, no later frame of the previous command
      // can show I92 = 0, so it is this edge's; dropping it left the command ACTIVE for ever
      // (CT-70, Halt at standstill: the forced-0 frame came 1.5 ms after the edge).
      if (!s.done() && !s.error()) tracker_->progress.reset_seen = true;
      return;
    }
    tracker_->counted = true;
  }
  if (tracker_->moved) {
    // Decision 1485: the axis moving away after the edge is this command running, even when
    // its I92 = 0 cycle and the I89/I83 frames were lost; no re-edge may repeat it.
    tracker_->progress.reset_seen = true;
    tracker_->progress.active_seen = true;
  }
  const CommandState state = Evaluate(tracker_->progress, s);
  if (state == CommandState::kError) {
    EndTrackerLocked(CommandState::kError,
                     absl::StrCat(CommandName(tracker_->progress.command),
                                  " denied or cancelled by the motion core: I90 ", s.cause, ": ",
                                  CauseText(s.cause)));
  } else if (state == CommandState::kDone) {
    if (!tracker_->done_withheld) {
      tracker_->done_frames = 1;
      tracker_->done_since = now;
    }
    // The node repeats its status every kStatusRefresh (TPDO1 event timer, decision 1175): Done
    // in kDoneRepeats frames in a row over two periods is the node's present state even if
    // TPDO2 never shows the expected target (a relative base the gateway saw late, I22 or C40
    // written since the configuration); a duplicated or held frame is at most two.
    // Only once the axis has moved (decision 1485): a node that never took the edge shows the
    // previous Done for ever.
    const bool repeated = tracker_->moved && tracker_->done_withheld &&
                          tracker_->done_frames >= kDoneRepeats &&
                          now - tracker_->done_since >= 2 * kStatusRefresh;
    if (!repeated && !ArrivedLocked(*tracker_)) {
      // Decision 1484: I92 alone does not say which command it belongs to; a duplicated or
      // reordered TPDO1 from before the edge carries the previous command's Done. DONE waits
      // for TPDO2 (event timer 100 ms, decision 1175) to show the axis where the node's own
      // Done rule puts it (I180 = actual in I22, I85 profile done; stober-motion.md §2.3 L390).
      if (!tracker_->done_withheld) ++counters_.done_withheld;
      tracker_->done_withheld = true;
      // BUSY until the command shows itself running: if the edge was lost, the re-edge and
      // the "did not take the Execute edge" error of decision 1207 still apply.
      if (tracker_->progress.active_seen || tracker_->moved) {
        UpdateCommand(tracker_->id, CommandState::kActive);
      }
      return;
    }
    demand_reached_ = demand_target_.has_value();
    EndTrackerLocked(CommandState::kDone, "");
  } else if (state == CommandState::kActive) {
    UpdateCommand(tracker_->id, CommandState::kActive);
  }
}

bool StoberDrive::ArrivedLocked(const Tracker& t) const {
  if (!t.target || endless_) return true;
  // The Done itself must come from a TPDO1 received after the edge: a status from before it,
  // re-evaluated at a TPDO2 (every TPDO1 since lost), is the previous command's (decision 1485).
  if (status_at_ < t.edge_sent + cycle_) return false;
  // A TPDO2 produced before the edge was applied says where the axis stood, not where this
  // command took it: it witnesses only a positioning that had nothing to do (already at the
  // target to one increment, at rest), else a move shorter than I22 could pass. One increment
  // of slack for the integer wire values.
  const bool after_edge = actual_at_ >= t.edge_sent + cycle_;
  const double window = after_edge ? position_window_ + kIncrement : kIncrement;
  return std::abs(actual_.position - *t.target) <= window &&
         std::abs(actual_.velocity) <= velocity_window_ + kIncrement;
}

absl::Status StoberDrive::RequireOnlineLocked(const std::string& what) const {
  if (OnlineLocked()) return absl::OkStatus();
  return absl::UnavailableError(
      absl::StrCat(Prefix(what), "drive is OFFLINE (", offline_reason_, ")"));
}

absl::Status StoberDrive::RequireEnabledLocked(const std::string& what) const {
  DGW_RETURN_IF_ERROR(RequireOnlineLocked(what));
  const PowerState p = DecodePowerState(status_->status_word);
  if (p != PowerState::kOperationEnabled) {
    return absl::FailedPreconditionError(
        absl::StrCat(Prefix(what), "needs CiA 402 operation enabled, the drive is ", ToString(p),
                     "; Enable first"));
  }
  if (status_->plc_state == kPlcErrorStop) {
    return absl::FailedPreconditionError(
        absl::StrCat(Prefix(what), "motion core in I89 7: Error stop (I90 ", status_->cause, ": ",
                     CauseText(status_->cause), "); AcknowledgeFault first"));
  }
  return absl::OkStatus();
}

template <typename Pred>
bool StoberDrive::WaitLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline, Pred pred) {
  while (!pred()) {
    const TimePoint now = clock_.Now();
    if (now >= deadline || stop_) return pred();
    cv_.wait_for(lock, std::min<Duration>(deadline - now, 5ms));
  }
  return true;
}

absl::Status StoberDrive::SendRpdoLocked(uint16_t number) {
  const PdoLayout* layout = FindDefaultPdo(co::PdoKind::kRpdo, number);
  if (layout == nullptr || !master_) return absl::InternalError("no RPDO");
  std::vector<double> values;
  const RpdoImage& i = image_;
  switch (number) {
    case 1:
      values = {double(Cw(i)), double(i.command), i.position, i.execute ? 1.0 : 0.0};
      break;
    case 2:
      values = {i.velocity, i.acceleration};
      break;
    case 3:
      values = {i.deceleration, i.jerk};
      break;
    case 4:
      values = {i.override_percent, double(i.direction), i.brake_at_end ? 1.0 : 0.0,
                double(i.motion_id)};
      break;
    default:
      return absl::InternalError("no RPDO");
  }
  auto payload = PackLayout(*layout, values);
  if (!payload.ok()) return payload.status();
  ++counters_.rpdos;
  return master_->SendRpdo(node_, number, *payload);
}

// ---------------------------------------------------------------- power state machine

template <typename Pred>
absl::Status StoberDrive::ControlStepLocked(std::unique_lock<std::mutex>& lock,
                                            uint16_t control_word, TimePoint deadline,
                                            const std::string& what, Pred pred) {
  image_.control_word = control_word;
  image_.execute = (control_word & control::kExecute) != 0;
  DGW_RETURN_IF_ERROR(SendRpdoLocked(1));
  const bool ok = WaitLocked(lock, deadline, [&] {
    return !OnlineLocked() || pred(DecodePowerState(status_->status_word), *status_);
  });
  DGW_RETURN_IF_ERROR(RequireOnlineLocked(what));
  if (!ok) {
    return absl::DeadlineExceededError(absl::StrCat(
        Prefix(what), "control word 0x", absl::Hex(control_word), " not answered within ",
        config().timeouts.request.count(), " ms (timeouts.request); drive is ",
        ToString(DecodePowerState(status_->status_word))));
  }
  return absl::OkStatus();
}

absl::StatusOr<CommandInfo> StoberDrive::RunControlCommand(
    const char* name, const std::function<absl::Status()>& precondition,
    const std::function<absl::Status(std::unique_lock<std::mutex>&)>& step) {
  DGW_RETURN_IF_ERROR(RequireActive(name));
  std::lock_guard op(op_mu_);
  std::unique_lock lock(mu_);
  DGW_RETURN_IF_ERROR(RequireOnlineLocked(name));
  // A refused precondition records no command (it never started).
  if (precondition) DGW_RETURN_IF_ERROR(precondition());
  const CommandInfo info = StartCommand(name, false);
  if (absl::Status s = step(lock); !s.ok()) {
    UpdateCommand(info.id, CommandState::kError, std::string(s.message()));
    return s;
  }
  UpdateCommand(info.id, CommandState::kDone);
  PublishLocked();
  return *GetCommand(info.id);
}

absl::StatusOr<CommandInfo> StoberDrive::Enable() {
  auto not_in_fault = [&]() -> absl::Status {
    const DriveStatus now = BuildStatusLocked();
    if (now.state == DriveState::kFault) {
      return absl::FailedPreconditionError(absl::StrCat(
          Prefix("Enable"), "drive is in FAULT (", now.fault.text, "); AcknowledgeFault first"));
    }
    return absl::OkStatus();
  };
  return RunControlCommand("Enable", not_in_fault, [&](std::unique_lock<std::mutex>& lock) {
    const TimePoint deadline = Deadline();
    for (int i = 0; i < 4; ++i) {
      const PowerState p = DecodePowerState(status_->status_word);
      if (p == PowerState::kOperationEnabled) break;
      const uint16_t cw = NextEnableStep(p);
      absl::Status s = ControlStepLocked(lock, cw, deadline, "Enable",
                                         [p](PowerState q, const MotionStatus&) { return q != p; });
      if (s.ok() && IsFaultState(DecodePowerState(status_->status_word))) {
        s = absl::FailedPreconditionError(Prefix("Enable") + "drive went to FAULT");
      }
      if (!s.ok()) return s;
    }
    return absl::OkStatus();
  });
}

absl::StatusOr<CommandInfo> StoberDrive::Disable() {
  return RunControlCommand("Disable", nullptr, [&](std::unique_lock<std::mutex>& lock) {
    // decision 1195: disable voltage (→ switch on disabled); the axis is held by the drive's own
    // enable-off reaction (sim decision 1146).
    disabling_ = true;
    absl::Status s = ControlStepLocked(lock, control::kDisableVoltage, Deadline(), "Disable",
                                       [](PowerState q, const MotionStatus&) {
                                         return q != PowerState::kOperationEnabled &&
                                                q != PowerState::kQuickStopActive;
                                       });
    EndTrackerLocked(CommandState::kAborted, "aborted by Disable");
    disabling_ = false;
    return s;
  });
}

absl::StatusOr<CommandInfo> StoberDrive::AcknowledgeFault() {
  return RunControlCommand("AcknowledgeFault", nullptr, [&](std::unique_lock<std::mutex>& lock) {
    const PowerState p = DecodePowerState(status_->status_word);
    const bool cia_fault = IsFaultState(p);
    const bool error_stop = status_->plc_state == kPlcErrorStop || status_->error();
    absl::Status s;
    if (cia_fault || error_stop) {
      // CiA 402 fault reset / motion-core reset: rising edge of control word bit 7 (decision 1147);
      // from Fault the power stage bits are 0 (CiA 402 transition 15). The edge is taken only in
      // Fault (not during the fault reaction) and, for the motion core, at standstill (G-04): wait
      // for that, and repeat an edge that was not taken (decision 1195).
      const TimePoint deadline = Deadline();
      auto cleared = [](PowerState q, const MotionStatus& m) {
        return !IsFaultState(q) && m.plc_state != kPlcErrorStop && !m.error();
      };
      auto resettable = [&] {
        if (!OnlineLocked()) return true;
        const PowerState q = DecodePowerState(status_->status_word);
        if (cia_fault) return q != PowerState::kFaultReactionActive;
        return (status_->flags & status_bit::kStandstill) != 0;
      };
      while (true) {
        WaitLocked(lock, deadline, resettable);
        if (s = RequireOnlineLocked("AcknowledgeFault"); !s.ok()) break;
        if (cleared(DecodePowerState(status_->status_word), *status_)) break;
        const uint16_t base = cia_fault
                                  ? control::kDisableVoltage
                                  : static_cast<uint16_t>(image_.control_word & ~control::kExecute);
        const TimePoint slice = std::min(deadline, clock_.Now() + kResetRetry);
        s = ControlStepLocked(lock, base | control::kFaultReset, slice, "AcknowledgeFault",
                              cleared);
        // Bit 7 low again so the next reset is an edge.
        image_.control_word = base;
        image_.execute = false;
        (void)SendRpdoLocked(1);
        execute_low_at_ = clock_.Now();
        if (s.ok() || !absl::IsDeadlineExceeded(s) || clock_.Now() >= deadline) break;
        WaitLocked(lock, execute_low_at_ + std::max<Duration>(2 * cycle_, kMinExecuteLow),
                   [] { return false; });
      }
    }
    if (!s.ok()) return s;
    emcy_code_ = 0;
    emcy_text_.clear();
    return absl::OkStatus();
  });
}

// ---------------------------------------------------------------- motion

absl::StatusOr<StoberDrive::McStart> StoberDrive::PlanMove(const MotionCommand& cmd) const {
  const AxisConfig& ax = config().axis;
  const std::string kind = KindName(cmd);
  auto bad = [&](const std::string& field, const std::string& why) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix(kind), field, ": ", why));
  };
  auto velocity = [&](double v) -> absl::StatusOr<double> {
    v = std::fabs(v);
    if (!std::isfinite(v) || v <= 0) return bad("velocity_mm_s", "must be > 0");
    if (v > ax.max_velocity_mm_s) {
      return bad("velocity_mm_s",
                 absl::StrCat(v, " exceeds axis.max_velocity_mm_s ", ax.max_velocity_mm_s));
    }
    return v;
  };
  // 0 = the axis maximum (decision 1198).
  auto ramp = [&](const char* field, double a) -> absl::StatusOr<double> {
    if (!std::isfinite(a) || a < 0) return bad(field, "must be >= 0");
    if (a == 0) return ax.max_acceleration_mm_s2;
    if (a > ax.max_acceleration_mm_s2) {
      return bad(field, absl::StrCat(a, " exceeds axis.max_acceleration_mm_s2 ",
                                     ax.max_acceleration_mm_s2));
    }
    return a;
  };
  auto in_range = [&](const char* field, double target) -> absl::Status {
    if (endless_) return absl::OkStatus();
    if (!std::isfinite(target) || target < ax.min_mm || target > ax.max_mm) {
      return bad(field, absl::StrCat(target, " mm outside axis.min_mm..max_mm ", ax.min_mm, "..",
                                     ax.max_mm));
    }
    return absl::OkStatus();
  };
  McStart s;
  s.kind = kind;
  if (const auto* m = std::get_if<MoveAbsolute>(&cmd)) {
    DGW_RETURN_IF_ERROR(in_range("position_mm", m->position_mm));
    s.command = mc::kMoveAbsolute;
    s.position = m->position_mm;
    DGW_ASSIGN_OR_RETURN(s.velocity, velocity(m->velocity_mm_s));
    DGW_ASSIGN_OR_RETURN(s.acceleration, ramp("acceleration_mm_s2", m->acceleration_mm_s2));
    DGW_ASSIGN_OR_RETURN(s.deceleration, ramp("deceleration_mm_s2", m->deceleration_mm_s2));
  } else if (const auto* r = std::get_if<MoveRelative>(&cmd)) {
    if (!std::isfinite(r->distance_mm)) return bad("distance_mm", "must be finite");
    DGW_RETURN_IF_ERROR(
        in_range("distance_mm (start + distance)", actual_.position + r->distance_mm));
    s.command = mc::kMoveRelative;
    s.position = r->distance_mm;
    DGW_ASSIGN_OR_RETURN(s.velocity, velocity(r->velocity_mm_s));
    DGW_ASSIGN_OR_RETURN(s.acceleration, ramp("acceleration_mm_s2", r->acceleration_mm_s2));
    DGW_ASSIGN_OR_RETURN(s.deceleration, ramp("deceleration_mm_s2", r->deceleration_mm_s2));
  } else if (const auto* v = std::get_if<MoveVelocity>(&cmd)) {
    DGW_ASSIGN_OR_RETURN(s.velocity, velocity(v->velocity_mm_s));
    DGW_ASSIGN_OR_RETURN(s.acceleration, ramp("acceleration_mm_s2", v->acceleration_mm_s2));
    DGW_ASSIGN_OR_RETURN(s.deceleration, ramp("deceleration_mm_s2", v->deceleration_mm_s2));
    if (endless_) {
      s.command = mc::kMoveVelocity;  // signed I404 (§3.5), runs until the next command
      s.velocity = v->velocity_mm_s;
    } else {
      // decision 005 / 1202: a linear axis moves towards its configured end and stops there.
      s.command = mc::kMoveAbsolute;
      s.position = v->velocity_mm_s > 0 ? ax.max_mm : ax.min_mm;
    }
  } else {
    const auto& stop = std::get<StopMotion>(cmd);
    s.command = mc::kStop;
    DGW_ASSIGN_OR_RETURN(s.deceleration, ramp("deceleration_mm_s2", stop.deceleration_mm_s2));
    s.acceleration = image_.acceleration;
    s.velocity = image_.velocity;
    s.position = image_.position;
  }
  s.jerk = kJerkPerAcceleration * std::max(s.acceleration, s.deceleration);
  return s;
}

absl::StatusOr<CommandInfo> StoberDrive::Move(const MotionCommand& cmd) {
  const std::string kind = KindName(cmd);
  DGW_RETURN_IF_ERROR(RequireActive(kind.c_str()));
  std::lock_guard op(op_mu_);
  absl::StatusOr<McStart> plan = absl::UnknownError("");
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireEnabledLocked(kind));
    plan = PlanMove(cmd);
  }
  if (!plan.ok()) return plan.status();
  return StartMc(*plan);
}

absl::StatusOr<CommandInfo> StoberDrive::Home() {
  DGW_RETURN_IF_ERROR(RequireActive("Home"));
  std::lock_guard op(op_mu_);
  McStart s;
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireEnabledLocked("Home"));
    s.kind = "Home";
    s.command = mc::kHome;
    s.position = image_.position;
    s.velocity = image_.velocity;
    s.acceleration = image_.acceleration;
    s.deceleration = image_.deceleration;
    s.jerk = image_.jerk;
    s.homing = true;
  }
  return StartMc(s);
}

// decision 1197: set values (RPDO2-4 only when changed) → RPDO1 with the edge → wait for a
// status TPDO produced after it (or 10 ms) → Execute low → wait up to timeouts.accept for the
// handle to leave BUSY. Execute stays low ≥ max(2 × A150, 3 ms) before the next edge (1179).
absl::StatusOr<CommandInfo> StoberDrive::StartMc(const McStart& start) {
  DGW_RETURN_IF_ERROR(WriteBlockInputs(start.command_mode, start.end_velocity));
  std::unique_lock lock(mu_);
  DGW_RETURN_IF_ERROR(RequireEnabledLocked(start.kind));
  if (image_.execute) {
    image_.execute = false;
    DGW_RETURN_IF_ERROR(SendRpdoLocked(1));
    execute_low_at_ = clock_.Now();
  }
  const TimePoint low_until = execute_low_at_ + std::max<Duration>(2 * cycle_, kMinExecuteLow);
  WaitLocked(lock, low_until, [] { return false; });
  DGW_RETURN_IF_ERROR(RequireEnabledLocked(start.kind));
  auto check = [&](ParamId id, double v) -> absl::Status {
    auto b = FindBinding(id);
    if (!b.ok()) return b.status();
    auto raw = ToRaw(*b, v);
    if (!raw.ok()) return Annotate(raw.status(), Prefix(start.kind));
    return absl::OkStatus();
  };
  DGW_RETURN_IF_ERROR(check(P("I403"), start.position));
  DGW_RETURN_IF_ERROR(check(P("I404"), start.velocity));
  DGW_RETURN_IF_ERROR(check(P("I405"), start.acceleration));
  DGW_RETURN_IF_ERROR(check(P("I406"), start.deceleration));
  DGW_RETURN_IF_ERROR(check(P("I407"), start.jerk));
  if (start.velocity != image_.velocity || start.acceleration != image_.acceleration) {
    image_.velocity = start.velocity;
    image_.acceleration = start.acceleration;
    DGW_RETURN_IF_ERROR(SendRpdoLocked(2));
  }
  if (start.deceleration != image_.deceleration || start.jerk != image_.jerk) {
    image_.deceleration = start.deceleration;
    image_.jerk = start.jerk;
    DGW_RETURN_IF_ERROR(SendRpdoLocked(3));
  }
  if (stream_ == nullptr && ((start.direction && *start.direction != image_.direction) ||
                             (start.motion_id && *start.motion_id != image_.motion_id))) {
    if (start.direction) image_.direction = *start.direction;
    if (start.motion_id) image_.motion_id = *start.motion_id;
    DGW_RETURN_IF_ERROR(SendRpdoLocked(4));
  }
  const bool clean = status_ && !status_->done() && !status_->error();
  // decision 1210: I409 = 1 behind an open handle keeps that handle running and queues this
  // one; any other start supersedes both (§2.15 CommandAborted).
  // Behind an MC_Stop the node denies every start (L1059, sim decision 1160): that is an
  // aborting start for the handles, as without I409.
  const bool buffered = start.command_mode == 1 && Bufferable(start.command) &&
                        tracker_.has_value() && tracker_->progress.command != mc::kStop;
  if (pending_) {
    UpdateCommand(pending_->id, CommandState::kAborted,
                  absl::StrCat(buffered ? "replaced by " : "superseded by ", start.kind,
                               buffered ? " (one buffered block, decision 1162)" : ""));
    pending_.reset();
  }
  if (!buffered && tracker_) {
    UpdateCommand(tracker_->id, CommandState::kAborted, absl::StrCat("superseded by ", start.kind));
  }
  const CommandInfo info = StartCommand(start.kind, !buffered);
  Tracker t;
  t.id = info.id;
  t.kind = start.kind;
  t.progress.command = start.command;
  t.progress.reset_seen = clean;
  // Decision 1484: where Done must find the axis. MoveRelative counts from the actual position
  // (I96 = I403 + I80, stober-motion.md G-27), known here only at standstill; MoveAdditive's
  // base (the previous set position) is not on the bus.
  const bool standstill = status_ && status_->plc_state == kPlcStandstill &&
                          (status_->flags & status_bit::kStandstill) != 0;
  if (standstill) t.start_position = actual_.position;
  if (start.command == mc::kMoveAbsolute) {
    t.target = start.position;
  } else if (start.command == mc::kMoveRelative && standstill) {
    t.target = actual_.position + start.position;
  }
  if (start.homing) t.deadline = clock_.Now() + config().timeouts.homing;
  if (buffered) {
    pending_ = t;
  } else {
    tracker_ = t;
  }
  image_.command = start.command;
  image_.position = start.position;
  image_.execute = true;
  // The profile's set position is not on the bus; after Done of a MoveAbsolute it is the target
  // (§3.2 Done: I85 profile done at the set position).
  demand_reached_ = false;
  demand_target_.reset();
  if (start.command == mc::kMoveAbsolute) demand_target_ = start.position;
  // This command's tracker: pending_ while buffered, tracker_ otherwise (or after its take-over).
  auto cur = [&]() -> Tracker* {
    if (pending_ && pending_->id == info.id) return &*pending_;
    if (tracker_ && tracker_->id == info.id) return &*tracker_;
    return nullptr;
  };
  auto mine = [&] { return cur() != nullptr; };
  // "Edge not taken yet": BUSY, and for a buffered command not yet shown queued (I83 = 2) —
  // BUSY is its normal state until the take-over (decision 1210).
  auto busy = [&] {
    const Tracker* c = cur();
    return GetCommand(info.id)->state == CommandState::kBusy && !(c && c->buffered_seen);
  };
  // decision 1207: the node shows the start (I92/I91 = 0 cycle, I89, I83) within
  // timeouts.accept + a few A150 after the edge, or the edge was not taken.
  const Duration window = config().timeouts.accept + kAcceptCycles * cycle_;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (attempt > 0) {
      // One re-edge after the usual low time (decision 1197); the handle stays the same.
      WaitLocked(lock, execute_low_at_ + std::max<Duration>(2 * cycle_, kMinExecuteLow),
                 [&] { return !mine() || !busy(); });
      if (!mine() || !busy() || !OnlineLocked()) break;
      ++counters_.execute_retries;
      cur()->counted = false;
      image_.execute = true;
    }
    cur()->edge_sent = clock_.Now();
    if (absl::Status s = SendRpdoLocked(1); !s.ok()) {
      EndTrackerLocked(CommandState::kError, std::string(s.message()));
      return s;
    }
    const TimePoint edge = cur()->edge_sent;
    WaitLocked(lock, edge + std::max<Duration>(3 * cycle_, kEdgeFallback),
               [&] { return !mine() || cur()->counted; });
    if (mine() && !cur()->counted && OnlineLocked()) {
      // No status change after the edge: the node has cycled since, evaluate what it shows.
      cur()->counted = true;
      EvaluateTrackerLocked(clock_.Now());
    }
    image_.execute = false;
    (void)SendRpdoLocked(1);
    execute_low_at_ = clock_.Now();
    WaitLocked(lock, edge + window, [&] { return !busy(); });
    if (!mine() || !busy() || !OnlineLocked()) break;
  }
  if (mine() && busy() && OnlineLocked()) {
    const std::string message =
        absl::StrCat("drive did not take the Execute edge of ", start.kind, " within ",
                     std::chrono::duration_cast<std::chrono::milliseconds>(window).count(),
                     " ms (stober-motion.md §2.1)");
    if (pending_ && pending_->id == info.id) {
      pending_.reset();  // the running block goes on; only this edge failed
      UpdateCommand(info.id, CommandState::kError, message);
    } else {
      EndTrackerLocked(CommandState::kError, message);
    }
  }
  PublishLocked();
  return *GetCommand(info.id);
}

// decision 1209: I409 and I429 are not in the RPDO layout (all four RPDOs carry 64 bits,
// decision 1175); they change rarely, so an SDO download before the edge, only when the node
// holds another value. The SDO is confirmed, so the node has the value before the RPDO1 edge
// (§2.1: set values before or with the edge).
absl::Status StoberDrive::WriteBlockInputs(uint8_t command_mode, double end_velocity) {
  uint8_t mode = 0;
  double velocity = 0;
  {
    std::lock_guard lock(mu_);
    mode = command_mode_;
    velocity = end_velocity_;
  }
  if (command_mode != mode) {
    DGW_RETURN_IF_ERROR(WriteBound("I409", command_mode));
    std::lock_guard lock(mu_);
    command_mode_ = command_mode;
  }
  if (end_velocity != velocity) {
    DGW_RETURN_IF_ERROR(WriteBound("I429", end_velocity));
    std::lock_guard lock(mu_);
    end_velocity_ = end_velocity;
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------- parameters, native

absl::StatusOr<int64_t> StoberDrive::ReadParameter(const ParameterRef& ref) {
  DGW_RETURN_IF_ERROR(RequireActive("ReadParameter"));
  if (ref.rom) {
    return absl::InvalidArgumentError(
        Prefix("ReadParameter") +
        "rom: stored values (1010h store) are not supported (decision 1201)");
  }
  if (ref.id > 0xFFFFFF) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix("ReadParameter"), "id 0x",
                                                   absl::Hex(ref.id),
                                                   " is not CANopen index << 8 | subindex"));
  }
  CanOpenSdoRequest req;
  req.index = static_cast<uint16_t>(ref.id >> 8);
  req.sub_index = static_cast<uint8_t>(ref.id & 0xFF);
  DGW_ASSIGN_OR_RETURN(NativeReply reply, Sdo(req));
  if (auto b = FindBinding(CanOpenAddress{req.index, req.sub_index}); b.ok()) {
    DGW_ASSIGN_OR_RETURN(double v, Decode(*b, reply.data));
    return static_cast<int64_t>(std::llround(v));
  }
  int64_t raw = 0;
  for (size_t i = 0; i < reply.data.size() && i < 8; ++i) {
    raw |= static_cast<int64_t>(reply.data[i]) << (8 * i);
  }
  return raw;
}

absl::Status StoberDrive::WriteParameter(const ParameterRef& ref, int64_t value) {
  DGW_RETURN_IF_ERROR(RequireActive("WriteParameter"));
  if (ref.rom) {
    return absl::InvalidArgumentError(
        Prefix("WriteParameter") +
        "rom: stored values (1010h store) are not supported (decision 1201)");
  }
  if (ref.id > 0xFFFFFF) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix("WriteParameter"), "id 0x",
                                                   absl::Hex(ref.id),
                                                   " is not CANopen index << 8 | subindex"));
  }
  CanOpenSdoRequest req;
  req.index = static_cast<uint16_t>(ref.id >> 8);
  req.sub_index = static_cast<uint8_t>(ref.id & 0xFF);
  req.write = true;
  if (auto b = FindBinding(CanOpenAddress{req.index, req.sub_index}); b.ok()) {
    auto bytes = Encode(*b, static_cast<double>(value));
    if (!bytes.ok()) return Annotate(bytes.status(), Prefix("WriteParameter"));
    req.data = *bytes;
  } else {
    // Unbound object: the smallest of 1/2/4 bytes that holds the value (decision 1201).
    size_t n = 4;
    if (value >= -128 && value <= 255) {
      n = 1;
    } else if (value >= -32768 && value <= 65535) {
      n = 2;
    }
    for (size_t i = 0; i < n; ++i) req.data.push_back(static_cast<uint8_t>(value >> (8 * i)));
  }
  return Sdo(req).status();
}

absl::StatusOr<NativeReply> StoberDrive::Sdo(const CanOpenSdoRequest& req) {
  std::shared_ptr<co::CanopenMaster> m;
  {
    std::lock_guard lock(mu_);
    m = master_;
    if (!m || !link_ok_) return RequireOnlineLocked("SDO");
  }
  const TimePoint deadline = Deadline();
  NativeReply reply;
  if (req.write) {
    if (req.data.empty()) {
      return absl::InvalidArgumentError(Prefix("SDO download") + "data: empty");
    }
    DGW_RETURN_IF_ERROR(m->Download(node_, req.index, req.sub_index, req.data, deadline));
  } else {
    DGW_ASSIGN_OR_RETURN(reply.data, m->Upload(node_, req.index, req.sub_index, deadline));
  }
  return reply;
}

absl::Status StoberDrive::WriteBound(const char* param, double value) {
  auto a = ToCanOpen(P(param));
  if (!a.ok()) return a.status();
  auto bytes = Encode(P(param), value);
  if (!bytes.ok()) return Annotate(bytes.status(), Prefix("write"));
  CanOpenSdoRequest w;
  w.index = a->index;
  w.sub_index = a->sub_index;
  w.write = true;
  w.data = *bytes;
  return Sdo(w).status();
}

absl::StatusOr<NativeReply> StoberDrive::SendNative(const NativeRequest& req) {
  DGW_RETURN_IF_ERROR(RequireActive("SendNative"));
  if (const auto* sdo = std::get_if<CanOpenSdoRequest>(&req)) return Sdo(*sdo);
  const auto* mcr = std::get_if<StoberMcRequest>(&req);
  if (mcr == nullptr) {
    return absl::InvalidArgumentError(Prefix("SendNative") +
                                      "family 'stober' takes StoberMcRequest or CanOpenSdoRequest");
  }
  if (mcr->command > mc::kHalt) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix("SendNative"),
                                                   "command: ", std::to_string(mcr->command),
                                                   " outside I401 0..11 (§1.1)"));
  }
  if (mcr->direction < 0 || mcr->direction > 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        Prefix("SendNative"), "direction: ", mcr->direction, " outside I411 0..3 (§3.2)"));
  }
  // decisions 1161, 1162, 1209: refused here, before any frame (CT-71).
  if (mcr->command_mode > 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix("SendNative"), "command_mode: ", mcr->command_mode,
                     " outside I409 0..1 (0 aborting, 1 buffered; §2.5)"));
  }
  if (mcr->command_mode == 1 && !Bufferable(mcr->command)) {
    return absl::InvalidArgumentError(absl::StrCat(
        Prefix("SendNative"), "command_mode: 1 (buffered) applies to commands 1-5, 8, 11, not ",
        CommandName(mcr->command), " (§2.7 L292)"));
  }
  if (mcr->end_velocity_mm_s != 0) {
    const bool positioning = mcr->command >= mc::kMoveAbsolute && mcr->command <= mc::kMoveAdditive;
    if (!positioning) {
      return absl::InvalidArgumentError(
          absl::StrCat(Prefix("SendNative"),
                       "end_velocity_mm_s: applies to MC_MoveAbsolute/Relative/Additive "
                       "only (I429, §3.2), not ",
                       CommandName(mcr->command)));
    }
    if (!std::isfinite(mcr->end_velocity_mm_s) || mcr->end_velocity_mm_s < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(Prefix("SendNative"), "end_velocity_mm_s: ", mcr->end_velocity_mm_s,
                       " must be >= 0 (I429 is a speed; the sign is the travel direction)"));
    }
    auto binding = FindBinding(P("I429"));
    if (!binding.ok()) return binding.status();
    if (auto raw = ToRaw(*binding, mcr->end_velocity_mm_s); !raw.ok()) {
      return Annotate(raw.status(), Prefix("SendNative") + "end_velocity_mm_s: ");
    }
  }
  std::lock_guard op(op_mu_);
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireEnabledLocked(CommandName(mcr->command)));
  }
  if (mcr->command == mc::kTorqueControl) {
    DGW_RETURN_IF_ERROR(WriteBound("I428", mcr->torque_percent));  // §3.10 set torque
  }
  McStart s;
  s.kind = CommandName(mcr->command) + 3;  // handle kind without "MC_", like "MoveAbsolute"
  s.command = mcr->command;
  s.position = mcr->position_mm;
  s.velocity = mcr->velocity_mm_s;
  s.acceleration = mcr->acceleration_mm_s2;
  s.deceleration = mcr->deceleration_mm_s2;
  s.jerk = mcr->jerk_mm_s3;
  s.direction = mcr->direction;
  s.motion_id = mcr->motion_id;
  s.homing = mcr->command == mc::kHome;
  s.command_mode = mcr->command_mode;
  s.end_velocity = mcr->end_velocity_mm_s;
  DGW_ASSIGN_OR_RETURN(CommandInfo info, StartMc(s));
  if (mcr->command == mc::kDoNothing) {
    // MC_DoNothing produces no status information (§2.7 L135): done once sent.
    std::lock_guard lock(mu_);
    EndTrackerLocked(CommandState::kDone, "");
    info = *GetCommand(info.id);
  }
  NativeReply reply;
  reply.command_id = info.id;
  return reply;
}

}  // namespace drivegw::stober
