// CanopenMaster life cycle, the receive thread (frame dispatch by COB-ID, heartbeat supervision,
// bus faults and reopening), observer delivery, NMT. SDO: master_sdo.cpp; SYNC: master_sync.cpp.
#include "adapters/canopen/master.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/core/log.h"
#include "adapters/core/wire_observer.h"

namespace drivegw::canopen {
namespace {

// Longest wait of the receive thread: the channel state (bus-off, down) is looked at least this
// often even on a silent bus (decision 1111).
constexpr Duration kIdleWait = std::chrono::milliseconds(100);

int64_t Ms(Duration d) { return std::chrono::duration_cast<std::chrono::milliseconds>(d).count(); }

// Predefined-set TPDO number of a function code (CiA 301 Table 72), 0 for other functions.
uint16_t TpdoNumber(Function f) {
  switch (f) {
    case Function::kTpdo1:
      return 1;
    case Function::kTpdo2:
      return 2;
    case Function::kTpdo3:
      return 3;
    case Function::kTpdo4:
      return 4;
    default:
      return 0;
  }
}

}  // namespace

const char* NodeEventName(NodeEvent event) {
  switch (event) {
    case NodeEvent::kHeartbeatLost:
      return "heartbeat_lost";
    case NodeEvent::kHeartbeatResumed:
      return "heartbeat_resumed";
    case NodeEvent::kBootUp:
      return "boot_up";
    case NodeEvent::kBusOff:
      return "bus_off";
    case NodeEvent::kLinkLost:
      return "link_lost";
    case NodeEvent::kLinkRestored:
      return "link_restored";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Life cycle.

absl::StatusOr<std::shared_ptr<CanopenMaster>> CanopenMaster::Open(const CanBusConfig& bus,
                                                                   const MasterOptions& options) {
  auto channel = transport::OpenCanChannel(bus);
  if (!channel.ok()) return channel.status();
  return Open(*std::move(channel), options, [bus] { return transport::OpenCanChannel(bus); });
}

absl::StatusOr<std::shared_ptr<CanopenMaster>> CanopenMaster::Open(
    std::unique_ptr<transport::CanChannel> channel, const MasterOptions& options, Reopen reopen) {
  if (channel == nullptr) return absl::InvalidArgumentError("canopen master: channel is null");
  if (options.clock == nullptr) return absl::InvalidArgumentError("canopen master: clock is null");
  if (options.sdo_timeout <= Duration::zero()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "canopen master.sdo_timeout: ", Ms(options.sdo_timeout), " ms must be positive"));
  }
  if (options.bus_retry_min <= Duration::zero() || options.bus_retry_max < options.bus_retry_min) {
    return absl::InvalidArgumentError(absl::StrCat(
        "canopen master.bus_retry_min: ", Ms(options.bus_retry_min),
        " ms must be positive and not above bus_retry_max ", Ms(options.bus_retry_max), " ms"));
  }
  // Private constructor: make_shared cannot reach it.
  std::shared_ptr<CanopenMaster> master(
      new CanopenMaster(std::move(channel), options, std::move(reopen)));
  {
    // The thread starts by taking mu_, so it sees receive_thread_id_ set.
    std::lock_guard lock(master->mu_);
    master->thread_ = std::thread([m = master.get()] { m->Run(); });
    master->receive_thread_id_.store(master->thread_.get_id());
  }
  log::Info(
      "canopen_master_open",
      log::Fields().Add("bus", master->bus_name()).Add("sdo_timeout_ms", Ms(options.sdo_timeout)));
  return master;
}

CanopenMaster::CanopenMaster(std::unique_ptr<transport::CanChannel> channel,
                             const MasterOptions& options, Reopen reopen)
    : options_(options),
      clock_(*options.clock),
      reopen_(std::move(reopen)),
      channel_(std::move(channel)),
      bus_name_(channel_->name()),
      backoff_(options.bus_retry_min) {}

CanopenMaster::~CanopenMaster() { Stop(); }

void CanopenMaster::Stop() {
  std::lock_guard stop_lock(stop_mu_);
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
    stop_cv_.notify_all();
  }
  {
    // StartSync checks stopping_ under the same mutex, so no SYNC thread starts after this.
    std::lock_guard control(sync_control_mu_);
    StopSync();
  }
  WakeReceiver();
  if (thread_.joinable()) {
    thread_.join();
    log::Info("canopen_master_closed", log::Fields().Add("bus", bus_name_));
  }
  std::lock_guard lock(mu_);
  FailAllSdoLocked(absl::UnavailableError(absl::StrCat("canopen master ", bus_name_, ": stopped")));
  pending_.clear();
}

std::string CanopenMaster::bus_name() const { return bus_name_; }

bool CanopenMaster::link_up() const {
  std::lock_guard lock(mu_);
  return fault_ == BusFault::kNone;
}

MasterCounters CanopenMaster::counters() const {
  std::lock_guard lock(mu_);
  MasterCounters c = counters_;
  c.frames_out = frames_out_.load();
  c.send_errors = send_errors_.load();
  return c;
}

std::optional<NmtState> CanopenMaster::node_state(uint8_t node) const {
  std::lock_guard lock(mu_);
  auto it = nodes_.find(node);
  if (it == nodes_.end()) return std::nullopt;
  return it->second.nmt;
}

void CanopenMaster::Wake() { WakeReceiver(); }

void CanopenMaster::WakeReceiver() {
  std::shared_lock lock(channel_mu_);
  channel_->Wake();
}

void CanopenMaster::SetNodeLabel(uint8_t node, const std::string& family,
                                 const std::string& drive) {
  std::lock_guard lock(mu_);
  Node& n = nodes_[node];
  n.family = family;
  n.drive = drive;
}

void CanopenMaster::SetNodeTrace(uint8_t node, const std::string& drive) {
  std::lock_guard lock(trace_mu_);
  if (drive.empty()) {
    traced_nodes_.erase(node);
  } else {
    traced_nodes_[node] = drive;
  }
  tracing_.store(!traced_nodes_.empty());
}

void CanopenMaster::TraceFrame(const transport::CanFrame& frame, const char* dir, uint8_t node) {
  if (!tracing_.load(std::memory_order_relaxed)) return;
  // CiA 301 §7.3.3: function code in bits 10..7, node ID in bits 6..0; NMT (0) names the node
  // in its second byte, SYNC/TIME (0x80, 0x100) none.
  if (node == 0 && !frame.extended) {
    if (frame.id == 0 && frame.dlc >= 2) {
      node = frame.data[1];
    } else if (frame.id != 0x80 && frame.id != 0x100) {
      node = static_cast<uint8_t>(frame.id & 0x7F);
    }
  }
  std::string drive;
  {
    std::lock_guard lock(trace_mu_);
    auto it = traced_nodes_.find(node);
    if (it == traced_nodes_.end()) return;
    drive = it->second;
  }
  wire::TraceText(drive, "canopen", dir, transport::FormatCanFrame(frame));
}

absl::Status CanopenMaster::SendFrame(const transport::CanFrame& frame) {
  TraceFrame(frame, "tx");
  absl::Status s;
  {
    std::shared_lock lock(channel_mu_);
    s = channel_->Send(frame);
  }
  if (s.ok()) {
    frames_out_.fetch_add(1);
  } else {
    send_errors_.fetch_add(1);
    log::Debug("canopen_send_error", log::Fields()
                                         .Add("bus", bus_name_)
                                         .Add("frame", transport::FormatCanFrame(frame))
                                         .Add("error", s.message()));
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// NMT.

absl::Status CanopenMaster::SendNmt(NmtCommand command, uint8_t node) {
  auto frame = EncodeNmt(NmtMessage{command, node});
  if (!frame.ok()) return frame.status();
  if (absl::Status s = SendFrame(*frame); !s.ok()) {
    return absl::UnavailableError(absl::StrCat("canopen nmt ", std::string(NmtCommandName(command)),
                                               " node ", node, " on ", bus_name_, ": ",
                                               s.message()));
  }
  std::lock_guard lock(mu_);
  ++counters_.nmt_sent;
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Observers.

absl::StatusOr<ObserverId> CanopenMaster::AddNodeObserver(uint8_t node, NodeObserver* observer) {
  if (absl::Status s = ValidateNodeId(node, "observer.node_id"); !s.ok()) return s;
  if (observer == nullptr) return absl::InvalidArgumentError("canopen master: observer is null");
  std::lock_guard lock(mu_);
  const ObserverId id = next_observer_++;
  observers_[id] = Observer{node, observer};
  nodes_[node];
  return id;
}

void CanopenMaster::RemoveNodeObserver(ObserverId id) {
  {
    std::lock_guard lock(mu_);
    observers_.erase(id);
  }
  // A delivery in progress may still hold the observer: wait for it to end (decision 1111).
  // On the receive thread the delivery re-checks registration before every call instead.
  if (!OnReceiveThread()) std::lock_guard wait(dispatch_mu_);
}

bool CanopenMaster::HasObserverLocked(uint8_t node) const {
  for (const auto& [id, o] : observers_) {
    if (o.node == node) return true;
  }
  return false;
}

void CanopenMaster::Dispatch() {
  std::lock_guard dispatching(dispatch_mu_);
  std::vector<Notification> batch;
  std::vector<std::pair<ObserverId, Observer>> observers;
  {
    std::lock_guard lock(mu_);
    batch.swap(pending_);
    if (batch.empty()) return;
    observers.assign(observers_.begin(), observers_.end());
  }
  for (const Notification& n : batch) {
    for (const auto& [id, o] : observers) {
      if (n.node != 0 && o.node != n.node) continue;
      {
        std::lock_guard lock(mu_);
        if (!observers_.contains(id) || stopping_) continue;
      }
      switch (n.kind) {
        case Notification::Kind::kHeartbeat:
          o.observer->OnHeartbeat(n.node, n.state, n.event.at);
          break;
        case Notification::Kind::kBootUp:
          o.observer->OnBootUp(n.event);
          break;
        case Notification::Kind::kEmcy:
          o.observer->OnEmcy(n.emcy);
          break;
        case Notification::Kind::kTpdo:
          o.observer->OnTpdo(n.tpdo);
          break;
        case Notification::Kind::kLink: {
          NodeEventInfo e = n.event;
          e.node = o.node;  // bus events reach every node's observer under its node id
          o.observer->OnLinkEvent(e);
          break;
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Receive thread.

void CanopenMaster::Run() {
  std::unique_lock lock(mu_);
  while (!stopping_) {
    const TimePoint now = clock_.Now();
    CheckBusStateLocked(now);
    const Duration wait = ServiceLocked(now);
    planned_wake_ = now + wait;
    lock.unlock();
    Dispatch();
    // Only this thread replaces channel_, so it reads it without channel_mu_.
    absl::StatusOr<std::optional<transport::CanFrame>> got = channel_->Receive(wait);
    lock.lock();
    if (stopping_) break;
    if (!got.ok()) {
      ++counters_.receive_errors;
      BusFaultLocked(BusFault::kBroken, absl::StrCat("receive error: ", got.status().message()),
                     clock_.Now());
      lock.unlock();
      Dispatch();
      lock.lock();
      // A broken channel fails at once: wait out the back-off instead of spinning (decision 1117).
      const Duration pause = backoff_;
      backoff_ = std::min(backoff_ * 2, options_.bus_retry_max);
      if (stop_cv_.wait_for(lock, pause, [&] { return stopping_; })) break;
      if (reopen_) {
        lock.unlock();
        auto reopened = reopen_();
        if (reopened.ok() && *reopened != nullptr) {
          std::unique_lock swap(channel_mu_);
          channel_ = *std::move(reopened);
        }
        lock.lock();
        if (reopened.ok()) {
          ++counters_.reopens;
          log::Info("canopen_bus_reopened", log::Fields().Add("bus", bus_name_));
        } else {
          log::Debug("canopen_bus_reopen_failed",
                     log::Fields().Add("bus", bus_name_).Add("error", reopened.status().message()));
        }
      }
      continue;
    }
    const TimePoint at = clock_.Now();
    if (fault_ == BusFault::kBroken) {
      const transport::CanBusState state = channel_->state();
      if (state != transport::CanBusState::kBusOff && state != transport::CanBusState::kDown) {
        BusRestoredLocked(at);
      }
    }
    if (got->has_value()) {
      ++counters_.frames_in;
      HandleFrameLocked(**got, at);
    }
  }
}

Duration CanopenMaster::ServiceLocked(TimePoint now) {
  TimePoint next = now + kIdleWait;
  if (own_node_ != 0) {
    if (now >= next_own_heartbeat_) {
      // CiA 301 §7.2.8.3.2.3: a producer sends its NMT state every period; a late thread sends
      // once, not a burst (the simulated slaves do the same, decision 1129).
      auto frame = EncodeErrorControl({own_node_, NmtState::kOperational, false});
      if (frame.ok() && SendFrame(*frame).ok()) ++counters_.own_heartbeats_sent;
      next_own_heartbeat_ += own_period_;
      if (next_own_heartbeat_ <= now) next_own_heartbeat_ = now + own_period_;
    }
    next = std::min(next, next_own_heartbeat_);
  }
  for (auto& [id, n] : nodes_) {
    next = ServiceSdoLocked(n, now, next);
    Heartbeat& hb = n.heartbeat;
    if (hb.consumer_time <= Duration::zero() || hb.state != Heartbeat::State::kAlive) continue;
    // Only while the bus works: our own outage is kLinkLost, not the node's (decision 1114).
    if (fault_ != BusFault::kNone) continue;
    const TimePoint expires = hb.last + hb.consumer_time;
    if (now > expires) {
      hb.state = Heartbeat::State::kLost;
      ++counters_.heartbeat_lost;
      Notification note;
      note.kind = Notification::Kind::kLink;
      note.node = id;
      note.event =
          NodeEventInfo{NodeEvent::kHeartbeatLost, id, now,
                        absl::StrCat("no heartbeat from node ", id, " for ", Ms(now - hb.last),
                                     " ms (consumer time ", Ms(hb.consumer_time), " ms, 1016h)")};
      log::Warn("canopen_heartbeat_lost", log::Fields()
                                              .Add("bus", bus_name_)
                                              .Add("node", static_cast<int>(id))
                                              .Add("reason", "\"" + note.event.reason + "\""));
      pending_.push_back(std::move(note));
    } else {
      next = std::min(next, expires + Duration(1));
    }
  }
  return std::clamp(next - now, Duration::zero(), kIdleWait);
}

void CanopenMaster::CheckBusStateLocked(TimePoint now) {
  const transport::CanBusState state = channel_->state();
  if (state == transport::CanBusState::kBusOff) {
    if (fault_ != BusFault::kBusOff) BusFaultLocked(BusFault::kBusOff, "bus-off", now);
  } else if (state == transport::CanBusState::kDown) {
    if (fault_ == BusFault::kNone) BusFaultLocked(BusFault::kDown, "interface down", now);
  } else if (fault_ == BusFault::kBusOff || fault_ == BusFault::kDown) {
    BusRestoredLocked(now);
  }
}

void CanopenMaster::BusFaultLocked(BusFault fault, const std::string& reason, TimePoint now) {
  const bool was_up = fault_ == BusFault::kNone;
  const bool new_bus_off = fault == BusFault::kBusOff && fault_ != BusFault::kBusOff;
  fault_ = fault;
  if (!was_up && !new_bus_off) return;
  if (was_up) backoff_ = options_.bus_retry_min;
  const NodeEvent event = fault == BusFault::kBusOff ? NodeEvent::kBusOff : NodeEvent::kLinkLost;
  if (event == NodeEvent::kBusOff) {
    ++counters_.bus_off_events;
  } else {
    ++counters_.link_lost_events;
  }
  const std::string text = absl::StrCat("canopen bus ", bus_name_, ": ", reason);
  log::Error("canopen_bus_fault", log::Fields()
                                      .Add("bus", bus_name_)
                                      .Add("event", NodeEventName(event))
                                      .Add("reason", "\"" + reason + "\""));
  FailAllSdoLocked(absl::UnavailableError(text));
  // Supervision restarts with the first heartbeat after the bus is back (decision 1114).
  for (auto& [id, n] : nodes_) {
    if (n.heartbeat.state == Heartbeat::State::kAlive)
      n.heartbeat.state = Heartbeat::State::kWaiting;
  }
  Notification note;
  note.kind = Notification::Kind::kLink;
  note.node = 0;
  note.event = NodeEventInfo{event, 0, now, text};
  pending_.push_back(std::move(note));
}

void CanopenMaster::BusRestoredLocked(TimePoint now) {
  if (fault_ == BusFault::kNone) return;
  fault_ = BusFault::kNone;
  backoff_ = options_.bus_retry_min;
  log::Warn("canopen_bus_restored", log::Fields().Add("bus", bus_name_));
  Notification note;
  note.kind = Notification::Kind::kLink;
  note.node = 0;
  note.event = NodeEventInfo{NodeEvent::kLinkRestored, 0, now,
                             absl::StrCat("canopen bus ", bus_name_, ": working again")};
  pending_.push_back(std::move(note));
}

// ---------------------------------------------------------------------------------------------
// Frames.

void CanopenMaster::HandleFrameLocked(const transport::CanFrame& frame, TimePoint now) {
  if (frame.error || frame.extended) {
    // CANopen uses 11-bit identifiers only (cob_id.h); an error frame's identifier holds error
    // class bits, not a COB-ID. Neither is looked at further (decision 1482).
    ++counters_.other_traffic;
    if (frame.error) ++counters_.error_frames;
    return;
  }
  if (!frame.rtr) {
    // Configured TPDOs first: they may use any identifier (decision 1107).
    if (auto it = tpdo_by_cob_.find(static_cast<uint16_t>(frame.id)); it != tpdo_by_cob_.end()) {
      TraceFrame(frame, "rx", it->second.first);
      return HandleTpdoLocked(it->second.first, it->second.second, frame, now);
    }
  }
  TraceFrame(frame, "rx");
  absl::StatusOr<CobIdClass> cls = ClassifyCobId(frame.id);
  if (!cls.ok()) {
    ++counters_.other_traffic;
    return;
  }
  switch (cls->function) {
    case Function::kSdoTx:
      return HandleSdoResponseLocked(cls->node, frame, now);
    case Function::kNmtErrorControl:
      if (frame.rtr) break;  // a node-guarding request of another master
      return HandleErrorControlLocked(frame, now);
    case Function::kEmcy:
      return HandleEmcyLocked(frame, now);
    case Function::kTpdo1:
    case Function::kTpdo2:
    case Function::kTpdo3:
    case Function::kTpdo4: {
      const uint16_t number = TpdoNumber(cls->function);
      // A TPDO configured elsewhere (or invalid) no longer uses its predefined identifier.
      if (frame.rtr || tpdo_cob_.contains({cls->node, number})) break;
      return HandleTpdoLocked(cls->node, number, frame, now);
    }
    default:
      break;  // SYNC/TIME of another producer, RPDOs, SDO requests, NMT of another master
  }
  ++counters_.other_traffic;
}

}  // namespace drivegw::canopen
