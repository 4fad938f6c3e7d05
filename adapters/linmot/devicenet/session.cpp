// DeviceNet master session: duplicate MAC ID check, connection set-up, poll cycle, watchdog,
// reconnection and the classification of every frame on the bus (linmot-devicenet.md §5, §11).
#include "adapters/linmot/devicenet/session.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/log.h"
#include "adapters/core/wire_observer.h"
#include "adapters/linmot/devicenet/codec_can.h"

namespace drivegw::linmot::devicenet {
namespace {

// Upper bound of one wait of the I/O thread with nothing scheduled; Register and Stop wake it.
constexpr Duration kIdleWait = std::chrono::milliseconds(200);
// §5.6 [SPEC-H]: the inactivity watchdog of a connection is 4 x its EPR.
constexpr int kWatchdogMultiple = 4;
// Largest image the fragmentation protocol carries in one message (decision 904).
constexpr size_t kMaxImage = kMaxFragmentedMessage;

void Add(PeerCounters& into, const PeerCounters& c) {
  into.frames_sent += c.frames_sent;
  into.frames_received += c.frames_received;
  into.polls_sent += c.polls_sent;
  into.poll_responses += c.poll_responses;
  into.poll_timeouts += c.poll_timeouts;
  into.explicit_requests += c.explicit_requests;
  into.explicit_errors += c.explicit_errors;
  into.explicit_timeouts += c.explicit_timeouts;
  into.fragment_errors += c.fragment_errors;
  into.size_mismatches += c.size_mismatches;
  into.unsolicited += c.unsolicited;
  into.foreign_master += c.foreign_master;
  into.watchdog_expiries += c.watchdog_expiries;
  into.connects += c.connects;
  into.drive_restarts += c.drive_restarts;
  into.send_errors += c.send_errors;
}

Duration Ms(uint16_t ms) { return std::chrono::milliseconds(ms); }

constexpr char kUnregistered[] = "unregistered";

}  // namespace

const char* ToString(LinkState s) {
  switch (s) {
    case LinkState::kUnknown:
      return "UNKNOWN";
    case LinkState::kOnline:
      return "ONLINE";
    case LinkState::kOffline:
      return "OFFLINE";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Life cycle.

absl::StatusOr<std::shared_ptr<Session>> Session::Open(const CanBusConfig& bus,
                                                       const SessionOptions& options,
                                                       const Clock& clock) {
  auto channel = transport::OpenCanChannel(bus);
  if (!channel.ok()) return channel.status();
  return Open(*std::move(channel), options, clock);
}

absl::StatusOr<std::shared_ptr<Session>> Session::Open(
    std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options,
    const Clock& clock) {
  if (channel == nullptr) return absl::InvalidArgumentError("devicenet session: channel is null");
  if (options.master_mac > kMaxMacId) {
    return absl::InvalidArgumentError(
        absl::StrCat("devicenet session.master_mac: ", options.master_mac, " exceeds ", kMaxMacId));
  }
  if (options.duplicate_check_wait <= Duration::zero() ||
      options.bus_retry_min <= Duration::zero() || options.bus_retry_max < options.bus_retry_min) {
    return absl::InvalidArgumentError(
        "devicenet session: duplicate_check_wait and bus_retry_min must be positive, "
        "bus_retry_max >= bus_retry_min");
  }
  std::shared_ptr<Session> session(new Session(std::move(channel), options, clock));
  session->thread_ = std::thread([s = session.get()] { s->Run(); });
  log::Info("devicenet_session_open", log::Fields()
                                          .Add("bus", session->bus_name())
                                          .Add("master_mac", static_cast<int>(options.master_mac)));
  return session;
}

Session::Session(std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options,
                 const Clock& clock)
    : options_(options), clock_(clock), channel_(std::move(channel)) {
  bus_next_ = clock_.Now();
  bus_backoff_ = options_.bus_retry_min;
}

Session::~Session() { Stop(); }

void Session::Stop() {
  std::lock_guard stop_lock(stop_mu_);
  {
    std::lock_guard lock(mu_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
    stop_cv_.notify_all();
  }
  channel_->Wake();  // releases a blocked Receive at once
  if (thread_.joinable()) {
    thread_.join();
    log::Info("devicenet_session_closed", log::Fields().Add("bus", bus_name()));
  }
}

absl::StatusOr<PeerId> Session::Register(const PeerOptions& o, SessionPeer* peer) {
  const std::string where = absl::StrCat("drive '", o.name, "'");
  if (peer == nullptr) return absl::InvalidArgumentError("devicenet session: peer is null");
  if (o.mac_id > kMaxMacId) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".mac_id: ", o.mac_id, " exceeds ", kMaxMacId));
  }
  if (o.mac_id == options_.master_mac) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".mac_id: ", o.mac_id,
                                                   " is the gateway's own MAC ID on ", bus_name(),
                                                   " (decision 981)"));
  }
  for (const auto& [field, size] :
       {std::pair{"consumed_size", o.consumed_size}, std::pair{"produced_size", o.produced_size}}) {
    if (size == 0 || size > kMaxImage) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".devicenet.", field, ": ", size,
                                                     " bytes is not 1..", kMaxImage,
                                                     " (linmot-devicenet.md §5.8)"));
    }
  }
  if (o.poll_period < std::chrono::milliseconds(1)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".devicenet.poll_period: below 1 ms"));
  }
  if (o.response_timeout <= Duration::zero() || o.explicit_timeout <= Duration::zero() ||
      o.retry_min <= Duration::zero() || o.retry_max < o.retry_min) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".devicenet: time-outs must be positive and retry_max >= retry_min"));
  }
  if (Ms(o.expected_packet_rate_ms) <= o.poll_period) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".devicenet.expected_packet_rate_ms: ", o.expected_packet_rate_ms,
                     " must exceed the poll period (linmot-devicenet.md §11.3)"));
  }
  auto ids = PredefinedSetIds(o.mac_id);
  if (!ids.ok()) return ids.status();
  PeerId id;
  {
    std::lock_guard lock(mu_);
    if (stopping_) {
      return absl::FailedPreconditionError(
          absl::StrCat("devicenet session ", bus_name(), ": stopped"));
    }
    for (const auto& [other_id, other] : peers_) {
      if (other.options.mac_id == o.mac_id) {
        return absl::AlreadyExistsError(absl::StrCat(where, ".mac_id: ", o.mac_id,
                                                     " is also the MAC ID of drive '",
                                                     other.options.name, "' on ", bus_name()));
      }
    }
    id = next_id_++;
    Peer p;
    p.options = o;
    p.peer = peer;
    p.ids = *ids;
    p.backoff = o.retry_min;
    HealthConfig health;
    health.down_after_failures =
        o.down_after_failures > 0
            ? o.down_after_failures
            : static_cast<int>(kWatchdogMultiple * Ms(o.expected_packet_rate_ms) /
                               std::max<Duration>(o.response_timeout, Duration(1))) +
                  1;
    health.backoff_min = std::chrono::duration_cast<std::chrono::milliseconds>(o.retry_min);
    health.backoff_max = std::chrono::duration_cast<std::chrono::milliseconds>(o.retry_max);
    health.up_after = o.up_after;
    if (auto s = ValidateHealthConfig(health, absl::StrCat(where, ".health.")); !s.ok()) return s;
    p.health.emplace(health, clock_);
    p.reassembler = Reassembler(std::max(o.produced_size, kMaxFrameData));
    peers_.emplace(id, std::move(p));
  }
  channel_->Wake();
  log::Info("devicenet_peer_registered", log::Fields()
                                             .Add("drive", o.name)
                                             .Add("bus", bus_name())
                                             .Add("mac_id", static_cast<int>(o.mac_id)));
  return id;
}

void Session::Unregister(PeerId id) {
  std::lock_guard lock(mu_);
  auto it = peers_.find(id);
  if (it == peers_.end()) return;
  Peer& p = it->second;
  if (p.step != Step::kWaitBus && p.step != Step::kBackoff && bus_ == BusState::kOnline) {
    // §11.9: release the set so that another master (or our next start) may allocate it. The
    // answer is not awaited: the peer is gone once this returns.
    auto bytes = EncodeExplicitRequest(
        ReleaseRequest(options_.master_mac, !p.xid, kAllocExplicit | kAllocPolled));
    if (bytes.ok()) {
      if (auto frame = MakeFrame(p.ids.unconnected_request, *bytes); frame.ok()) {
        SendFrameLocked(*frame, &p.counters);
        ++p.counters.explicit_requests;
      }
    }
  }
  SetLinkLocked(p, LinkState::kOffline, kUnregistered);
  Add(counters_.total, p.counters);
  log::Info("devicenet_peer_unregistered",
            log::Fields().Add("drive", p.options.name).Add("bus", bus_name()));
  peers_.erase(it);
}

bool Session::bus_online() const {
  std::lock_guard lock(mu_);
  return bus_ == BusState::kOnline;
}

SessionCounters Session::counters() const {
  std::lock_guard lock(mu_);
  SessionCounters c = counters_;
  for (const auto& [id, p] : peers_) Add(c.total, p.counters);
  return c;
}

std::optional<PeerCounters> Session::peer_counters(PeerId id) const {
  std::lock_guard lock(mu_);
  auto it = peers_.find(id);
  if (it == peers_.end()) return std::nullopt;
  return it->second.counters;
}

std::optional<LinkState> Session::link_state(PeerId id) const {
  std::lock_guard lock(mu_);
  auto it = peers_.find(id);
  if (it == peers_.end()) return std::nullopt;
  return it->second.link;
}

size_t Session::peer_count() const {
  std::lock_guard lock(mu_);
  return peers_.size();
}

// ---------------------------------------------------------------------------------------------
// Sending.

bool Session::SendFrameLocked(const Frame& frame, PeerCounters* counters) {
  if (counters != nullptr) {
    ++counters->frames_sent;
  } else {
    ++counters_.frames_sent;
  }
  if (auto ident = DecodeIdentifier(frame.id); ident.ok()) TraceLocked(ident->mac_id, "tx", frame);
  absl::Status s = channel_->Send(ToCanFrame(frame));
  if (s.ok()) return true;
  if (counters != nullptr) ++counters->send_errors;
  log::Debug("devicenet_send_error", log::Fields()
                                         .Add("bus", bus_name())
                                         .Add("frame", FrameToString(frame))
                                         .Add("error", s.message()));
  return false;
}

void Session::TraceLocked(uint8_t mac, const char* dir, const Frame& frame) {
  const Peer* p = FindByMacLocked(mac);
  if (p != nullptr && p->options.wire_trace &&
      p->options.wire_trace->load(std::memory_order_relaxed)) {
    wire::TraceText(p->options.name, "linmot-devicenet", dir, FrameToString(frame));
  }
}

void Session::SendExplicitLocked(Peer& p, const ExplicitRequest& request, uint16_t id,
                                 TimePoint now, bool keep_alive) {
  auto bytes = EncodeExplicitRequest(request);
  absl::StatusOr<Frame> frame =
      bytes.ok() ? MakeFrame(id, *bytes) : absl::StatusOr<Frame>(bytes.status());
  if (!frame.ok()) {
    // Our requests all fit 8 bytes (§11.2); anything else is a bug.
    log::Error("devicenet_internal",
               log::Fields().Add("drive", p.options.name).Add("error", frame.status().message()));
    return;
  }
  ++p.counters.explicit_requests;
  SendFrameLocked(*frame, &p.counters);
  // Outstanding even after a send error: the time-out then drives the retry.
  p.pending_explicit =
      Explicit{request.service, request.header.xid, now + p.options.explicit_timeout, keep_alive};
}

void Session::SendPollLocked(Peer& p, TimePoint now) {
  const std::vector<uint8_t> image = p.peer->BuildPollCommand();
  auto frames = EncodePollCommand(p.options.mac_id, image, p.options.consumed_size);
  if (!frames.ok()) {
    log::Error("devicenet_internal",
               log::Fields().Add("drive", p.options.name).Add("error", frames.status().message()));
    p.next_poll = now + p.options.poll_period;
    return;
  }
  ++p.counters.polls_sent;
  // §5.8 / §5.12: the fragments of one message leave back-to-back, never interleaved.
  for (const Frame& f : *frames) {
    if (!SendFrameLocked(f, &p.counters)) break;
  }
  p.poll_outstanding = true;
  p.poll_deadline = now + p.options.response_timeout;
  // Paced polls keep their grid (no drift from loop latency); an urgent or late one restarts it.
  p.next_poll = now >= p.next_poll && now - p.next_poll < p.options.poll_period
                    ? p.next_poll + p.options.poll_period
                    : now + p.options.poll_period;
  p.reassembler.Reset();
}

// ---------------------------------------------------------------------------------------------
// Link and set-up state.

void Session::SetLinkLocked(Peer& p, LinkState to, const std::string& reason) {
  if (p.link == to) return;
  const LinkState from = p.link;
  p.link = to;
  log::Fields fields;
  fields.Add("drive", p.options.name)
      .Add("bus", bus_name())
      .Add("mac_id", static_cast<int>(p.options.mac_id))
      .Add("from", ToString(from))
      .Add("to", ToString(to));
  if (!reason.empty()) fields.Add("reason", "\"" + reason + "\"");
  if (to == LinkState::kOffline && from == LinkState::kOnline && reason != kUnregistered) {
    log::Warn("devicenet_link", fields);  // recovered automatically (§11.8)
  } else {
    log::Info("devicenet_link", fields);
  }
  p.peer->OnLinkChange(to, reason);
}

void Session::StartSetupLocked(Peer& p, TimePoint now) {
  p.poll_outstanding = false;
  p.pending_explicit.reset();
  p.reassembler.Reset();
  p.xid = !p.xid;  // §11.2: toggle XID for each new request
  if (p.release_first) {
    // §11.8: a set this gateway may still own from before (restart, lost connection).
    p.step = Step::kRelease;
    SendExplicitLocked(p, ReleaseRequest(options_.master_mac, p.xid, kAllocExplicit | kAllocPolled),
                       p.ids.unconnected_request, now);
    return;
  }
  p.step = Step::kAllocate;
  // §11.2 step 2: explicit + polled (0x03), allocator = our MAC.
  SendExplicitLocked(p, AllocateRequest(options_.master_mac, p.xid, kAllocExplicit | kAllocPolled),
                     p.ids.unconnected_request, now);
}

void Session::FailSetupLocked(Peer& p, TimePoint now, const std::string& why, bool release_first) {
  log::Fields fields;
  fields.Add("drive", p.options.name)
      .Add("bus", bus_name())
      .Add("mac_id", static_cast<int>(p.options.mac_id))
      .Add("retry_ms", std::chrono::duration_cast<std::chrono::milliseconds>(p.backoff).count())
      .Add("reason", "\"" + why + "\"");
  // One warning per outage, then debug: a drive that is switched off is a state (drive.h).
  if (!p.warned_setup) {
    log::Warn("devicenet_setup_failed", fields);
    p.warned_setup = true;
  } else {
    log::Debug("devicenet_setup_failed", fields);
  }
  p.pending_explicit.reset();
  p.poll_outstanding = false;
  p.step = Step::kBackoff;
  // Decision 1431: a failed set-up is DOWN at once (the old OFFLINE from the first failure); each
  // further one doubles the shared model's back-off up to retry_max.
  if (p.health->state() == HealthState::kDown) {
    HealthChangedLocked(p, p.health->RecordFailure("set-up failures"));
  } else {
    HealthChangedLocked(p, p.health->ForceDown(why));
  }
  p.retry_at = now + p.health->backoff();
  p.backoff = p.health->backoff();
  p.release_first = release_first;
  if (p.link == LinkState::kUnknown) SetLinkLocked(p, LinkState::kOffline, why);
}

void Session::EstablishLocked(Peer& p, TimePoint now) {
  p.step = Step::kEstablished;
  p.backoff = p.options.retry_min;
  p.release_first = false;
  p.poll_outstanding = false;
  p.next_poll = now;
  p.last_response = now;  // the watchdog runs from establishment (§5.6 step 2)
  p.next_keep_alive = now + Ms(p.granted_explicit_epr_ms) / 2;
  ++p.counters.connects;
  // Decision 1431: a completed set-up means the drive answered, so a DOWN peer is recovering
  // (DEMOTED; UP once its poll responses pass the hold, decision 1432). Left DOWN, the first lost
  // poll of the new connection would drop it again at once instead of counting up to
  // health.down_after_failures (found by DnFaultTest under 10 % loss: the connection never survived
  // long enough to answer a poll).
  if (p.health->state() == HealthState::kDown) HealthChangedLocked(p, p.health->RecordSuccess());
  log::Debug("devicenet_established", log::Fields()
                                          .Add("drive", p.options.name)
                                          .Add("epr_ms", p.granted_epr_ms)
                                          .Add("explicit_epr_ms", p.granted_explicit_epr_ms));
}

void Session::DropConnectionLocked(Peer& p, TimePoint now, const std::string& reason, Duration wait,
                                   bool release_first) {
  p.step = Step::kBackoff;
  p.retry_at = now + wait;
  p.release_first = release_first;
  p.pending_explicit.reset();
  p.poll_outstanding = false;
  p.reassembler.Reset();
  p.warned_setup = false;
  if (reason != kUnregistered) HealthChangedLocked(p, p.health->ForceDown(reason));
  SetLinkLocked(p, LinkState::kOffline, reason);
}

void Session::HealthChangedLocked(Peer& p, bool changed) {
  if (changed) p.peer->OnHealthChange(p.health->info());
}

void Session::BusLostLocked(TimePoint now, const std::string& reason) {
  if (bus_ == BusState::kDown) return;
  bus_ = BusState::kDown;
  ++counters_.bus_off_events;
  bus_backoff_ = options_.bus_retry_min;
  bus_next_ = now + bus_backoff_;
  log::Error("devicenet_bus_lost", log::Fields().Add("bus", bus_name()).Add("reason", reason));
  // §10.2 "Bus-off in the gateway": every drive offline; after recovery our own duplicate MAC ID
  // check and a full set-up (release first: the drives may still hold our connections).
  for (auto& [id, p] : peers_) {
    DropConnectionLocked(p, now, absl::StrCat("bus ", reason), Duration::zero(), true);
    p.step = Step::kWaitBus;
  }
}

Session::Peer* Session::FindByMacLocked(uint8_t mac) {
  for (auto& [id, p] : peers_) {
    if (p.options.mac_id == mac) return &p;
  }
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Scheduling.

Duration Session::ServiceBusLocked(TimePoint now) {
  const transport::CanBusState state = channel_->state();
  if (state == transport::CanBusState::kBusOff) {
    BusLostLocked(now, "bus-off");
  } else if (state == transport::CanBusState::kDown && bus_ != BusState::kDown) {
    BusLostLocked(now, "down");
  }
  auto send_check = [&]() -> bool {
    auto frame = DuplicateMacCheckFrame(
        options_.master_mac,
        DuplicateMacCheck{false, 0, options_.vendor_id, options_.serial_number});
    return frame.ok() && SendFrameLocked(*frame, nullptr);
  };
  switch (bus_) {
    case BusState::kOnline:
      return kIdleWait;
    case BusState::kDown:
    case BusState::kDuplicate:
      if (now < bus_next_) return bus_next_ - now;
      if (state == transport::CanBusState::kBusOff) {
        bus_next_ = now + bus_backoff_;
        bus_backoff_ = std::min(bus_backoff_ * 2, options_.bus_retry_max);
        return bus_next_ - now;
      }
      bus_ = BusState::kChecking;
      checks_sent_ = 0;
      bus_next_ = now;
      [[fallthrough]];
    case BusState::kChecking:
      if (now < bus_next_) return bus_next_ - now;
      if (checks_sent_ < 2) {
        // §5.7: request, wait, second request, wait; online if nobody answered.
        if (!send_check()) {
          // Still down (route, interface, bus-off): back off without a new bus-lost event.
          bus_ = BusState::kDown;
          bus_next_ = now + bus_backoff_;
          bus_backoff_ = std::min(bus_backoff_ * 2, options_.bus_retry_max);
          return bus_next_ - now;
        }
        ++checks_sent_;
        bus_next_ = now + options_.duplicate_check_wait;
        return bus_next_ - now;
      }
      bus_ = BusState::kOnline;
      bus_backoff_ = options_.bus_retry_min;
      log::Info("devicenet_bus_online",
                log::Fields()
                    .Add("bus", bus_name())
                    .Add("master_mac", static_cast<int>(options_.master_mac)));
      return Duration::zero();
  }
  return kIdleWait;
}

void Session::ServicePeerLocked(Peer& p, TimePoint now) {
  if (bus_ != BusState::kOnline) {
    if (p.step != Step::kWaitBus && p.step != Step::kBackoff) p.step = Step::kWaitBus;
    return;
  }
  if (p.pending_explicit && now >= p.pending_explicit->deadline) {
    const Explicit request = *p.pending_explicit;
    p.pending_explicit.reset();
    ++p.counters.explicit_timeouts;
    OnExplicitResultLocked(p, request, std::nullopt, now);
  }
  switch (p.step) {
    case Step::kWaitBus:
      StartSetupLocked(p, now);
      return;
    case Step::kBackoff:
      if (now >= p.retry_at) StartSetupLocked(p, now);
      return;
    case Step::kEstablished:
      break;
    default:
      return;  // an explicit request is outstanding
  }
  if (p.poll_outstanding && now >= p.poll_deadline) {
    p.poll_outstanding = false;
    ++p.counters.poll_timeouts;
    p.reassembler.Reset();
    p.peer->OnPollTimeout();
    HealthChangedLocked(p, p.health->RecordFailure("poll time-outs"));
    if (p.health->state() == HealthState::kDown) {
      // health.down_after_failures reached before the watchdog: the connection counts as lost.
      DropConnectionLocked(p, now, p.health->info().reason, Duration::zero(), true);
      return;
    }
  }
  // §5.6 / §11.3: our side of the inactivity watchdog; the drive runs the same one.
  const Duration watchdog = kWatchdogMultiple * Ms(p.granted_epr_ms);
  if (now - p.last_response >= watchdog) {
    ++p.counters.watchdog_expiries;
    DropConnectionLocked(
        p, now,
        absl::StrCat("no poll response for 4 x EPR = ", kWatchdogMultiple * p.granted_epr_ms,
                     " ms (linmot-devicenet.md §5.6)"),
        Duration::zero(), true);
    return;
  }
  if (!p.pending_explicit && now >= p.next_keep_alive) {
    // §11.2 step 5: keep the explicit connection alive with a harmless Get (connection state).
    p.xid = !p.xid;
    SendExplicitLocked(p,
                       GetAttributeSingleRequest(options_.master_mac, p.xid, kClassConnection,
                                                 kInstanceExplicit, kAttrConnState),
                       p.ids.explicit_request, now, /*keep_alive=*/true);
    p.next_keep_alive = now + Ms(p.granted_explicit_epr_ms) / 2;
  }
  // One poll outstanding per drive; the period paces polling, an urgent image leaves as soon as
  // the previous poll is answered (decision 006).
  if (!p.poll_outstanding && (now >= p.next_poll || p.peer->HasUrgentRequest())) {
    SendPollLocked(p, now);
  }
}

Duration Session::ServiceLocked(TimePoint now) {
  Duration wait = std::min(kIdleWait, ServiceBusLocked(now));
  for (auto& [id, p] : peers_) {
    ServicePeerLocked(p, now);
    TimePoint next = now + kIdleWait;
    if (p.pending_explicit) next = std::min(next, p.pending_explicit->deadline);
    switch (p.step) {
      case Step::kBackoff:
        next = std::min(next, p.retry_at);
        break;
      case Step::kWaitBus:
        break;
      case Step::kEstablished:
        next = std::min(next, p.poll_outstanding ? p.poll_deadline : p.next_poll);
        next = std::min(next, p.last_response + kWatchdogMultiple * Ms(p.granted_epr_ms));
        if (!p.pending_explicit) next = std::min(next, p.next_keep_alive);
        break;
      default:
        break;
    }
    wait = std::min(wait, next - now);
  }
  return std::max(Duration::zero(), wait);
}

void Session::Run() {
  std::unique_lock lock(mu_);
  while (!stopping_) {
    const Duration wait = ServiceLocked(clock_.Now());
    lock.unlock();
    absl::StatusOr<std::optional<transport::CanFrame>> got = channel_->Receive(wait);
    lock.lock();
    if (stopping_) break;
    if (!got.ok()) {
      ++counters_.receive_errors;
      log::Warn("devicenet_receive_error",
                log::Fields().Add("bus", bus_name()).Add("error", got.status().message()));
      // A broken channel fails at once: wait out the bus back-off instead of spinning.
      BusLostLocked(clock_.Now(), "receive error");
      stop_cv_.wait_for(lock, bus_backoff_, [&] { return stopping_; });
      continue;
    }
    if (got->has_value()) HandleFrameLocked(**got, clock_.Now());
  }
}

// ---------------------------------------------------------------------------------------------
// Receiving.

void Session::HandleFrameLocked(const transport::CanFrame& raw, TimePoint now) {
  ++counters_.frames_received;
  absl::StatusOr<Frame> frame = FromCanFrame(raw);
  absl::StatusOr<Identifier> ident =
      frame.ok() ? DecodeIdentifier(frame->id) : absl::StatusOr<Identifier>(frame.status());
  if (!ident.ok()) {
    // STYLE §6: a bad frame is counted, traced (by the channel) and dropped.
    ++counters_.malformed;
    log::Debug("devicenet_malformed", log::Fields()
                                          .Add("bus", bus_name())
                                          .Add("frame", transport::FormatCanFrame(raw))
                                          .Add("error", ident.status().message()));
    return;
  }
  const std::span<const uint8_t> data = frame->payload();
  const uint8_t mac = ident->mac_id;
  TraceLocked(mac, "rx", *frame);
  if (ident->group == MessageGroup::kGroup1) {
    Peer* p = FindByMacLocked(mac);
    if (p == nullptr) {
      ++counters_.unexpected_mac;
      log::Debug("devicenet_unexpected_mac",
                 log::Fields().Add("bus", bus_name()).Add("frame", FrameToString(*frame)));
      return;
    }
    ++p->counters.frames_received;
    if (ident->message_id == kG1PollResponse) return HandlePollResponseLocked(*p, data, now);
    // Change of state / bit-strobe / multicast poll responses: we never allocate them.
    ++p->counters.unsolicited;
    return;
  }
  if (ident->group != MessageGroup::kGroup2) {
    ++counters_.other_traffic;  // UCMM (group 3) and group 4: not used (D-11)
    return;
  }
  switch (ident->message_id) {
    case kG2DuplicateMacCheck:
      return HandleDuplicateMacLocked(mac, data, now);
    case kG2ExplicitResponse: {
      Peer* p = FindByMacLocked(mac);
      if (p == nullptr) {
        ++counters_.unexpected_mac;
        return;
      }
      ++p->counters.frames_received;
      return HandleExplicitResponseLocked(*p, data, now);
    }
    case kG2ExplicitRequest:
    case kG2PollCommand:
    case kG2UnconnectedRequest:
    case kG2CosAcknowledge: {
      // Our own frames are never returned by the channel, so these come from another master
      // (seed line 142: one master at a time). Counted, dropped; the drive refuses it.
      Peer* p = FindByMacLocked(mac);
      if (p == nullptr) {
        if (mac == options_.master_mac) {
          ++counters_.malformed;  // master-produced frames addressed to our own MAC
        } else {
          ++counters_.other_traffic;
        }
        return;
      }
      ++p->counters.foreign_master;
      if (!p->warned_foreign) {
        p->warned_foreign = true;
        log::Warn("devicenet_foreign_master", log::Fields()
                                                  .Add("drive", p->options.name)
                                                  .Add("bus", bus_name())
                                                  .Add("frame", FrameToString(*frame)));
      }
      return;
    }
    default:
      ++counters_.other_traffic;  // bit-strobe / multicast poll commands of some master
      return;
  }
}

void Session::HandleDuplicateMacLocked(uint8_t mac, std::span<const uint8_t> data, TimePoint now) {
  absl::StatusOr<DuplicateMacCheck> check = DecodeDuplicateMacCheck(data);
  if (!check.ok()) {
    ++counters_.malformed;
    return;
  }
  if (mac == options_.master_mac) {
    if (bus_ == BusState::kOnline && !check->response) {
      // §5.7 [SPEC-H]: an online node answers a check of its own MAC ID.
      auto frame = DuplicateMacCheckFrame(
          mac, DuplicateMacCheck{true, 0, options_.vendor_id, options_.serial_number});
      if (frame.ok() && SendFrameLocked(*frame, nullptr)) ++counters_.duplicate_mac_answered;
      return;
    }
    if (bus_ == BusState::kChecking) {
      // §5.7: a response (or another node's request) during our check: our MAC ID is taken.
      ++counters_.duplicate_mac_detected;
      bus_ = BusState::kDuplicate;
      bus_next_ = now + options_.bus_retry_max;
      log::Error("devicenet_duplicate_mac",
                 log::Fields()
                     .Add("bus", bus_name())
                     .Add("mac_id", static_cast<int>(mac))
                     .Add("vendor_id", check->vendor_id)
                     .Add("serial", absl::StrFormat("0x%08X", check->serial_number))
                     .Add("action", "\"another node uses the gateway's MAC ID; retrying\""));
      return;
    }
    ++counters_.other_traffic;
    return;
  }
  Peer* p = FindByMacLocked(mac);
  if (p == nullptr) {
    ++counters_.other_traffic;
    return;
  }
  ++p->counters.frames_received;
  if (check->response) {
    // Somebody answered the drive's own check: two nodes with this MAC ID.
    ++p->counters.unsolicited;
    log::Warn("devicenet_drive_duplicate_mac",
              log::Fields().Add("drive", p->options.name).Add("mac_id", static_cast<int>(mac)));
    return;
  }
  if (p->step == Step::kWaitBus) return;
  if (p->step != Step::kEstablished) {
    // The drive is starting (power-up, reset): it cannot answer before its check ends (§5.7).
    p->pending_explicit.reset();
    p->step = Step::kBackoff;
    p->retry_at = now + p->options.restart_wait;
    p->release_first = false;
    return;
  }
  // §11.8: the drive's duplicate MAC ID request while we talk to it: it restarted (reset,
  // power cycle, bus-off recovery) and lost every connection. Wait >= 2 s, then a fresh set-up.
  ++p->counters.drive_restarts;
  DropConnectionLocked(*p, now, "drive restarted (duplicate MAC ID check seen, §11.8)",
                       p->options.restart_wait, false);
}

void Session::HandleExplicitResponseLocked(Peer& p, std::span<const uint8_t> data, TimePoint now) {
  if (data.empty()) {
    ++counters_.malformed;
    return;
  }
  const ExplicitHeader header = DecodeExplicitHeader(data[0]);
  if (header.mac_id != options_.master_mac) {
    // §5.3: the header names the destination master; this answers someone else.
    ++p.counters.foreign_master;
    return;
  }
  absl::StatusOr<ExplicitResponse> response = DecodeExplicitResponse(data);
  if (!response.ok()) {
    ++counters_.malformed;
    log::Debug(
        "devicenet_malformed",
        log::Fields().Add("drive", p.options.name).Add("error", response.status().message()));
    return;
  }
  const uint8_t expected_service =
      response->is_error() ? 0 : response->service;  // an error answers any service
  if (!p.pending_explicit || header.xid != p.pending_explicit->xid ||
      (expected_service != 0 && expected_service != p.pending_explicit->service)) {
    ++p.counters.unsolicited;
    return;
  }
  const Explicit request = *p.pending_explicit;
  p.pending_explicit.reset();
  // Sent at deadline - explicit_timeout (SendExplicitLocked): the request's round trip.
  const Duration round_trip = now - (request.deadline - p.options.explicit_timeout);
  p.counters.last_round_trip_ms = std::chrono::duration<double, std::milli>(round_trip).count();
  wire::ObserveRoundTrip("linmot-devicenet", p.options.name, round_trip);
  if (response->is_error()) ++p.counters.explicit_errors;
  OnExplicitResultLocked(p, request, *response, now);
}

void Session::OnExplicitResultLocked(Peer& p, const Explicit& request,
                                     const std::optional<ExplicitResponse>& response,
                                     TimePoint now) {
  if (request.keep_alive) return;  // any answer (or none) is fine; polls supervise the link
  const bool error = response && response->is_error();
  std::string error_text;
  if (error) {
    auto e = DecodeErrorResponse(*response);
    error_text = e.ok() ? ErrorResponseText(*e) : "malformed error response";
  }
  auto send_get = [&](uint8_t attribute) {
    p.xid = !p.xid;
    SendExplicitLocked(p,
                       GetAttributeSingleRequest(options_.master_mac, p.xid, kClassConnection,
                                                 kInstancePoll, attribute),
                       p.ids.explicit_request, now);
  };
  auto send_poll_epr = [&]() {
    p.step = Step::kPollEpr;
    p.xid = !p.xid;
    SendExplicitLocked(p,
                       SetExpectedPacketRateRequest(options_.master_mac, p.xid, kInstancePoll,
                                                    p.options.expected_packet_rate_ms),
                       p.ids.explicit_request, now);
  };
  switch (p.step) {
    case Step::kRelease:
      // Whatever the answer (released, nothing to release, none): allocate now.
      p.release_first = false;
      StartSetupLocked(p, now);
      return;
    case Step::kAllocate: {
      if (!response) {
        // §10.2 / §11.8: absent, wrong MAC ID or bit rate, duplicate MAC, DeviceNet disabled.
        return FailSetupLocked(p, now,
                               "no answer to Allocate: check the drive's MAC ID, bit rate and "
                               "cabling (linmot-devicenet.md §10.2)",
                               false);
      }
      if (error) {
        auto e = DecodeErrorResponse(*response);
        const bool already = e.ok() && e->general == kErrAlreadyInRequestedState;
        // D-14: 0x0B/0x02 "already allocated" is most likely our own set from before a restart:
        // release it first. 0x0C/0x01: another master owns the set (line 142): wait and retry.
        return FailSetupLocked(p, now, absl::StrCat("Allocate refused: ", error_text), already);
      }
      auto format = DecodeAllocateResponse(*response);
      if (!format.ok() || *format != BodyFormat::k8_8) {
        return FailSetupLocked(p, now,
                               format.ok()
                                   ? "Allocate granted body format other than 8/8 (not supported)"
                                   : std::string(format.status().message()),
                               true);
      }
      p.step = Step::kExplicitEpr;
      p.xid = !p.xid;
      SendExplicitLocked(p,
                         SetExpectedPacketRateRequest(options_.master_mac, p.xid, kInstanceExplicit,
                                                      p.options.explicit_epr_ms),
                         p.ids.explicit_request, now);
      return;
    }
    case Step::kExplicitEpr: {
      // Tolerated when refused (D-13): the explicit connection then keeps its default EPR of
      // 2500 ms [SPEC-M], which the keep-alive also covers.
      p.granted_explicit_epr_ms = 2500;
      if (response && !error && response->data.size() == 2) {
        if (auto v = DecodeUintValue(response->data); v.ok() && *v > 0) {
          p.granted_explicit_epr_ms = *v;
        }
      } else if (response && !error) {
        p.granted_explicit_epr_ms = p.options.explicit_epr_ms;
      }
      p.step = Step::kProducedSize;
      send_get(kAttrConnProducedSize);
      return;
    }
    case Step::kProducedSize:
    case Step::kConsumedSize: {
      // §11.2 step 4 (optional, D-13): a readable size must match the configured layout.
      const bool produced = p.step == Step::kProducedSize;
      const size_t expected = produced ? p.options.produced_size : p.options.consumed_size;
      if (response && !error) {
        auto v = DecodeUintValue(response->data);
        if (v.ok() && *v != expected) {
          ++p.counters.size_mismatches;
          log::Error("devicenet_size_mismatch",
                     log::Fields()
                         .Add("drive", p.options.name)
                         .Add(produced ? "produced_size" : "consumed_size", *v)
                         .Add("configured", expected)
                         .Add("action",
                              "\"the drive's I/O setup (LinTalk) and the gateway layout differ; "
                              "linmot-devicenet.md line 326\""));
          return FailSetupLocked(p, now, "I/O size mismatch", true);
        }
      }
      if (produced) {
        p.step = Step::kConsumedSize;
        send_get(kAttrConnConsumedSize);
      } else {
        send_poll_epr();
      }
      return;
    }
    case Step::kPollEpr: {
      if (!response || error) {
        return FailSetupLocked(p, now,
                               response
                                   ? absl::StrCat("Set expected packet rate refused: ", error_text)
                                   : "no answer to Set expected packet rate",
                               true);
      }
      // §5.6 step 5: use the granted value (the drive may round up).
      p.granted_epr_ms = p.options.expected_packet_rate_ms;
      if (auto v = DecodeUintValue(response->data); v.ok() && *v > 0) p.granted_epr_ms = *v;
      if (Ms(p.granted_epr_ms) <= p.options.poll_period) {
        return FailSetupLocked(
            p, now,
            absl::StrCat("granted EPR ", p.granted_epr_ms, " ms does not exceed the poll period"),
            true);
      }
      EstablishLocked(p, now);
      return;
    }
    default:
      ++p.counters.unsolicited;
      return;
  }
}

void Session::HandlePollResponseLocked(Peer& p, std::span<const uint8_t> data, TimePoint now) {
  if (p.step != Step::kEstablished || !p.poll_outstanding) {
    ++p.counters.unsolicited;  // late (after its time-out) or without a connection
    return;
  }
  std::vector<uint8_t> message;
  if (p.options.produced_size <= kMaxFrameData) {
    if (data.size() != p.options.produced_size) {
      ++p.counters.size_mismatches;
      log::Debug("devicenet_size_mismatch", log::Fields()
                                                .Add("drive", p.options.name)
                                                .Add("bytes", data.size())
                                                .Add("produced_size", p.options.produced_size));
      return;
    }
    message.assign(data.begin(), data.end());
  } else {
    auto got = p.reassembler.FeedIo(data);
    if (!got.ok()) {
      // §5.8 [SPEC-M]: discard the message on a sequence error; the poll stays outstanding.
      ++p.counters.fragment_errors;
      log::Debug("devicenet_fragment_error",
                 log::Fields().Add("drive", p.options.name).Add("error", got.status().message()));
      return;
    }
    if (!got->has_value()) return;
    message = **std::move(got);
    if (message.size() != p.options.produced_size) {
      ++p.counters.size_mismatches;
      return;
    }
  }
  p.poll_outstanding = false;
  p.last_response = now;
  p.warned_setup = false;
  ++p.counters.poll_responses;
  SetLinkLocked(p, LinkState::kOnline, "");
  HealthChangedLocked(p, p.health->RecordSuccess());
  p.peer->OnPollResponse(message, now);
}

// ---------------------------------------------------------------------------------------------
// Pool.

SessionPool& SessionPool::Instance() {
  static SessionPool* pool = new SessionPool();  // never destroyed: sessions may outlive main
  return *pool;
}

absl::StatusOr<std::shared_ptr<Session>> SessionPool::Acquire(const CanBusConfig& bus,
                                                              const SessionOptions& options,
                                                              const Clock& clock) {
  const std::string key = transport::CanSpecString(bus);
  std::lock_guard lock(mu_);
  auto it = sessions_.find(key);
  if (it != sessions_.end()) {
    if (std::shared_ptr<Session> live = it->second.lock()) {
      if (live->master_mac() != options.master_mac) {
        return absl::FailedPreconditionError(
            absl::StrCat("devicenet bus ", key, ": the gateway already uses MAC ID ",
                         live->master_mac(), " there, not ", options.master_mac));
      }
      return live;
    }
    sessions_.erase(it);
  }
  auto opened = Session::Open(bus, options, clock);
  if (!opened.ok()) return opened.status();
  sessions_[key] = *opened;
  return *opened;
}

}  // namespace drivegw::linmot::devicenet
