// LinUDP master session: cyclic exchange, reply routing, time-outs and link supervision.
#include "adapters/linmot/linudp/session.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "adapters/core/log.h"
#include "adapters/core/status.h"
#include "adapters/core/wire_observer.h"

namespace drivegw::linmot::linudp {
namespace {

// Upper bound of one wait of the I/O thread with nothing scheduled; Register and Stop wake it.
constexpr Duration kIdleWait = std::chrono::milliseconds(200);
// A wake-up of the I/O thread later than this after it was due is a stall of the thread (the
// host held it off the CPU), counted apart from the exchange's own late periods (decision 1312):
// a quarter of the 2 ms cycle of issue 10 (P2), well above the tens of µs of a normal wake-up.
constexpr Duration kStallThreshold = std::chrono::microseconds(500);
// Datagrams taken per recvmmsg.
constexpr size_t kReceiveBatch = transport::UdpSocket::kMaxBatch;

bool Later(const auto& a, const auto& b) { return a.due > b.due; }

void Add(ExchangeCounters& into, const ExchangeCounters& c) {
  into.telegrams_sent += c.telegrams_sent;
  into.send_errors += c.send_errors;
  into.replies += c.replies;
  into.timeouts += c.timeouts;
  into.malformed += c.malformed;
  into.late += c.late;
  into.header_mismatch += c.header_mismatch;
  into.cycles += c.cycles;
  into.late_cycles += c.late_cycles;
  into.late_cycles_stalled += c.late_cycles_stalled;
}

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

absl::StatusOr<std::shared_ptr<Session>> Session::Open(
    const transport::Endpoint& local, const Clock& clock,
    const transport::ThreadScheduling& scheduling) {
  const std::string where = absl::StrCat("linudp session ", local.ToString());
  DGW_RETURN_IF_ERROR(transport::ValidateThreadScheduling(scheduling, where));
  // Exclusive bind: a second gateway on the same master port must fail loudly instead of
  // stealing half of the replies (docs/decisions/202-udp-reuseaddr.md).
  transport::UdpSocket::BindOptions options;
  options.reuse_address = false;
  auto socket = transport::UdpSocket::Bind(local, options);
  if (!socket.ok()) return socket.status();
  std::shared_ptr<Session> session(new Session(std::move(*socket), clock, scheduling));
  session->thread_ = std::thread([s = session.get()] { s->Run(); });
  // Applied from here so that a refusal reaches the caller; the thread has sent nothing yet
  // (no peer can register before Open returns).
  if (absl::Status s =
          transport::ApplyThreadScheduling(session->thread_.native_handle(), scheduling, where);
      !s.ok()) {
    session->Stop();
    return s;
  }
  log::Info("linudp_session_open", log::Fields()
                                       .Add("local", session->local_.ToString())
                                       .Add("io_priority", scheduling.fifo_priority)
                                       .Add("io_cpus", absl::StrJoin(scheduling.cpus, ",")));
  return session;
}

Session::Session(transport::UdpSocket socket, const Clock& clock,
                 transport::ThreadScheduling scheduling)
    : clock_(clock),
      socket_(std::move(socket)),
      local_(socket_.local_endpoint()),
      scheduling_(std::move(scheduling)),
      epoch_(clock.Now()),
      receive_buffers_(kReceiveBatch) {
  receive_slots_.resize(kReceiveBatch);
  for (size_t i = 0; i < kReceiveBatch; ++i) receive_slots_[i].buffer = receive_buffers_[i];
}

void Session::Expedite(PeerId id) {
  {
    std::lock_guard lock(urgent_mu_);
    urgent_.push_back(id);
  }
  socket_.Wake();
}

bool Session::SendUrgentNow(PeerId id) {
  // try_lock: the I/O thread holds mu_ for a whole turn (every due peer of the fleet); waiting
  // for it would block the caller longer than the wake-up this saves.
  std::unique_lock lock(mu_, std::try_to_lock);
  if (!lock.owns_lock() || stopping_) return false;
  auto it = peers_.find(id);
  if (it == peers_.end()) return false;
  Peer& p = it->second;
  if (p.outstanding) return true;  // it leaves on the reply (HandleDatagramLocked)
  const TimePoint planned_wake =
      timers_.empty() ? TimePoint::max() : timers_.front().due;  // what the I/O thread sleeps to
  ServicePeerLocked(p, clock_.Now());  // queues the telegram: the peer reports it urgent
  FlushLocked();                       // sendmmsg from this thread (UdpSocket is thread-safe)
  // The reply deadline may now come before the I/O thread's planned wake-up (a cycle longer
  // than the reply time-out): wake it so that the time-out is seen in time.
  const bool earlier = !timers_.empty() && timers_.front().due < planned_wake;
  lock.unlock();
  if (earlier) socket_.Wake();
  return true;
}

Session::~Session() { Stop(); }

void Session::Stop() {
  std::lock_guard stop_lock(stop_mu_);
  {
    std::lock_guard lock(mu_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  socket_.Shutdown();  // releases a blocked Receive at once
  if (thread_.joinable()) {
    thread_.join();
    log::Info("linudp_session_closed", log::Fields().Add("local", local_.ToString()));
  }
}

absl::StatusOr<PeerId> Session::Register(const PeerOptions& options, SessionPeer* peer) {
  if (peer == nullptr) return absl::InvalidArgumentError("linudp session: peer is null");
  if (options.cycle < std::chrono::milliseconds(1)) {
    return absl::InvalidArgumentError(absl::StrCat("drive '", options.name,
                                                   "'.linudp.cycle: ", options.cycle.count(),
                                                   " ms is below 1 ms (A-10)"));
  }
  if (options.reply_timeout <= std::chrono::milliseconds(0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "drive '", options.name, "'.linudp.reply_timeout: ", options.reply_timeout.count(),
        " ms must be positive"));
  }
  if (options.lost_after_timeouts < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "drive '", options.name, "'.linudp.lost_after_timeouts: ", options.lost_after_timeouts,
        " must be at least 1"));
  }
  HealthConfig health;
  health.down_after_failures = options.lost_after_timeouts;
  health.backoff_min = options.probe_backoff_min;
  health.backoff_max = options.probe_backoff_max;
  health.up_after = options.up_after;
  if (absl::Status s =
          ValidateHealthConfig(health, absl::StrCat("drive '", options.name, "'.health."));
      !s.ok()) {
    return s;
  }
  PeerId id;
  {
    std::lock_guard lock(mu_);
    if (stopping_) {
      return absl::FailedPreconditionError(
          absl::StrCat("linudp session ", local_.ToString(), ": stopped"));
    }
    if (auto it = by_remote_.find(options.remote); it != by_remote_.end()) {
      return absl::AlreadyExistsError(absl::StrCat(
          "drive '", options.name, "': linudp session ", local_.ToString(), " already serves ",
          options.remote.ToString(), " for drive '", it->second->options.name, "'"));
    }
    id = next_id_++;
    const TimePoint now = clock_.Now();
    Peer& p = peers_[id];
    p.id = id;
    p.options = options;
    p.peer = peer;
    p.health.emplace(health, clock_);
    p.next_send = now;
    p.period_start = now - (now - epoch_) % kGridTick;
    by_remote_.emplace(options.remote, &p);
    ArmLocked(p, now);
  }
  socket_.Wake();  // the loop recomputes its schedule and sends the first telegram
  log::Info("linudp_peer_registered", log::Fields()
                                          .Add("drive", options.name)
                                          .Add("local", local_.ToString())
                                          .Add("remote", options.remote.ToString()));
  return id;
}

void Session::Unregister(PeerId id) {
  std::lock_guard lock(mu_);
  auto it = peers_.find(id);
  if (it == peers_.end()) return;
  Add(counters_.total, it->second.counters);
  by_remote_.erase(it->second.options.remote);
  log::Info("linudp_peer_unregistered",
            log::Fields().Add("drive", it->second.options.name).Add("local", local_.ToString()));
  peers_.erase(it);
}

SessionCounters Session::counters() const {
  std::lock_guard lock(mu_);
  SessionCounters c = counters_;
  for (const auto& [id, p] : peers_) Add(c.total, p.counters);
  const transport::UdpSocketCounters s = socket_.counters();
  c.receive_errors = s.receive_errors;
  return c;
}

std::optional<ExchangeCounters> Session::peer_counters(PeerId id) const {
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

void Session::SetLinkLocked(Peer& p, LinkState to) {
  if (p.link == to) return;
  const LinkState from = p.link;
  p.link = to;
  log::Fields fields;
  fields.Add("drive", p.options.name)
      .Add("remote", p.options.remote.ToString())
      .Add("from", ToString(from))
      .Add("to", ToString(to));
  if (to == LinkState::kOffline) {
    // lost after lost_after_timeouts consecutive time-outs; the exchange keeps probing.
    fields.Add("timeouts", p.consecutive_timeouts);
    log::Warn("linudp_link", fields);
  } else {
    log::Info("linudp_link", fields);
  }
  p.peer->OnLinkChange(to);
}

void Session::RollPeriodsLocked(Peer& p, TimePoint now) {
  const Duration cycle = p.options.cycle;
  if (now < p.period_start + cycle) return;
  const auto ended = static_cast<uint64_t>((now - p.period_start) / cycle);
  p.counters.cycles += ended;
  p.counters.late_cycles += ended - (p.period_met ? 1 : 0);
  if (stall_until_ > stall_from_ && stall_until_ > p.period_start) {
    // Ended periods j = 0 .. ended-1 span [start + j*cycle, start + (j+1)*cycle); the late ones
    // (all but a met first one) that overlap the last stall are counted as stalled.
    const auto first =
        static_cast<uint64_t>(std::max<Duration::rep>(0, (stall_from_ - p.period_start) / cycle));
    const auto last = std::min<uint64_t>(
        ended - 1, static_cast<uint64_t>((stall_until_ - p.period_start - Duration(1)) / cycle));
    const uint64_t from = p.period_met ? std::max<uint64_t>(first, 1) : first;
    if (last >= from) p.counters.late_cycles_stalled += last - from + 1;
  }
  p.period_start += static_cast<int64_t>(ended) * cycle;
  p.period_met = false;
}

void Session::ArmLocked(Peer& p, TimePoint now) {
  // Idle: the next period's telegram. Outstanding: the reply deadline, or the period
  // start first when that comes earlier (a reply arriving later then sends at once).
  TimePoint due = p.next_send;
  // A DOWN drive is probed at its back-off (decision 1431); 0 ms keeps the cycle.
  if (p.health->state() == HealthState::kDown) due = std::max(due, p.health->next_probe());
  if (p.outstanding)
    due = p.next_send > now ? std::min(p.next_send, p.reply_deadline) : p.reply_deadline;
  if (p.armed && p.armed_due == due) return;
  p.armed = true;
  p.armed_due = due;
  timers_.push_back(Timer{due, p.id, ++p.timer_seq});
  std::push_heap(timers_.begin(), timers_.end(), Later<Timer, Timer>);
}

void Session::QueueSendLocked(Peer& p, TimePoint now) {
  RollPeriodsLocked(p, now);
  const Request request = p.peer->BuildRequest();
  Outgoing& out = outgoing_.emplace_back();
  out.peer = &p;
  out.size = EncodeRequestInto(request, out.bytes);
  ++p.counters.telegrams_sent;
  if (p.options.wire_trace && p.options.wire_trace->load(std::memory_order_relaxed)) {
    wire::Trace(p.options.name, "linmot", "tx",
                std::span<const uint8_t>(out.bytes.data(), out.size));
  }
  // Outstanding even after a send error: the time-out then feeds link supervision.
  p.outstanding = true;
  p.asked_response = request.response_definition & kRespDefinedMask;
  p.sent_request = RequestDefinitionOf(request);
  p.sent_at = now;
  p.reply_deadline = now + p.options.reply_timeout;
  // one exchange per cycle period; the next cyclic telegram leaves at the next period's
  // start on the fixed grid (or on the reply, if that comes later), never twice in one period.
  p.next_send = p.period_start + p.options.cycle;
}

void Session::FlushLocked() {
  if (outgoing_.empty()) return;
  outgoing_views_.clear();
  for (const Outgoing& o : outgoing_) {
    outgoing_views_.push_back(
        {o.peer->options.remote, std::span<const uint8_t>(o.bytes.data(), o.size)});
  }
  send_failed_.clear();
  absl::StatusOr<size_t> sent = socket_.SendBatch(outgoing_views_, &send_failed_);
  if (!sent.ok()) {
    for (Outgoing& o : outgoing_) ++o.peer->counters.send_errors;
    log::Debug("linudp_send_error",
               log::Fields().Add("local", local_.ToString()).Add("error", sent.status().message()));
  }
  for (size_t i : send_failed_) {
    ++outgoing_[i].peer->counters.send_errors;
    log::Debug("linudp_send_error", log::Fields().Add("drive", outgoing_[i].peer->options.name));
  }
  outgoing_.clear();
}

void Session::ServicePeerLocked(Peer& p, TimePoint now) {
  RollPeriodsLocked(p, now);
  if (p.outstanding && now >= p.reply_deadline) {
    // the request is given up; a reply arriving now counts as late.
    p.outstanding = false;
    ++p.counters.timeouts;
    ++p.consecutive_timeouts;
    p.peer->OnTimeout();
    // A-10 via the shared model (decision 1431): DOWN after lost_after_timeouts consecutive
    // time-outs; while DOWN each unanswered probe lengthens the probe back-off.
    if (p.health->RecordFailure("time-outs")) p.peer->OnHealthChange(p.health->info());
    if (p.health->state() == HealthState::kDown) SetLinkLocked(p, LinkState::kOffline);
  }
  // A-07 keeps one request outstanding per drive; the cycle paces the status exchange, an
  // urgent command leaves as soon as the line is free (decision 006), even to a DOWN drive (a
  // Stop is never held back); a DOWN drive's cyclic probe waits for its back-off.
  if (!p.outstanding &&
      ((now >= p.next_send && p.health->ProbeDue()) || p.peer->HasUrgentRequest())) {
    QueueSendLocked(p, now);
  }
  ArmLocked(p, now);
}

void Session::FireTimersLocked(TimePoint now) {
  while (!timers_.empty() && timers_.front().due <= now) {
    const Timer t = timers_.front();
    std::pop_heap(timers_.begin(), timers_.end(), Later<Timer, Timer>);
    timers_.pop_back();
    auto it = peers_.find(t.id);
    if (it == peers_.end() || it->second.timer_seq != t.seq) continue;  // unregistered or stale
    it->second.armed = false;
    ServicePeerLocked(it->second, now);
  }
}

void Session::TakeUrgentLocked(TimePoint now) {
  {
    std::lock_guard lock(urgent_mu_);
    if (urgent_.empty()) return;
    urgent_taken_.swap(urgent_);
  }
  for (PeerId id : urgent_taken_) {
    auto it = peers_.find(id);
    // An outstanding peer is asked again on its reply (HandleDatagramLocked).
    if (it != peers_.end() && !it->second.outstanding) ServicePeerLocked(it->second, now);
  }
  urgent_taken_.clear();
}

void Session::HandleDatagramLocked(const transport::DatagramSlot& d, TimePoint now) {
  const std::span<const uint8_t> bytes(d.buffer.data(), d.size);
  auto route = by_remote_.find(d.from);
  if (route == by_remote_.end()) {
    // A-07 routing by source ip:port; a stranger is counted and dropped.
    ++counters_.unknown_source;
    log::Debug("linudp_unknown_source", log::Fields()
                                            .Add("local", local_.ToString())
                                            .Add("from", d.from.ToString())
                                            .Add("bytes", d.size));
    return;
  }
  Peer& p = *route->second;
  if (p.options.wire_trace && p.options.wire_trace->load(std::memory_order_relaxed)) {
    wire::Trace(p.options.name, "linmot", "rx", bytes);
  }
  if (!p.outstanding) {
    ++p.counters.late;
    log::Debug("linudp_late", log::Fields().Add("drive", p.options.name).Add("bytes", d.size));
    return;
  }
  absl::StatusOr<Reply> reply = DecodeReply(bytes);
  if (!reply.ok()) {
    // shorter than its own layout; counted and dropped, the request stays outstanding.
    ++p.counters.malformed;
    log::Debug("linudp_malformed",
               log::Fields().Add("drive", p.options.name).Add("error", reply.status().message()));
    return;
  }
  const uint32_t missing = p.asked_response & ~reply->response_definition;
  if (missing != 0) {
    // a reply lacking a block we asked for is rejected.
    ++p.counters.malformed;
    log::Debug("linudp_malformed",
               log::Fields()
                   .Add("drive", p.options.name)
                   .Add("missing_response_bits", absl::StrFormat("0x%03X", missing)));
    return;
  }
  if ((reply->request_definition & kReqDefinedMask) != p.sent_request) {
    ++p.counters.header_mismatch;  // bytes 0-3 are logged, never checked
    log::Debug("linudp_header_mismatch",
               log::Fields()
                   .Add("drive", p.options.name)
                   .Add("sent", absl::StrFormat("0x%X", p.sent_request))
                   .Add("echo", absl::StrFormat("0x%X", reply->request_definition)));
  }
  p.outstanding = false;
  p.consecutive_timeouts = 0;
  ++p.counters.replies;
  RollPeriodsLocked(p, now);
  if (p.sent_at >= p.period_start) p.period_met = true;
  const Duration round_trip = now - p.sent_at;
  p.counters.last_round_trip_ms = std::chrono::duration<double, std::milli>(round_trip).count();
  wire::ObserveRoundTrip("linmot", p.options.name, round_trip);
  SetLinkLocked(p, LinkState::kOnline);
  if (p.health->RecordSuccess()) p.peer->OnHealthChange(p.health->info());
  p.peer->OnReply(*reply, now);
  // A reply after its period's end lets the next telegram leave at once; an urgent command
  // leaves as soon as the line is free (decision 006).
  if (now >= p.next_send || p.peer->HasUrgentRequest()) QueueSendLocked(p, now);
  ArmLocked(p, now);
}

void Session::NoteStallLocked(TimePoint from, TimePoint until) {
  ++counters_.io_stalls;
  counters_.io_stalled_ms += std::chrono::duration<double, std::milli>(until - from).count();
  stall_from_ = from;
  stall_until_ = until;
}

void Session::Run() {
  // Every wait of this loop is a timed ppoll to a grid tick; at the normal policy the default
  // 50 us slack would let the kernel defer each of them (decision 1311).
  transport::MinimiseTimerSlack();
  std::unique_lock lock(mu_);
  TimePoint woke = clock_.Now();
  Duration cpu_at_wait = transport::ThreadCpuTime();
  uint64_t switches_at_wake = transport::ThreadVoluntarySwitches();
  while (!stopping_) {
    TimePoint now = clock_.Now();
    TakeUrgentLocked(now);
    FireTimersLocked(now);
    FlushLocked();
    Duration wait = kIdleWait;
    const TimePoint wait_from = clock_.Now();
    // Decision 1312: the turn since the last wake-up took wall time the thread did not spend on
    // a CPU although it never blocked (a hypervisor or a higher priority held it off). Waiting
    // for a lock is a voluntary switch: the gateway's own contention is never called a stall.
    const Duration cpu_now = transport::ThreadCpuTime();
    if (const Duration off_cpu = (wait_from - woke) - (cpu_now - cpu_at_wait);
        off_cpu > kStallThreshold && transport::ThreadVoluntarySwitches() == switches_at_wake) {
      NoteStallLocked(woke, wait_from);
    }
    cpu_at_wait = cpu_now;
    if (!timers_.empty())
      wait = std::clamp(timers_.front().due - wait_from, Duration::zero(), kIdleWait);
    lock.unlock();
    absl::StatusOr<size_t> got = socket_.ReceiveBatch(receive_slots_, wait);
    // The wait ends by wait_from + wait at the latest (earlier for a datagram or a wake-up), so
    // waking later than that is a lower bound of how long the thread was held off the CPU. Taken
    // before the lock: a wait for mu_ belongs to the turn (and is a voluntary switch there).
    woke = clock_.Now();
    switches_at_wake = transport::ThreadVoluntarySwitches();
    lock.lock();
    if (stopping_) break;
    if (const TimePoint due = wait_from + wait; woke - due > kStallThreshold) {
      NoteStallLocked(due, woke);
    }
    now = clock_.Now();
    if (!got.ok()) {
      if (absl::IsCancelled(got.status())) break;  // Shutdown
      log::Warn("linudp_receive_error",
                log::Fields().Add("local", local_.ToString()).Add("error", got.status().message()));
      continue;
    }
    for (size_t i = 0; i < *got; ++i) HandleDatagramLocked(receive_slots_[i], now);
    FlushLocked();
  }
}

SessionPool& SessionPool::Instance() {
  static SessionPool* pool = new SessionPool();  // never destroyed: sessions may outlive main
  return *pool;
}

absl::StatusOr<std::shared_ptr<Session>> SessionPool::Acquire(
    const transport::Endpoint& local, const Clock& clock,
    const transport::ThreadScheduling& scheduling) {
  if (local.port == 0) return Session::Open(local, clock, scheduling);
  std::lock_guard lock(mu_);
  auto it = sessions_.find(local);
  if (it != sessions_.end()) {
    if (std::shared_ptr<Session> live = it->second.lock()) {
      // One I/O thread serves every drive of the endpoint; it cannot run at two
      // priorities, and taking either one silently would hide a configuration error.
      if (!(live->scheduling() == scheduling)) {
        return absl::FailedPreconditionError(absl::StrCat(
            "linudp session ", local.ToString(), " runs its I/O thread with ",
            live->scheduling().ToString(), ", this drive asks for ", scheduling.ToString(),
            ": drives sharing bind_host:master_port must give the same values"));
      }
      return live;
    }
    sessions_.erase(it);
  }
  auto opened = Session::Open(local, clock, scheduling);
  if (!opened.ok()) return opened.status();
  sessions_[local] = *opened;
  return *opened;
}

}  // namespace drivegw::linmot::linudp
