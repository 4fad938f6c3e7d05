// Pack: shared session + poll thread of one SIXpack/QUADpack (pack.h; decisions 1081, 1085, 1086).
#include "adapters/trinamic/pack.h"

#include <algorithm>
#include <condition_variable>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"

namespace drivegw::trinamic {
namespace {

using std::chrono::milliseconds;

// `$43` reset probe period (decision 1085): a reset is noticed within ~0.5 s.
constexpr milliseconds kResetProbePeriod{500};
// Motion words closer together than this share one `$43` (decision 1086).
constexpr milliseconds kMotionProbeAge{20};

std::string CanSpec(const CanBusConfig& c) {
  if (c.kind == CanBusConfig::Kind::kSocketCan) return absl::StrCat("socketcan:", c.interface);
  return absl::StrCat("udp:", c.group, ":", c.port);
}

// Process-wide registry: one Pack per controller (decision 1081).
struct Registry {
  std::mutex mu;
  std::condition_variable gone;  // an expired entry was erased (its Pack fully destroyed)
  std::map<std::string, std::weak_ptr<Pack>> packs;
};
Registry& TheRegistry() {
  static Registry* r = new Registry;  // never destroyed: Packs may outlive static destruction
  return *r;
}

// Same key, different transport settings: the second drive would silently use the first's.
absl::Status SameTransport(const TrinamicConfig& have, const TrinamicConfig& want,
                           const std::string& key) {
  auto conflict = [&](const std::string& field, const std::string& a, const std::string& b) {
    return absl::InvalidArgumentError(absl::StrCat("trinamic.", field, ": ", b, " conflicts with ",
                                                   a, " of another axis on ", key,
                                                   " (one controller, one transport)"));
  };
  if (have.serial && want.serial) {
    if (have.serial->baud != want.serial->baud) {
      return conflict("serial.baud", std::to_string(have.serial->baud),
                      std::to_string(want.serial->baud));
    }
    if (have.serial->rs485 != want.serial->rs485) {
      return conflict("serial.rs485", have.serial->rs485 ? "true" : "false",
                      want.serial->rs485 ? "true" : "false");
    }
    if (have.serial->turnaround != want.serial->turnaround) {
      return conflict("serial.turnaround", std::to_string(have.serial->turnaround.count()),
                      std::to_string(want.serial->turnaround.count()));
    }
  }
  if (have.response_address != want.response_address) {
    return conflict("response_address", std::to_string(have.response_address),
                    std::to_string(want.response_address));
  }
  if (have.axes != want.axes) {
    return conflict("axes", std::to_string(have.axes), std::to_string(want.axes));
  }
  if (have.reply_timeout != want.reply_timeout) {
    return conflict("reply_timeout", std::to_string(have.reply_timeout.count()),
                    std::to_string(want.reply_timeout.count()));
  }
  if (have.offline_after_misses != want.offline_after_misses) {
    return conflict("offline_after_misses", std::to_string(have.offline_after_misses),
                    std::to_string(want.offline_after_misses));
  }
  // One HealthModel per controller (decision 1431): its axes share the back-off.
  if (have.retry_min != want.retry_min) {
    return conflict("health.backoff_min_ms", std::to_string(have.retry_min.count()),
                    std::to_string(want.retry_min.count()));
  }
  if (have.retry_max != want.retry_max) {
    return conflict("health.backoff_max_ms", std::to_string(have.retry_max.count()),
                    std::to_string(want.retry_max.count()));
  }
  if (have.up_after != want.up_after) {
    return conflict("health.up_after_ms", std::to_string(have.up_after.count()),
                    std::to_string(want.up_after.count()));
  }
  return absl::OkStatus();
}

// CT-50, §3.1: on one line / bus a response address equal to another PACK's address would make
// its replies look like commands to that PACK (CAN: reply ID RA << 3 = its command ID).
absl::Status NoAddressClash(Registry& r, const TrinamicConfig& want) {
  const std::string where = Pack::KeyOf(want);
  const std::string line = where.substr(0, where.rfind('#'));
  for (const auto& [key, weak] : r.packs) {
    std::shared_ptr<Pack> p = weak.lock();
    if (!p || key.substr(0, key.rfind('#')) != line) continue;
    const TrinamicConfig& have = p->config();
    if (want.response_address == have.address) {
      return absl::InvalidArgumentError(absl::StrCat(
          "trinamic.response_address: ", std::to_string(want.response_address),
          " is the address of the controller ", key, " on the same line (CT-50, §3.1)"));
    }
    if (want.address == have.response_address) {
      return absl::InvalidArgumentError(
          absl::StrCat("trinamic.address: ", std::to_string(want.address),
                       " is the response address of ", key, " on the same line (CT-50, §3.1)"));
    }
  }
  return absl::OkStatus();
}

SessionOptions SessionOptionsOf(const TrinamicConfig& c) {
  SessionOptions o;
  o.address = c.address;
  o.response_address = c.response_address;
  o.offline_after_misses = c.offline_after_misses;
  o.retry_min = c.retry_min;
  o.retry_max = c.retry_max;
  o.up_after = c.up_after;
  o.probe_timeout = std::max(c.reply_timeout, milliseconds(50));
  // A reset PACK talks 19200 again (L273, L899, G-40): the probe falls back to it.
  if (c.serial) o.reset_baud = kResetBaud;
  return o;
}

}  // namespace

std::string Pack::KeyOf(const TrinamicConfig& config) {
  const std::string where = config.serial ? absl::StrCat("serial:", config.serial->device)
                            : config.can  ? absl::StrCat("can:", CanSpec(*config.can))
                                          : std::string("none");
  return absl::StrCat(where, "#", std::to_string(config.address));
}

absl::StatusOr<std::shared_ptr<Pack>> Pack::Acquire(const TrinamicConfig& config,
                                                    const std::string& owner) {
  if (config.serial.has_value() == config.can.has_value()) {
    return absl::InvalidArgumentError("trinamic: exactly one of serial / can must be set");
  }
  const std::string key = KeyOf(config);
  Registry& r = TheRegistry();
  std::unique_lock lock(r.mu);
  for (auto it = r.packs.find(key); it != r.packs.end(); it = r.packs.find(key)) {
    if (std::shared_ptr<Pack> p = it->second.lock()) {
      if (auto s = SameTransport(p->config(), config, key); !s.ok()) return s;
      return p;
    }
    // Expired: its Pack is still being destroyed and its session still holds the controller's
    // place on a shared serial line (decision 1471); a new session would be refused meanwhile.
    r.gone.wait(lock);
  }
  if (auto s = NoAddressClash(r, config); !s.ok()) return s;
  SessionOptions options = SessionOptionsOf(config);
  options.owner = owner;
  absl::StatusOr<std::shared_ptr<ControllerSession>> session;
  if (config.serial) {
    transport::SerialConfig sc;
    sc.device = config.serial->device;
    sc.baud = config.serial->baud;
    sc.duplex = config.serial->rs485 ? transport::SerialConfig::Duplex::kHalfRs485
                                     : transport::SerialConfig::Duplex::kFull;
    sc.turnaround = config.serial->rs485 ? config.serial->turnaround : std::chrono::microseconds(0);
    session = ControllerSession::OpenSerial(sc, options);
  } else {
    session = ControllerSession::OpenCan(*config.can, options);
  }
  if (!session.ok()) return session.status();
  std::shared_ptr<Pack> pack(new Pack(config, key, std::move(*session)));
  r.packs[key] = pack;
  return pack;
}

Pack::Pack(TrinamicConfig config, std::string key, std::shared_ptr<ControllerSession> session)
    : config_(std::move(config)), key_(std::move(key)), session_(std::move(session)) {
  observer_id_ = session_->AddObserver(this);
}

Pack::~Pack() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  session_->RemoveObserver(observer_id_);
  session_.reset();  // leaves the serial line before a successor may join it (decision 1471)
  Registry& r = TheRegistry();
  std::lock_guard lock(r.mu);
  if (auto it = r.packs.find(key_); it != r.packs.end() && it->second.expired()) {
    r.packs.erase(it);
  }
  r.gone.notify_all();
}

absl::Status Pack::Register(uint8_t axis, PackListener* listener, milliseconds poll_period) {
  std::thread old;
  {
    std::lock_guard lock(mu_);
    if (axes_.count(axis) != 0) {
      return absl::AlreadyExistsError(
          absl::StrCat(name(), ": motor ", std::to_string(axis), " already has a drive"));
    }
    Axis a;
    a.listener = listener;
    a.period = std::max(poll_period, milliseconds(1));
    a.next = SessionClock::now();
    axes_[axis] = a;
    if (!thread_.joinable() || stop_) {
      // A thread that was told to stop (last axis gone) is joined before a new one starts.
      old = std::move(thread_);
    }
  }
  if (old.joinable()) old.join();
  std::lock_guard lock(mu_);
  if (!thread_.joinable()) {
    stop_ = false;
    thread_ = std::thread([this] { Run(); });
  }
  cv_.notify_all();
  return absl::OkStatus();
}

void Pack::Unregister(uint8_t axis) {
  std::thread to_join;
  {
    // cb_mu_ first: no callback of this listener is running once we hold it.
    std::lock_guard cb(cb_mu_);
    std::lock_guard lock(mu_);
    axes_.erase(axis);
    if (axes_.empty()) {
      stop_ = true;
      if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) {
        to_join = std::move(thread_);
      }
    }
  }
  cv_.notify_all();
  if (to_join.joinable()) to_join.join();
}

std::string Pack::link_reason() const {
  std::lock_guard lock(mu_);
  return link_reason_;
}

std::map<uint8_t, AxisSample> Pack::samples() const {
  std::lock_guard lock(mu_);
  std::map<uint8_t, AxisSample> out;
  for (const auto& [n, a] : axes_) {
    if (a.last) out[n] = *a.last;
  }
  return out;
}

PackCounters Pack::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

void Pack::PollSoon(uint8_t axis) {
  {
    std::lock_guard lock(mu_);
    auto it = axes_.find(axis);
    if (it == axes_.end()) return;
    it->second.next = SessionClock::now();
    poke_ = true;
  }
  cv_.notify_all();
}

namespace {
// Words that start or redirect motion (§4.2): a freshly reset PACK must not see them before its
// parameters (CT-57).
bool IsMotionWord(Opcode op) {
  switch (op) {
    case Opcode::kStartReferenceSearch:
    case Opcode::kStartRamp:
    case Opcode::kActivatePi:
    case Opcode::kStartRotation:
    case Opcode::kSetTarget:
    case Opcode::kStartRampParallel:
    case Opcode::kInterpolate:
      return true;
    default:
      return false;
  }
}
}  // namespace

absl::StatusOr<std::optional<Reply>> Pack::Send(const Command& command, Deadline deadline) {
  // A link that is not ONLINE is probed first so that a reset that happened meanwhile is seen
  // (and re-applied) before this word (CT-57, decision 1086).
  if (session_->link_state() != LinkState::kOnline) {
    if (auto s = session_->Probe(); !s.ok()) return s;
  }
  const bool motion = IsMotionWord(command.opcode);
  uint64_t gen0 = 0;
  bool pending0 = false;
  {
    std::lock_guard lock(mu_);
    gen0 = reset_gen_;
    pending0 = reset_pending_;
  }
  if (motion) {
    // Every motion command gets its own `$43` first: a reset between two periodic polls would
    // otherwise run it with default parameters (decision 1086). Words of one command ($26 + $23,
    // $26... + $50) follow within kMotionProbeAge and share the probe.
    bool stale = false;
    {
      std::lock_guard lock(mu_);
      stale = SessionClock::now() - last_motion_probe_ > kMotionProbeAge;
    }
    if (stale) {
      ProbeReset();
      std::lock_guard lock(mu_);
      last_motion_probe_ = SessionClock::now();
    }
  }
  bool was_reset = false;
  {
    std::lock_guard cb(cb_mu_);
    if (auto s = EnsureApplied(); !s.ok()) return s;
    std::lock_guard lock(mu_);
    was_reset = pending0 || reset_gen_ != gen0;
  }
  if (motion && was_reset) {
    return absl::AbortedError(absl::StrCat(
        name(), ": ", SpecOf(command.opcode).name,
        " not sent: the controller was reset (L853); parameters re-applied, re-enable first"));
  }
  // cb_mu_ across the word and its absorb: two drives' configuration words reach the shadows in
  // the order they reached the PACK (decision 1098). It only delays the poll thread's dispatch.
  std::lock_guard cb(cb_mu_);
  return TransactWord(command, deadline);
}

absl::StatusOr<std::optional<Reply>> Pack::TransactWord(const Command& command, Deadline deadline) {
  absl::StatusOr<std::optional<Reply>> r = std::optional<Reply>();
  if (command.opcode == Opcode::kSetBaudRate) {
    // G-40: the PACK switches after the word; the session follows and verifies (CT-08).
    if (auto s = session_->ChangeBaud(command, deadline); !s.ok()) return s;
  } else {
    r = session_->Transact(command, deadline);
    if (!r.ok()) return r;
  }
  // Decisions 1072/1073/1098: every axis sees every configuration word (controller-wide values,
  // the `$10` pair); ParameterShadow::Absorb ignores the words of other motors. cb_mu_ (held
  // by every caller; recursive): no listener leaves while it is called.
  std::lock_guard cb(cb_mu_);
  std::vector<PackListener*> listeners;
  {
    std::lock_guard lock(mu_);
    for (auto& [n, a] : axes_) listeners.push_back(a.listener);
  }
  for (PackListener* l : listeners) l->AbsorbWord(command);
  return r;
}

absl::Status Pack::CheckShared(uint32_t id, int64_t value, int baud) {
  std::lock_guard cb(cb_mu_);  // no listener leaves meanwhile
  std::vector<PackListener*> listeners;
  {
    std::lock_guard lock(mu_);
    for (auto& [n, a] : axes_) listeners.push_back(a.listener);
  }
  for (const PackListener* l : listeners) {
    if (auto s = l->CheckShared(id, value, baud); !s.ok()) return s;
  }
  return absl::OkStatus();
}

std::optional<int> Pack::can_bit_rate() const {
  std::lock_guard lock(mu_);
  return can_bit_rate_;
}

void Pack::ReadJumpers() {
  Command q;
  q.address = config_.address;
  q.opcode = Opcode::kReadInputs;
  q.values = {0, config_.response_address, 0, 0, 0, 0, 0};
  auto r = session_->Transact(q, SessionClock::now() + config_.reply_timeout);
  std::lock_guard lock(mu_);
  if (!r.ok() || !r->has_value()) return;  // retried at the next connect
  // `$30` P4 bit 6 = JP1, bit 7 = JP2, 1 = set (L305, L790, G-19); §3.2 table.
  const int64_t p4 = (**r).values[3];
  const bool jp1 = (p4 & 0x40) != 0;
  const bool jp2 = (p4 & 0x80) != 0;
  can_bit_rate_ = jp1 && jp2 ? 1'000'000 : jp2 ? 500'000 : jp1 ? 125'000 : 250'000;
}

absl::Status Pack::SendTunnel(const std::vector<uint8_t>& data) {
  return session_->SendTunnel(data);
}

absl::Status Pack::Probe() {
  absl::Status s = session_->Probe();
  DispatchEvents();
  if (!s.ok()) return s;
  std::lock_guard cb(cb_mu_);
  return EnsureApplied();
}

// Controller-scoped words go out once per (re-)apply, with the first axis (decision 1086).
absl::Status Pack::EnsureApplied() {
  std::vector<std::pair<uint8_t, PackListener*>> todo;
  std::vector<PackListener*> notify;
  bool reset = false;
  bool controller_sent = false;
  {
    std::lock_guard lock(mu_);
    if (reset_pending_) {
      reset = true;
      reset_pending_ = false;
      for (auto& [n, a] : axes_) a.needs_apply = true;
      ++counters_.resets;
    }
    // Controller words already stand unless every axis needs its words (first apply or reset).
    controller_sent = std::any_of(axes_.begin(), axes_.end(),
                                  [](const auto& kv) { return !kv.second.needs_apply; });
    for (auto& [n, a] : axes_) {
      if (a.needs_apply) todo.emplace_back(n, a.listener);
      if (reset && a.applied_once) notify.push_back(a.listener);
    }
  }
  for (auto& [n, listener] : todo) {
    const std::vector<Command> words = listener->ApplyCommands(!controller_sent);
    for (const Command& w : words) {
      auto r = TransactWord(w, SessionClock::now() + config_.reply_timeout);
      if (!r.ok()) {
        std::lock_guard lock(mu_);
        if (reset) reset_pending_ = true;  // retry the whole re-apply
        return absl::Status(r.status().code(),
                            absl::StrCat("re-applying parameters of motor ", std::to_string(n),
                                         ": ", r.status().message()));
      }
      std::lock_guard lock(mu_);
      ++counters_.reapplied_words;
    }
    controller_sent = true;
    std::lock_guard lock(mu_);
    if (auto it = axes_.find(n); it != axes_.end()) {
      it->second.needs_apply = false;
      it->second.applied_once = true;
    }
  }
  if (reset && !notify.empty()) {
    log::Warn("trinamic_reset", log::Fields().Add("pack", key_).Add("axes", notify.size()));
    for (PackListener* listener : notify) listener->OnControllerReset();
  }
  return absl::OkStatus();
}

void Pack::OnLinkChange(LinkState state, const std::string& reason) noexcept {
  {
    std::lock_guard lock(mu_);
    link_reason_ = reason;
    events_.push_back(Event{Event::kLink, state, reason});
    if (state == LinkState::kOnline && config_.can) jumpers_pending_ = true;
  }
  cv_.notify_all();
}

void Pack::OnHealthChange(const HealthInfo& health) noexcept {
  {
    std::lock_guard lock(mu_);
    events_.push_back(Event{Event::kHealth, LinkState::kUnknown, "", health});
  }
  cv_.notify_all();
}

void Pack::OnControllerReset(uint8_t) noexcept {
  {
    std::lock_guard lock(mu_);
    reset_pending_ = true;
    ++reset_gen_;
  }
  cv_.notify_all();
}

void Pack::OnSessionEvent(SessionEvent event, const std::string& detail) noexcept {
  if (event != SessionEvent::kDuplicateAddress) return;
  {
    std::lock_guard lock(mu_);
    ++counters_.duplicates;
    events_.push_back(Event{Event::kDuplicate, LinkState::kUnknown, detail});
  }
  cv_.notify_all();
}

void Pack::DispatchEvents() {
  std::lock_guard cb(cb_mu_);
  std::vector<Event> events;
  std::vector<PackListener*> listeners;
  {
    std::lock_guard lock(mu_);
    events.swap(events_);
    for (auto& [n, a] : axes_) listeners.push_back(a.listener);
  }
  for (const Event& e : events) {
    for (PackListener* l : listeners) {
      if (e.kind == Event::kLink) {
        l->OnLink(e.state, e.text);
      } else if (e.kind == Event::kHealth) {
        l->OnHealth(e.health);
      } else {
        l->OnDuplicateAddress(e.text);
      }
    }
  }
}

void Pack::ProbeReset() {
  Command c;
  c.address = config_.address;
  c.opcode = Opcode::kUnitInformation;
  c.values[0] = config_.response_address;
  // The session's reset observer (OnControllerReset) flags the re-apply.
  (void)session_->Transact(c, SessionClock::now() + config_.reply_timeout);
  std::lock_guard lock(mu_);
  ++counters_.reset_probes;
}

void Pack::PollAxis(uint8_t axis) {
  bool velocity = false;
  {
    std::lock_guard lock(mu_);
    auto it = axes_.find(axis);
    if (it == axes_.end()) return;
    velocity = it->second.velocity_turn;
    it->second.velocity_turn = !velocity;
  }
  // `$21` every other round (decision 1085): halves the wire time of an idle poll.
  int vact = 0;
  bool have_vact = false;
  if (velocity) {
    Command q;
    q.address = config_.address;
    q.opcode = Opcode::kQueryVelocity;
    q.values = {axis, config_.response_address, 0, 0, 0, 0, 0};
    auto r = session_->Transact(q, SessionClock::now() + config_.reply_timeout);
    if (r.ok() && r->has_value() && (*r)->values[0] == axis) {
      vact = static_cast<int>((*r)->values[1]);
      have_vact = true;
    }
  }
  Command q;
  q.address = config_.address;
  q.opcode = Opcode::kQueryPosition;
  q.values = {axis, config_.response_address, 0, 0, 0, 0, 0};
  const SessionClock::time_point sent = SessionClock::now();
  auto r = session_->Transact(q, sent + config_.reply_timeout);
  AxisSample sample;
  PackListener* listener = nullptr;
  {
    std::lock_guard lock(mu_);
    auto it = axes_.find(axis);
    if (it == axes_.end()) return;
    if (have_vact) {
      it->second.vact = vact;
      ++counters_.velocity_polls;
    }
    if (!r.ok() || !r->has_value() || (*r)->values[0] != axis) {
      ++counters_.poll_failures;
      return;
    }
    ++counters_.polls;
    const Reply& rep = **r;
    sample.posact = static_cast<int32_t>(rep.values[1]);
    sample.action = static_cast<uint8_t>(rep.values[2]);
    sample.stop_flag = (rep.values[3] & 1) != 0;
    // An inactive motor stands: a `$21` from the previous round would be stale.
    sample.vact = sample.action == 0 ? 0 : it->second.vact;
    sample.sent = sent;
    it->second.last = sample;
    listener = it->second.listener;
  }
  DispatchEvents();
  std::lock_guard cb(cb_mu_);
  {
    std::lock_guard lock(mu_);
    if (axes_.count(axis) == 0) return;  // unregistered meanwhile
  }
  listener->OnSample(sample);
}

void Pack::Run() {
  std::unique_lock lock(mu_);
  next_reset_probe_ = SessionClock::now();
  while (!stop_) {
    const bool apply =
        reset_pending_ || std::any_of(axes_.begin(), axes_.end(),
                                      [](const auto& kv) { return kv.second.needs_apply; });
    const bool events = !events_.empty();
    if (events || (apply && session_->link_state() == LinkState::kOnline)) {
      lock.unlock();
      DispatchEvents();
      absl::Status applied = absl::OkStatus();
      if (apply && session_->link_state() == LinkState::kOnline) {
        std::lock_guard cb(cb_mu_);
        applied = EnsureApplied();  // a failure leaves the flags set: retried
      }
      lock.lock();
      if (stop_) break;
      if (!applied.ok()) {
        // Not faster than every 50 ms (the words failed on an ONLINE link: I/O trouble).
        cv_.wait_for(lock, milliseconds(50), [&] { return stop_; });
      }
    }
    if (jumpers_pending_ && session_->link_state() == LinkState::kOnline) {
      jumpers_pending_ = false;  // a failed read waits for the next connect
      lock.unlock();
      ReadJumpers();  // CT-20: once per connect
      lock.lock();
      if (stop_) break;
    }
    // While OFFLINE the polls below reconnect through the session's probe and back-off.
    // Next due: the reset probe or the earliest axis.
    SessionClock::time_point due = next_reset_probe_;
    std::optional<uint8_t> axis;
    for (const auto& [n, a] : axes_) {
      if (a.next < due) {
        due = a.next;
        axis = n;
      }
    }
    const auto now = SessionClock::now();
    if (due > now) {
      cv_.wait_until(lock, due, [&] {
        return stop_ || poke_ || !events_.empty() ||
               (reset_pending_ && session_->link_state() == LinkState::kOnline);
      });
      poke_ = false;
      continue;  // re-evaluate (PollSoon may have moved a due time)
    }
    if (axis) {
      auto& a = axes_[*axis];
      a.next = now + a.period;
      lock.unlock();
      PollAxis(*axis);
    } else {
      next_reset_probe_ = now + kResetProbePeriod;
      lock.unlock();
      ProbeReset();
    }
    lock.lock();
  }
}

}  // namespace drivegw::trinamic
