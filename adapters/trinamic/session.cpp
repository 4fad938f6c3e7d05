// Trinamic controller session: serial and CAN links plus the shared serialised Transact logic.
// Reference: shared/protocols/trinamic-sixpack.md §2.3-2.6, §3.1, §3.4, §4.2 $43.
#include "adapters/trinamic/session.h"

#include <algorithm>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "adapters/core/wire_observer.h"
#include "adapters/transport/can_frame.h"
#include "adapters/trinamic/serial_line.h"

namespace drivegw::trinamic {
namespace {

using std::chrono::duration_cast;
using std::chrono::microseconds;
using std::chrono::milliseconds;
using std::chrono::nanoseconds;

std::string Hex(uint8_t b) {
  static const char* kDigits = "0123456789ABCDEF";
  return std::string("$") + kDigits[b >> 4] + kDigits[b & 15];
}

nanoseconds Remaining(Deadline deadline) {
  auto left = deadline - SessionClock::now();
  return left > nanoseconds(0) ? duration_cast<nanoseconds>(left) : nanoseconds(0);
}

void Add(SessionCounters& to, const SessionCounters& d) {
  to.requests += d.requests;
  to.replies += d.replies;
  to.timeouts += d.timeouts;
  to.garbage += d.garbage;
  to.resyncs += d.resyncs;
  to.stray_zeros += d.stray_zeros;
  to.unsolicited += d.unsolicited;
  to.duplicate_replies += d.duplicate_replies;
  to.resets_seen += d.resets_seen;
  to.probes += d.probes;
  to.probe_failures += d.probe_failures;
  to.offline_events += d.offline_events;
  to.io_errors += d.io_errors;
  to.wrong_address += d.wrong_address;
}

// Serial link (§2): 9-byte words, R8/R9 replies detected at connect (G-01, decision 1051), on a
// line that other controllers may share (decision 1471): every call runs under the line's lock
// (ControllerSession takes LockLine() around each transaction).
class SerialLink final : public SessionLink {
 public:
  SerialLink(std::shared_ptr<SerialLine> line, uint8_t address, milliseconds break_duration)
      : line_(std::move(line)), address_(address), break_duration_(break_duration) {}
  ~SerialLink() override { line_->Detach(address_); }

  std::string Name() const override { return "serial " + line_->device(); }

  std::unique_lock<std::mutex> LockLine() override { return line_->Lock(); }
  SessionClock::time_point LineWordEnd() const override { return line_->last_word_end(); }
  void SetLineWordEnd(SessionClock::time_point t) override { line_->set_last_word_end(t); }
  std::vector<std::string> Neighbours() const override { return line_->Neighbours(address_); }

  absl::Status Open() override { return line_->Open(); }
  void Close() override {
    line_->Close();  // every member's next word reopens it (Send)
    framing_.reset();
  }

  size_t Drain(uint64_t& stray_zeros) override {
    transport::SerialPort* port = line_->port();
    if (!port) return 0;
    auto bytes = port->ReadAvailable(nanoseconds(0));
    if (!bytes.ok()) return 0;
    size_t dropped = 0;
    for (uint8_t b : *bytes) {
      if (b == 0) {
        ++stray_zeros;
      } else {
        ++dropped;
      }
    }
    return dropped;
  }

  absl::Status Send(const Command& command) override {
    // Another member's transport failure closed the line: it reopens for whoever talks next.
    if (auto s = line_->Open(); !s.ok()) return s;
    auto bytes = EncodeCommand(command);
    if (!bytes.ok()) return bytes.status();
    return line_->port()->Write(*bytes);
  }

  absl::StatusOr<Reply> Receive(const Command& command, uint8_t ra, Deadline deadline, bool detect,
                                SessionCounters& c) override {
    transport::SerialPort* port = line_->port();
    if (!port) return absl::UnavailableError(Name() + ": not open");
    const uint8_t op = static_cast<uint8_t>(command.opcode);
    uint8_t first = 0;
    for (;;) {
      // First byte: 00 bytes after a reset are discarded (§2.4, L228, L902).
      auto b = port->ReadExactly(1, Remaining(deadline));
      if (!b.ok()) return b.status();
      if ((*b)[0] == 0) {
        ++c.stray_zeros;
        continue;
      }
      first = (*b)[0];
      // R9 (§2.4): a reply starting with the RA of another controller on this line is that
      // controller's late reply (after its time-out): counted, its word dropped, ours awaited.
      // Under R8 the first byte is an opcode, never a valid RA (§2.4), so this cannot misfire.
      if (first != ra && line_->MemberWithResponseAddress(first, address_)) {
        ++c.wrong_address;
        auto rest = port->ReadExactly(ReplySize(ReplyFraming::kR9) - 1, Remaining(deadline));
        if (!rest.ok()) {
          Resync(c);
          return rest.status();
        }
        continue;
      }
      break;
    }
    if (detect) {
      auto f = DetectReplyFraming(first, ra);
      if (!f.ok())
        return Garbage(c, absl::StrCat("first reply byte ", Hex(first), " is neither RA ", Hex(ra),
                                       " nor a reply opcode"));
      framing_ = *f;
    } else if (!framing_) {
      return absl::FailedPreconditionError(Name() + ": reply framing not detected");
    }
    const uint8_t expected = *framing_ == ReplyFraming::kR9 ? ra : op;
    if (first != expected) {
      return Garbage(c,
                     absl::StrCat("first reply byte ", Hex(first), ", expected ", Hex(expected)));
    }
    std::vector<uint8_t> bytes{first};
    auto rest = port->ReadExactly(ReplySize(*framing_) - 1, Remaining(deadline));
    if (!rest.ok()) {
      // Half a word on the line: resynchronise before the next request (§2.6, L279).
      Resync(c);
      auto partial = transport::PartialReadBytes(rest.status());
      return absl::Status(rest.status().code(),
                          absl::StrCat(std::string(rest.status().message()), " (",
                                       std::to_string(partial.size() + 1), " reply bytes)"));
    }
    bytes.insert(bytes.end(), rest->begin(), rest->end());
    auto reply = DecodeReply(bytes, *framing_);
    if (!reply.ok()) return Garbage(c, std::string(reply.status().message()));
    if (reply->opcode != command.opcode) {
      return Garbage(c, absl::StrCat("reply opcode ", Hex(static_cast<uint8_t>(reply->opcode))));
    }
    if (*framing_ == ReplyFraming::kR8) reply->response_address = ra;
    last_first_byte_ = first;
    return *reply;
  }

  Extra AfterReply(microseconds window, SessionCounters& c) override {
    transport::SerialPort* port = line_->port();
    if (!port) return Extra::kNone;
    auto extra = port->ReadAvailable(window);
    if (!extra.ok() || extra->empty()) return Extra::kNone;
    auto first = std::find_if(extra->begin(), extra->end(), [](uint8_t b) { return b != 0; });
    c.stray_zeros += static_cast<uint64_t>(first - extra->begin());
    if (first == extra->end()) return Extra::kNone;
    (void)port->Flush();
    ++c.resyncs;
    // A second reply starts like the first one (RA under R9, the opcode under R8).
    if (*first == last_first_byte_) return Extra::kDuplicate;
    if (line_->MemberWithResponseAddress(*first, address_)) {
      ++c.wrong_address;  // a neighbour's late reply (R9 names its RA), not ours twice
      return Extra::kNone;
    }
    ++c.garbage;
    return Extra::kGarbage;
  }

  std::optional<ReplyFraming> framing() const override { return framing_; }

  std::optional<int> baud() const override { return line_->baud(); }
  absl::Status CheckBaudChange(int baud) const override {
    return line_->CheckRateChange(baud, address_);
  }
  absl::Status SetBaud(int baud) override { return line_->SetBaud(baud, address_); }

 private:
  absl::Status Garbage(SessionCounters& c, const std::string& what) {
    ++c.garbage;
    Resync(c);
    return absl::DataLossError(what);
  }
  // Flush, break, flush (§2.3 L279: a break aborts a partial word; §2.6).
  void Resync(SessionCounters& c) {
    transport::SerialPort* port = line_->port();
    if (!port) return;
    ++c.resyncs;
    (void)port->Flush();
    (void)port->SendBreak(break_duration_);
    (void)port->Flush();
  }

  std::shared_ptr<SerialLine> line_;
  const uint8_t address_;
  milliseconds break_duration_;
  std::optional<ReplyFraming> framing_;
  uint8_t last_first_byte_ = 0;
};

// CAN link (§3.1): command ID A << 3, reply ID RA << 3, 8 data bytes.
class CanLink final : public SessionLink {
 public:
  CanLink(std::unique_ptr<transport::CanChannel> channel, uint32_t reply_id)
      : channel_(std::move(channel)), reply_id_(reply_id) {
    // Only our reply identifier RA << 3 (§3.1, L291); other nodes' traffic stays in the kernel.
    const transport::CanFilter filter{reply_id, transport::kCanStandardIdMax, false};
    (void)channel_->SetFilters(std::span<const transport::CanFilter>(&filter, 1));
  }

  std::string Name() const override { return "can " + channel_->name(); }
  absl::Status Open() override { return absl::OkStatus(); }
  void Close() override {}

  size_t Drain(uint64_t&) override {
    size_t n = 0;
    for (;;) {
      auto f = channel_->Receive(nanoseconds(0));
      if (!f.ok() || !f->has_value()) return n;
      if (IsReply(**f)) ++n;
    }
  }

  absl::Status Send(const Command& command) override {
    auto frame = EncodeCommandCan(command);
    if (!frame.ok()) return frame.status();
    return channel_->Send(transport::MakeCanFrame(frame->id, frame->data));
  }

  absl::StatusOr<Reply> Receive(const Command& command, uint8_t ra, Deadline deadline, bool,
                                SessionCounters& c) override {
    (void)ra;  // fixed at construction: reply_id_
    for (;;) {
      auto left = Remaining(deadline);
      if (left <= nanoseconds(0)) return absl::DeadlineExceededError("no reply frame");
      auto f = channel_->Receive(left);
      if (!f.ok()) return f.status();
      if (!f->has_value()) continue;
      if (!IsReply(**f)) continue;  // other nodes' traffic
      auto reply = Decode(**f);
      if (!reply.ok() || reply->opcode != command.opcode) {
        ++c.garbage;  // a late reply to an earlier query or a bad frame: dropped (§2.6)
        continue;
      }
      return *reply;
    }
  }

  absl::Status SendCanFrame(uint16_t id, const std::vector<uint8_t>& data) override {
    return channel_->Send(transport::MakeCanFrame(id, data));
  }

  Extra AfterReply(microseconds window, SessionCounters&) override {
    const Deadline end = SessionClock::now() + window;
    for (;;) {
      auto left = Remaining(end);
      if (left <= nanoseconds(0)) return Extra::kNone;
      auto f = channel_->Receive(left);
      if (!f.ok()) return Extra::kNone;
      if (f->has_value() && IsReply(**f)) return Extra::kDuplicate;
    }
  }

 private:
  bool IsReply(const transport::CanFrame& f) const {
    return !f.extended && !f.rtr && !f.error && f.id == reply_id_;
  }
  static absl::StatusOr<Reply> Decode(const transport::CanFrame& f) {
    CanFrame tf;
    tf.id = static_cast<uint16_t>(f.id);
    tf.dlc = f.dlc;
    tf.data = f.data;
    return DecodeReplyCan(tf);
  }

  std::unique_ptr<transport::CanChannel> channel_;
  const uint32_t reply_id_;
};

}  // namespace

const char* ToString(LinkState state) {
  switch (state) {
    case LinkState::kUnknown:
      return "UNKNOWN";
    case LinkState::kOnline:
      return "ONLINE";
    case LinkState::kOffline:
      return "OFFLINE";
  }
  return "?";
}

const char* ToString(SessionEvent event) {
  switch (event) {
    case SessionEvent::kGarbage:
      return "garbage";
    case SessionEvent::kDuplicateAddress:
      return "duplicate_address";
    case SessionEvent::kIoError:
      return "io_error";
  }
  return "?";
}

absl::StatusOr<std::shared_ptr<ControllerSession>> ControllerSession::OpenSerial(
    const transport::SerialConfig& config, const SessionOptions& options) {
  if (auto s = transport::ValidateSerialConfig(config); !s.ok()) return s;
  // One line object per device, shared with the other controllers on it (decision 1471).
  auto line = SerialLine::Attach(
      config, LineMember{options.address, options.response_address, options.owner});
  if (!line.ok()) return line.status();
  return Open(
      std::make_unique<SerialLink>(*std::move(line), options.address, options.break_duration),
      options);
}

absl::StatusOr<std::shared_ptr<ControllerSession>> ControllerSession::OpenCan(
    const CanBusConfig& bus, const SessionOptions& options) {
  auto channel = transport::OpenCanChannel(bus);
  if (!channel.ok()) return channel.status();
  return OpenCan(std::move(*channel), options);
}

absl::StatusOr<std::shared_ptr<ControllerSession>> ControllerSession::OpenCan(
    std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options) {
  if (!channel) return absl::InvalidArgumentError("trinamic can: no channel");
  auto reply_id = ReplyCanId(options.response_address);
  if (!reply_id.ok()) return reply_id.status();
  return Open(std::make_unique<CanLink>(std::move(channel), *reply_id), options);
}

absl::StatusOr<std::shared_ptr<ControllerSession>> ControllerSession::Open(
    std::unique_ptr<SessionLink> link, const SessionOptions& options) {
  if (options.address == 0) {
    return absl::InvalidArgumentError("trinamic session.address: 0 is not a unit address (1..255)");
  }
  if (auto s = ValidateResponseAddress(options.response_address); !s.ok()) return s;
  if (options.response_address == options.address) {
    return absl::InvalidArgumentError(
        "trinamic session.response_address: equals the controller address (§2.4)");
  }
  if (options.offline_after_misses < 1) {
    return absl::InvalidArgumentError("trinamic session.offline_after_misses: must be >= 1");
  }
  if (auto s = ValidateHealthConfig(HealthConfig{options.offline_after_misses, options.retry_min,
                                                 options.retry_max, options.up_after},
                                    "trinamic session.health.");
      !s.ok()) {
    return s;
  }
  {
    auto line = link->LockLine();
    if (auto s = link->Open(); !s.ok()) return s;
  }
  return std::shared_ptr<ControllerSession>(new ControllerSession(std::move(link), options));
}

ControllerSession::ControllerSession(std::unique_ptr<SessionLink> link,
                                     const SessionOptions& options)
    : options_(options),
      link_(std::move(link)),
      name_(absl::StrCat("trinamic ", link_->Name(), " address ", std::to_string(options.address))),
      health_(HealthConfig{options.offline_after_misses, options.retry_min, options.retry_max,
                           options.up_after}),
      baud_(link_->baud()) {
  health_info_ = health_.info();
}

int ControllerSession::AddObserver(SessionObserver* observer) {
  std::lock_guard<std::mutex> lock(observers_mutex_);
  observers_[next_observer_id_] = observer;
  return next_observer_id_++;
}

void ControllerSession::RemoveObserver(int id) {
  std::lock_guard<std::mutex> lock(observers_mutex_);
  observers_.erase(id);
}

LinkState ControllerSession::link_state() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return state_;
}

HealthInfo ControllerSession::health() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return health_info_;
}

std::chrono::milliseconds ControllerSession::probe_backoff() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return backoff_mirror_;
}

void ControllerSession::PublishHealth() {
  const HealthInfo info = health_.info();
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    backoff_mirror_ = health_.backoff();
    if (health_info_ == info) return;
    health_info_ = info;
  }
  std::lock_guard<std::mutex> lock(observers_mutex_);
  for (auto& [id, o] : observers_) o->OnHealthChange(info);
}

std::optional<ReplyFraming> ControllerSession::framing() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return state_ == LinkState::kOnline ? link_->framing() : std::nullopt;
}

SessionCounters ControllerSession::counters() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return counters_;
}

std::string ControllerSession::Where(const Command& command) const {
  return absl::StrCat(name_, ": ", SpecOf(command.opcode).name);
}

void ControllerSession::SetState(LinkState state, const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    if (state_ == state) return;
    state_ = state;
    if (state == LinkState::kOffline) ++counters_.offline_events;
  }
  std::lock_guard<std::mutex> lock(observers_mutex_);
  for (auto& [id, o] : observers_) o->OnLinkChange(state, reason);
}

void ControllerSession::Emit(SessionEvent event, const std::string& detail) {
  std::lock_guard<std::mutex> lock(observers_mutex_);
  for (auto& [id, o] : observers_) o->OnSessionEvent(event, detail);
}

void ControllerSession::CheckReset(const Reply& reply) {
  // $43 reply P1 = reset flag, 1 at the first read-out after a reset (§4.2 $43, L853).
  if (reply.opcode != Opcode::kUnitInformation || reply.values[1] == 0) return;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    ++counters_.resets_seen;
  }
  std::lock_guard<std::mutex> lock(observers_mutex_);
  for (auto& [id, o] : observers_) o->OnControllerReset(options_.address);
}

void ControllerSession::Miss(const std::string& reason) {
  // Decision 1054 via the shared model (1431): OFFLINE (DOWN) after offline_after_misses
  // consecutive misses; the model starts the probe back-off at retry_min.
  health_.RecordFailure(absl::StrCat("misses, last: ", reason));
  PublishHealth();
  if (health_.state() == HealthState::kDown) SetState(LinkState::kOffline, health_.info().reason);
}

absl::StatusOr<Reply> ControllerSession::Exchange(const Command& command, Deadline deadline,
                                                  bool detect) {
  SessionCounters d;
  // §2.5 [P]: at least command_gap after the end of the previous word on the line (L303), ours
  // or a neighbour's (decision 1471).
  std::this_thread::sleep_until(std::max(last_word_end_, link_->LineWordEnd()) +
                                options_.command_gap);
  // Late replies or garbage pending now would be taken for this request's reply: dropped.
  d.unsolicited += link_->Drain(d.stray_zeros);
  ++d.requests;
  std::string traced;
  if (tracing_.load(std::memory_order_relaxed)) {
    std::lock_guard<std::mutex> lock(state_mutex_);
    traced = absl::StrJoin(traced_drives_, ",");
  }
  if (!traced.empty()) {
    if (auto bytes = EncodeCommand(command); bytes.ok()) {
      wire::Trace(traced, "trinamic", "tx", *bytes, SpecOf(command.opcode).name);
    }
  }
  const Deadline sent_at = SessionClock::now();
  absl::Status sent = link_->Send(command);
  absl::StatusOr<Reply> reply = absl::UnknownError("not sent");
  bool duplicate = false;
  bool garbage_after = false;
  if (!sent.ok()) {
    reply = sent;
  } else if (!SpecOf(command.opcode).has_reply) {
    reply = absl::NotFoundError("");  // silent command
  } else {
    reply = link_->Receive(command, options_.response_address, deadline, detect, d);
    if (reply.ok()) {
      ++d.replies;
      wire::ObserveRoundTrip("trinamic", name_, SessionClock::now() - sent_at);
      if (!traced.empty()) {
        auto bytes = EncodeReply(*reply, link_->framing().value_or(ReplyFraming::kR8));
        if (bytes.ok()) wire::Trace(traced, "trinamic", "rx", *bytes);
      }
      const auto extra = link_->AfterReply(options_.duplicate_window, d);
      duplicate = extra == SessionLink::Extra::kDuplicate;
      if (duplicate) ++d.duplicate_replies;
      if (extra == SessionLink::Extra::kGarbage) garbage_after = true;
    } else if (reply.status().code() == absl::StatusCode::kDeadlineExceeded) {
      ++d.timeouts;
    }
  }
  last_word_end_ = SessionClock::now();
  link_->SetLineWordEnd(last_word_end_);
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    Add(counters_, d);
  }
  if (duplicate) {
    std::string what =
        absl::StrCat(Where(command), ": a second controller answered with the same address");
    Emit(SessionEvent::kDuplicateAddress, what);
    return absl::FailedPreconditionError(what);
  }
  if (garbage_after) {
    Emit(SessionEvent::kGarbage, absl::StrCat(Where(command), ": bytes after the reply, flushed"));
  }
  return reply;
}

absl::Status ControllerSession::ProbeLocked() {
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    ++counters_.probes;
  }
  Command probe;
  probe.address = options_.address;
  probe.opcode = Opcode::kUnitInformation;
  probe.values[0] = options_.response_address;
  absl::Status opened = link_->Open();
  absl::StatusOr<Reply> reply =
      opened.ok() ? Exchange(probe, SessionClock::now() + options_.probe_timeout, /*detect=*/true)
                  : absl::StatusOr<Reply>(opened);
  const std::optional<int> rate = link_->baud();
  // Not on a shared line: the other PACKs there would lose the line rate meanwhile (1471).
  if (!reply.ok() && opened.ok() && options_.reset_baud && rate && *rate != *options_.reset_baud &&
      link_->Neighbours().empty()) {
    // G-40, L273, L899: a PACK that was reset (power cycle, `$CC`) talks 19200 again and ignores
    // words at our rate. One probe at the reset rate; its reset flag then re-applies `$40`.
    if (SetBaudLocked(*options_.reset_baud).ok()) {
      reply = Exchange(probe, SessionClock::now() + options_.probe_timeout, /*detect=*/true);
      if (!reply.ok()) (void)SetBaudLocked(*rate);
    }
  }
  if (!reply.ok()) {
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      ++counters_.probe_failures;
    }
    std::string why =
        absl::StrCat(Where(probe), ": probe failed: ", std::string(reply.status().message()));
    // A failed probe: DOWN at once when not yet (the old OFFLINE on a failed connect), else the
    // back-off doubles up to retry_max (decision 1431).
    if (health_.state() == HealthState::kDown) {
      health_.RecordFailure("probe failures");
    } else {
      health_.ForceDown(why);
    }
    PublishHealth();
    SetState(LinkState::kOffline, why);
    return absl::UnavailableError(why);
  }
  health_.RecordSuccess();
  PublishHealth();
  SetState(LinkState::kOnline, "unit information answered");
  CheckReset(*reply);
  return absl::OkStatus();
}

absl::Status ControllerSession::Probe() {
  std::lock_guard<std::mutex> lock(io_mutex_);
  auto line = link_->LockLine();
  return ProbeLocked();
}

absl::Status ControllerSession::SendTunnel(const std::vector<uint8_t>& data) {
  if (data.empty() || data.size() > 8) {
    return absl::InvalidArgumentError(absl::StrCat(name_, ": rs232 tunnel: ", data.size(),
                                                   " bytes, a frame carries 1..8 (L315)"));
  }
  auto id = TunnelTransmitCanId(options_.address);
  if (!id.ok()) return id.status();
  std::lock_guard<std::mutex> lock(io_mutex_);
  auto line = link_->LockLine();
  std::this_thread::sleep_until(last_word_end_ + options_.command_gap);
  absl::Status s = link_->SendCanFrame(*id, data);
  last_word_end_ = SessionClock::now();
  if (!s.ok()) return absl::Status(s.code(), absl::StrCat(name_, ": rs232 tunnel: ", s.message()));
  std::lock_guard<std::mutex> l(state_mutex_);
  ++counters_.requests;
  return absl::OkStatus();
}

void ControllerSession::SetWireTrace(const std::string& drive, bool on) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (on) {
    traced_drives_.insert(drive);
  } else {
    traced_drives_.erase(drive);
  }
  tracing_.store(!traced_drives_.empty());
}

absl::StatusOr<std::optional<Reply>> ControllerSession::Transact(const Command& command,
                                                                 Deadline deadline) {
  if (command.address != options_.address) {
    return absl::InvalidArgumentError(
        absl::StrCat(Where(command), ": command for address ", std::to_string(command.address)));
  }
  if (auto s = ValidateCommand(command); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(io_mutex_);
  // A DOWN controller before its back-off answers without touching the line: a dead PACK on a
  // shared line costs the others nothing between its probes (decision 1471).
  if (link_state() == LinkState::kOffline && !health_.ProbeDue()) {
    return absl::UnavailableError(absl::StrCat(Where(command), ": controller OFFLINE"));
  }
  auto line = LockLine(deadline);
  return TransactLocked(command, deadline);
}

std::unique_lock<std::mutex> ControllerSession::LockLine(Deadline& deadline) {
  const Deadline before = SessionClock::now();
  auto line = link_->LockLine();
  // The reply time-out runs from when the word can go out: a neighbour's transaction (at most
  // its probe time-out) on a shared line is no miss of this controller (decision 1471).
  deadline += SessionClock::now() - before;
  return line;
}

absl::StatusOr<std::optional<Reply>> ControllerSession::TransactLocked(const Command& command,
                                                                       Deadline deadline) {
  if (link_state() != LinkState::kOnline) {
    if (link_state() == LinkState::kOffline && !health_.ProbeDue()) {
      return absl::UnavailableError(absl::StrCat(Where(command), ": controller OFFLINE"));
    }
    if (auto s = ProbeLocked(); !s.ok()) return s;
  }
  auto reply = Exchange(command, deadline, /*detect=*/false);
  if (reply.ok()) {
    health_.RecordSuccess();
    PublishHealth();
    CheckReset(*reply);
    return std::optional<Reply>(*reply);
  }
  const absl::Status& s = reply.status();
  switch (s.code()) {
    case absl::StatusCode::kNotFound:
      if (command.opcode == Opcode::kHardwareReset) {
        // $CC: the PACK boots ca. 1 s (L900) and then reports the reset flag (L853, G-43).
        health_.ForceDown("hardware reset ($CC) sent");
        health_.ProbeNotBefore(SteadyClock::Instance().Now() + options_.reset_boot_time);
        PublishHealth();
        SetState(LinkState::kOffline, "hardware reset ($CC) sent");
      }
      return std::optional<Reply>();  // silent command sent
    case absl::StatusCode::kFailedPrecondition:
      return s;  // duplicate address: reported, the link itself answered
    case absl::StatusCode::kDeadlineExceeded: {
      std::string what =
          absl::StrCat(Where(command), ": no reply (", std::string(s.message()), ")");
      Miss(what);
      return absl::DeadlineExceededError(what);
    }
    case absl::StatusCode::kDataLoss: {
      std::string what = absl::StrCat(Where(command), ": garbage on the line, resynchronised (",
                                      std::string(s.message()), ")");
      Emit(SessionEvent::kGarbage, what);
      Miss(what);
      return absl::UnavailableError(what);
    }
    default: {
      std::string what = absl::StrCat(Where(command), ": ", std::string(s.message()));
      {
        std::lock_guard<std::mutex> l(state_mutex_);
        ++counters_.io_errors;
      }
      Emit(SessionEvent::kIoError, what);
      link_->Close();  // reopened by the next probe
      // The transport failed: OFFLINE at once, whatever the count (decision 1054).
      health_.ForceDown(what);
      PublishHealth();
      SetState(LinkState::kOffline, what);
      return absl::UnavailableError(what);
    }
  }
}

std::optional<int> ControllerSession::baud() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return baud_;
}

absl::Status ControllerSession::SetBaudLocked(int baud) {
  absl::Status s = link_->SetBaud(baud);
  std::lock_guard<std::mutex> lock(state_mutex_);
  baud_ = link_->baud();
  if (!s.ok()) return absl::Status(s.code(), absl::StrCat(name_, ": ", s.message()));
  return absl::OkStatus();
}

absl::Status ControllerSession::SetBaud(int baud) {
  std::lock_guard<std::mutex> lock(io_mutex_);
  auto line = link_->LockLine();
  return SetBaudLocked(baud);
}

absl::Status ControllerSession::ChangeBaud(const Command& word, Deadline deadline) {
  if (word.opcode != Opcode::kSetBaudRate) {
    return absl::InvalidArgumentError(
        absl::StrCat(Where(word), ": ChangeBaud takes a set_baud_rate ($40) word"));
  }
  if (word.address != options_.address) {
    return absl::InvalidArgumentError(
        absl::StrCat(Where(word), ": command for address ", std::to_string(word.address)));
  }
  if (auto s = ValidateCommand(word); !s.ok()) return s;
  const absl::StatusOr<int> target = BaudOfDivisor(word.values[0]);
  std::lock_guard<std::mutex> lock(io_mutex_);
  auto line = LockLine(deadline);
  const std::optional<int> old = link_->baud();
  // Our own port must be able to follow before the PACK is told to switch (CT-08), and so must
  // the other PACKs on a shared line (decision 1471).
  if (old && !target.ok()) return target.status();
  if (old) {
    if (auto s = link_->CheckBaudChange(*target); !s.ok()) {
      return absl::Status(s.code(), absl::StrCat(Where(word), ": ", s.message()));
    }
  }
  if (!old) return TransactLocked(word, deadline).status();  // CAN: the PACK's RS-232 only
  Command probe;
  probe.address = options_.address;
  probe.opcode = Opcode::kUnitInformation;
  probe.values[0] = options_.response_address;
  const auto probe_deadline = [&] {
    return SessionClock::now() + std::max(options_.probe_timeout, std::chrono::milliseconds(50));
  };
  // The PACK acknowledges nothing (G-06): a `$40` lost on the line leaves it at the old rate.
  // Then the `$43` at the old rate answers and the word is sent once more.
  absl::Status last = absl::OkStatus();
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto sent = TransactLocked(word, deadline);
    if (!sent.ok()) return sent.status();
    if (*old == *target) return absl::OkStatus();
    // G-40 [P]: the new rate is effective after the complete word; switch, settle, verify. The
    // word must have reached the PACK at the old rate first: TCSADRAIN covers a UART's queue,
    // twice the word's line time (10 bits per byte, G-03) plus the command gap a pty reader.
    std::this_thread::sleep_for(microseconds(2 * kCommandSize * 10 * 1'000'000 / *old) +
                                options_.command_gap);
    if (auto s = SetBaudLocked(*target); !s.ok()) return s;
    std::this_thread::sleep_for(options_.baud_settle);
    auto verified = TransactLocked(probe, probe_deadline());
    if (verified.ok()) return absl::OkStatus();
    (void)SetBaudLocked(*old);
    last = absl::UnavailableError(absl::StrCat(
        Where(word), ": no unit_information ($43) answer at ", *target, " baud after the switch (",
        std::string(verified.status().message()), "); returned to ", *old, " baud (G-40)"));
    if (!TransactLocked(probe, probe_deadline()).ok()) break;  // not at the old rate either
  }
  return last;
}

}  // namespace drivegw::trinamic
