// MC_CyclicPosition (10) / MC_CyclicSpeed (7) streams of StoberDrive (stober-motion.md §3.8,
// §3.11, §2.7 L1415): RPDO4 is remapped to I421 cyclic position + I426 cyclic speed for the
// stream's lifetime and one RPDO4 leaves per SYNC from the master's "SYNC sent" listener
// (decision 1205). Cycles without a fresh set point send nothing: the drive extrapolates for
// I423 (L1344) and the stream counts them as missing.
#include <deque>

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "adapters/stober/drive.h"

namespace drivegw::stober {
namespace {

namespace co = drivegw::canopen;
// At most this many set points wait; older ones are dropped as late (the client fell behind
// the bus and would otherwise be replayed seconds later).
constexpr size_t kMaxQueued = 64;

}  // namespace

PdoLayout CyclicLayout() {
  PdoLayout layout = *FindDefaultPdo(co::PdoKind::kRpdo, 4);
  layout.fields.clear();
  for (const char* id : {"I421", "I426"}) {
    const ObjectBinding b = *FindBinding(P(id));
    PdoField f;
    f.param = b.param;
    f.entry = co::PdoMappingEntry{b.address.index, b.address.sub_index, WireTypeBits(b.type)};
    f.type = b.type;
    layout.fields.push_back(f);
  }
  return layout;
}

class StoberDrive::Stream final : public Drive::CyclicStream {
 public:
  Stream(StoberDrive* drive, std::shared_ptr<co::CanopenMaster> master, CommandInfo info,
         CyclicMode mode, Duration cycle)
      : drive_(drive), master_(std::move(master)), info_(std::move(info)), mode_(mode) {
    stats_.cycle = std::chrono::duration_cast<std::chrono::microseconds>(cycle);
  }
  ~Stream() override { (void)Close(); }

  const CommandInfo& command() const override { return info_; }

  absl::Status Push(const CyclicSetpoint& setpoint) override {
    std::lock_guard lock(mu_);
    if (closed_) {
      return absl::FailedPreconditionError(
          absl::StrCat("cyclic stream of command ", info_.id, " is closed"));
    }
    ++stats_.received;
    queue_.push_back(setpoint);
    while (queue_.size() > kMaxQueued) {
      queue_.pop_front();
      ++stats_.late;
    }
    return absl::OkStatus();
  }

  CyclicStats stats() const override {
    std::lock_guard lock(mu_);
    return stats_;
  }

  absl::StatusOr<CommandInfo> Close() override {
    {
      std::lock_guard lock(mu_);
      if (closed_) return final_;
      closed_ = true;
    }
    if (listener_) master_->RemoveSyncListener(*listener_);
    listener_.reset();
    absl::StatusOr<CommandInfo> r =
        drive_ != nullptr ? drive_->CloseStream(this) : absl::StatusOr<CommandInfo>(info_);
    std::lock_guard lock(mu_);
    final_ = r;
    return r;
  }

  void Listen() {
    listener_ = master_->AddSyncListener([this](const co::SyncEvent&) { OnSync(); });
  }
  // The drive is going away (Deactivate): stop sending, never call back.
  void Detach() {
    if (listener_) master_->RemoveSyncListener(*listener_);
    listener_.reset();
    std::lock_guard lock(mu_);
    drive_ = nullptr;
    closed_ = true;
    final_ = absl::UnavailableError("drive deactivated");
  }

 private:
  // SYNC thread: one RPDO4 with the oldest waiting set point.
  void OnSync() {
    std::lock_guard lock(mu_);
    if (closed_ || drive_ == nullptr) return;
    if (queue_.empty()) {
      ++stats_.missing;
      return;
    }
    const CyclicSetpoint sp = queue_.front();
    queue_.pop_front();
    const double values[2] = {mode_ == CyclicMode::kPosition ? sp.value : 0,
                              mode_ == CyclicMode::kPosition ? sp.velocity_mm_s : sp.value};
    auto payload = PackLayout(drive_->cyclic_layout_, values);
    if (!payload.ok() || !master_->SendRpdo(drive_->node_, 4, *payload).ok()) {
      ++stats_.missing;
      return;
    }
    ++stats_.sent;
  }

  StoberDrive* drive_;
  const std::shared_ptr<co::CanopenMaster> master_;
  const CommandInfo info_;
  const CyclicMode mode_;
  mutable std::mutex mu_;
  std::deque<CyclicSetpoint> queue_;
  CyclicStats stats_;
  bool closed_ = false;
  absl::StatusOr<CommandInfo> final_ = absl::UnknownError("open");
  std::optional<co::SyncListenerId> listener_;
};

absl::Status StoberDrive::MapCyclicRpdo(bool cyclic) {
  std::shared_ptr<co::CanopenMaster> m;
  {
    std::lock_guard lock(mu_);
    m = master_;
  }
  if (!m) return absl::UnavailableError(Prefix("StartCyclic") + "no master");
  const PdoLayout* def = FindDefaultPdo(co::PdoKind::kRpdo, 4);
  const PdoLayout& layout = cyclic ? cyclic_layout_ : *def;
  const co::PdoMapping mapping = layout.Mapping();
  return m->ConfigurePdo(node_, co::PdoKind::kRpdo, 4, RpdoComm(layout), mapping, Deadline());
}

absl::StatusOr<std::unique_ptr<Drive::CyclicStream>> StoberDrive::StartCyclic(CyclicMode mode) {
  return OpenCyclic(mode, mode == CyclicMode::kPosition ? "CyclicPosition" : "CyclicSpeed",
                    nullptr);
}

absl::StatusOr<std::unique_ptr<Drive::CyclicStream>> StoberDrive::OpenCyclic(
    CyclicMode mode, const std::string& kind, const std::function<absl::Status()>& precondition) {
  DGW_RETURN_IF_ERROR(RequireActive(kind.c_str()));
  std::lock_guard op(op_mu_);
  double start_position = 0;
  std::shared_ptr<co::CanopenMaster> m;
  {
    std::lock_guard lock(mu_);
    DGW_RETURN_IF_ERROR(RequireEnabledLocked(kind));
    if (stream_ != nullptr) {
      return absl::FailedPreconditionError(Prefix(kind) + "a cyclic stream is already open");
    }
    if (precondition) DGW_RETURN_IF_ERROR(precondition());
    start_position = actual_.position;
    m = master_;
  }
  // The first set value is taken at the edge (§2.2, L1307): the axis's own position / zero
  // speed, so the start does not jump. A291 = the SYNC period spreads each set value over it.
  DGW_RETURN_IF_ERROR(WriteBound("I421", mode == CyclicMode::kPosition ? start_position : 0));
  DGW_RETURN_IF_ERROR(WriteBound("I426", 0));
  const auto period = config().canopen.sync_period;
  DGW_RETURN_IF_ERROR(WriteBound("A291", static_cast<double>(period.count())));
  DGW_RETURN_IF_ERROR(MapCyclicRpdo(true));
  if (!m->sync_running()) {
    DGW_RETURN_IF_ERROR(m->StartSync(period));
    std::lock_guard lock(mu_);
    sync_started_ = true;
  }
  McStart s;
  s.kind = kind;
  s.command = mode == CyclicMode::kPosition ? mc::kCyclicPosition : mc::kCyclicSpeed;
  {
    std::lock_guard lock(mu_);
    s.position = image_.position;
    s.velocity = image_.velocity;
    s.acceleration = image_.acceleration;
    s.deceleration = image_.deceleration;
    s.jerk = image_.jerk;
  }
  auto info = StartMc(s);
  if (!info.ok()) {
    (void)MapCyclicRpdo(false);
    return info.status();
  }
  auto stream = std::make_unique<Stream>(this, m, *info, mode, period);
  {
    std::lock_guard lock(mu_);
    stream_ = stream.get();
  }
  stream->Listen();
  return std::unique_ptr<Drive::CyclicStream>(std::move(stream));
}

void StoberDrive::DetachStream() {
  Stream* stream = nullptr;
  std::shared_ptr<co::CanopenMaster> m;
  bool stop_sync = false;
  {
    std::lock_guard lock(mu_);
    stream = std::exchange(stream_, nullptr);
    stop_sync = std::exchange(sync_started_, false);
    m = master_;
  }
  if (stream != nullptr) stream->Detach();
  if (stop_sync && m) m->StopSync();
}

// Close: the cyclic handle ends DONE (an open one; a cancelled one keeps its ERROR), the axis
// stops with MC_Stop at the axis's maximum deceleration unless a later motion command took over,
// RPDO4 gets its default mapping back.
absl::StatusOr<CommandInfo> StoberDrive::CloseStream(Stream* stream) {
  const uint64_t id = stream->command().id;
  bool stop_sync = false;
  std::shared_ptr<co::CanopenMaster> m;
  {
    std::lock_guard lock(mu_);
    if (stream_ == stream) stream_ = nullptr;
    if (tracker_ && tracker_->id == id) EndTrackerLocked(CommandState::kDone, "stream closed");
    stop_sync = std::exchange(sync_started_, false);
    m = master_;
  }
  if (stop_sync && m) m->StopSync();
  absl::Status stopped = absl::OkStatus();
  if (lifecycle() == Lifecycle::kActive) {
    std::lock_guard op(op_mu_);
    McStart stop;
    stop.kind = "Stop";
    stop.command = mc::kStop;
    {
      std::lock_guard lock(mu_);
      stop.position = image_.position;
      stop.velocity = image_.velocity;
      stop.acceleration = image_.acceleration;
      stop.deceleration = config().axis.max_acceleration_mm_s2;
      stop.jerk = 10 * stop.deceleration;
      const bool enabled = RequireEnabledLocked("Stop").ok();
      // A later motion command replaced the cyclic one (it superseded the stream's handle): the
      // axis runs that command now, and a Stop would end it (decision 1208).
      const bool still_cyclic =
          image_.command == mc::kCyclicPosition || image_.command == mc::kCyclicSpeed;
      if (!enabled || !still_cyclic) stop.command = mc::kDoNothing;
    }
    if (stop.command == mc::kStop) stopped = StartMc(stop).status();
    if (absl::Status s = MapCyclicRpdo(false); !s.ok() && stopped.ok()) stopped = s;
  }
  auto info = GetCommand(id);
  if (!info) return absl::NotFoundError(Prefix("Close") + "command gone");
  if (!stopped.ok()) return stopped;
  return *info;
}

}  // namespace drivegw::stober
