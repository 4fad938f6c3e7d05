// TrinamicServer: pty loop, per-unit 9-byte word assembly with the `$41` packet timeout, break,
// replies (optionally after the switchover delay) and fault injection for the simulated SIXpack
// (trinamic-sixpack.md §2.3-2.6, §7; decisions 1037, 1039, 1040, 1045).
#include "sim/trinamic/server.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/trinamic/codec.h"

namespace drivegw::sim::trinamic {

absl::StatusOr<std::unique_ptr<TrinamicServer>> TrinamicServer::Start(const ServerOptions& options,
                                                                      const Clock& clock) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  std::vector<Unit> units;
  std::vector<ControllerOptions> all = {options.controller};
  all.insert(all.end(), options.more_units.begin(), options.more_units.end());
  for (const ControllerOptions& o : all) {
    auto controller = Controller::Create(o);
    if (!controller.ok()) return controller.status();
    const uint64_t resets = controller->reset_count();
    units.push_back(Unit{*std::move(controller), WordAssembler{}, resets});
  }
  auto pty = transport::PseudoTerminal::Open(options.pty_path);
  if (!pty.ok()) return pty.status();
  std::unique_ptr<TrinamicServer> server(
      new TrinamicServer(options, clock, *std::move(pty), std::move(units)));
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  return server;
}

TrinamicServer::TrinamicServer(const ServerOptions& options, const Clock& clock,
                               transport::PseudoTerminal pty, std::vector<Unit> units)
    : options_(options),
      clock_(clock),
      pty_(std::move(pty)),
      units_(std::move(units)),
      start_(clock.Now()),
      advanced_to_(start_) {}

TrinamicServer::~TrinamicServer() { Stop(); }

void TrinamicServer::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

ServerCounters TrinamicServer::counters() const {
  std::lock_guard lock(mu_);
  ServerCounters c = counters_;
  const AssemblerCounters& a = units_.front().words.counters();
  c.words = a.words;
  c.words_dropped = a.words_dropped;
  c.partial_timeouts = a.partial_timeouts;
  c.breaks = a.breaks;
  return c;
}

void TrinamicServer::SetSilent(bool silent) {
  std::lock_guard lock(mu_);
  options_.faults.silent = silent;
}

void TrinamicServer::SetUnitSilent(size_t index, bool silent) {
  std::lock_guard lock(mu_);
  units_.at(index).silent = silent;
}

void TrinamicServer::LoseSteps(int motor, int64_t steps) {
  WithController([&](Controller& c) { c.LoseSteps(motor, steps); });
}

void TrinamicServer::SetStuckSwitch(int motor, std::optional<bool> level) {
  WithController([&](Controller& c) { c.SetStuckSwitch(motor, level); });
}

void TrinamicServer::WithController(const std::function<void(Controller&)>& fn) { WithUnit(0, fn); }

void TrinamicServer::WithUnit(size_t index, const std::function<void(Controller&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(units_.at(index).controller);
  // A change made by `fn` (a motion ending, the supply) may release a delayed `$28`.
  AdvanceLocked();
}

void TrinamicServer::Break() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  for (Unit& u : units_) u.words.Break();
}

void TrinamicServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (options_.faults.reset_after && !reset_done_ && now >= start_ + *options_.faults.reset_after) {
    // Physics up to the power loss, then defaults, reset flag and the stray 00 byte (L228).
    const TimePoint at = start_ + *options_.faults.reset_after;
    for (Unit& u : units_) AdvanceUnitLocked(u, at);
    advanced_to_ = at;
    Unit& first = units_.front();
    first.controller.Reset();
    first.resets_seen = first.controller.reset_count();
    first.words.Clear();
    reset_done_ = true;
    ++counters_.resets;
    SendLocked({0x00});
  }
  if (now > advanced_to_) {
    for (Unit& u : units_) AdvanceUnitLocked(u, now);
    advanced_to_ = now;
  }
  for (Unit& u : units_) {
    if (auto delayed = u.controller.TakeDelayedReply()) ReplyLocked(u, *std::move(delayed), now);
  }
  FlushLocked(now);
}

void TrinamicServer::AdvanceUnitLocked(Unit& unit, TimePoint now) {
  // While a delayed `$28` waits, step tick by tick so that its reply is timed from the tick in
  // which the masked motors came to rest (L740, CT-16), not from the end of a long advance.
  TimePoint t = advanced_to_;
  while (t < now && unit.controller.delayed_pending()) {
    const Duration step = std::min<Duration>(kTick, now - t);
    unit.controller.Advance(step);
    t += step;
    if (auto delayed = unit.controller.TakeDelayedReply()) {
      ReplyLocked(unit, *std::move(delayed), t);
    }
  }
  if (now > t) unit.controller.Advance(now - t);
}

void TrinamicServer::ReplyLocked(const Unit& unit, std::vector<uint8_t> bytes, TimePoint at) {
  if (options_.faults.silent || unit.silent) return;
  if (reply_impairment_) {
    const transport::ImpairmentDecision d = reply_impairment_->Decide();
    if (d.drop) {
      ++counters_.replies_impaired_dropped;
      return;
    }
    if (d.corrupt) {  // line noise: one bit of the reply flipped (decision 1421)
      ++counters_.replies_impaired_corrupted;
      transport::FlipBit(bytes, d.corrupt_bits);
    }
    if (d.reorder && !held_reply_) {
      ++counters_.replies_impaired_reordered;
      held_reply_ = std::move(bytes);
      return;
    }
    std::optional<std::vector<uint8_t>> held;
    held.swap(held_reply_);
    if (d.duplicate) {
      ++counters_.replies_impaired_duplicated;
      ReplyNowLocked(unit, bytes, at);
    }
    ReplyNowLocked(unit, std::move(bytes), at);
    if (held) ReplyNowLocked(unit, std::move(*held), at);
    return;
  }
  ReplyNowLocked(unit, std::move(bytes), at);
}

void TrinamicServer::ReplyNowLocked(const Unit& unit, std::vector<uint8_t> bytes, TimePoint at) {
  if (!options_.turnaround) {
    SendLocked(bytes);
    return;
  }
  // The PACK starts transmitting only after the switchover time (L283, L833); replies leave in
  // order, so a later one never overtakes an earlier one (decision 1040).
  TimePoint due = at + kTick * unit.controller.globals().switchover;
  if (!outbox_.empty()) due = std::max(due, outbox_.back().due);
  outbox_.push_back(PendingReply{due, std::move(bytes)});
}

void TrinamicServer::FlushLocked(TimePoint now) {
  while (!outbox_.empty() && outbox_.front().due <= now) {
    SendLocked(outbox_.front().bytes);
    outbox_.pop_front();
  }
}

void TrinamicServer::SendLocked(const std::vector<uint8_t>& bytes) {
  if (pty_.Write(bytes).ok()) ++counters_.replies;
  if (options_.trace_limit > 0) {
    wire_.push_back(WireEvent{false, bytes});
    if (wire_.size() > options_.trace_limit) wire_.pop_front();
  }
}

std::vector<TrinamicServer::WireEvent> TrinamicServer::wire() const {
  std::lock_guard lock(mu_);
  return {wire_.begin(), wire_.end()};
}

std::vector<std::vector<uint8_t>> TrinamicServer::words() const {
  std::lock_guard lock(mu_);
  return {trace_.begin(), trace_.end()};
}

void TrinamicServer::ClearWords() {
  std::lock_guard lock(mu_);
  trace_.clear();
  wire_.clear();
}

void TrinamicServer::HandleLocked(Unit& unit, const drivegw::trinamic::Command& command,
                                  TimePoint now) {
  // Every unit on a multi-drop line decodes the same host word; trace it once (decision 1039).
  const bool first_unit = &unit == &units_.front();
  if (options_.trace_limit > 0 && first_unit) {
    if (auto bytes = drivegw::trinamic::EncodeCommand(command); bytes.ok()) {
      wire_.push_back(WireEvent{true, *bytes});
      if (wire_.size() > options_.trace_limit) wire_.pop_front();
      trace_.push_back(*std::move(bytes));
      if (trace_.size() > options_.trace_limit) trace_.pop_front();  // bounded for long runs
    }
  }
  auto reply = unit.controller.Handle(command);
  if (unit.controller.reset_count() != unit.resets_seen) {
    // `$CC`: the RS-232 receives one `00` byte while the unit restarts (L228, L902, CT-47);
    // replies still waiting for the switchover are lost with the reset.
    unit.resets_seen = unit.controller.reset_count();
    outbox_.clear();
    ++counters_.reset_bytes;
    SendLocked({0x00});
  }
  if (reply) ReplyLocked(unit, *std::move(reply), now);
}

void TrinamicServer::ImpairWordLocked(Unit& unit, const drivegw::trinamic::Command& command,
                                      TimePoint now) {
  if (!word_impairment_) {
    HandleLocked(unit, command, now);
    return;
  }
  const transport::ImpairmentDecision d = word_impairment_->Decide();
  if (d.drop) {
    ++counters_.words_impaired_dropped;
    return;
  }
  if (d.corrupt) {
    // A flipped bit fails the word's checksum byte: the PACK ignores it (L279 framing; the
    // codec refuses a bad checksum), which on the line is a lost word.
    ++counters_.words_impaired_corrupted;
    return;
  }
  if (d.reorder && !held_word_) {
    ++counters_.words_impaired_reordered;
    held_word_ = command;
    return;
  }
  HandleLocked(unit, command, now);
  if (d.duplicate) {
    ++counters_.words_impaired_duplicated;
    HandleLocked(unit, command, now);
  }
  if (held_word_) {
    const drivegw::trinamic::Command held = *held_word_;
    held_word_.reset();
    HandleLocked(unit, held, now);
  }
}

absl::Status TrinamicServer::SetImpairment(const transport::Impairment& host_words,
                                           const transport::Impairment& replies) {
  for (const auto& [what, imp] :
       {std::pair<const char*, const transport::Impairment&>{"host words", host_words},
        {"replies", replies}}) {
    if (auto s = transport::ImpairedLink::Validate(imp); !s.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(what, " ", s.message()));
    }
    // A UART line loses or garbles bytes; it neither duplicates nor reorders them, and a second
    // reply can only come from a second PACK at the same address, which the gateway rightly
    // reports as such (decision 1055). Delays are the PACK's own turnaround (decision 1040).
    if (imp.duplicate_probability != 0 || imp.reorder_probability != 0 ||
        imp.delay_max.count() != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          what, " impairment: a serial line takes only drop and corrupt (decision 1421), not ",
          transport::ImpairmentString(imp)));
    }
  }
  std::lock_guard lock(mu_);
  if (units_.size() != 1) {
    return absl::FailedPreconditionError(
        absl::StrCat("impairment needs one unit on the line, not ", units_.size()));
  }
  word_impairment_.emplace(host_words);
  reply_impairment_.emplace(replies);
  held_word_.reset();
  held_reply_.reset();
  return absl::OkStatus();
}

void TrinamicServer::ReceiveLocked(const std::vector<uint8_t>& bytes) {
  const TimePoint now = clock_.Now();
  counters_.bytes_in += bytes.size();
  int peer_baud = 0;
  if (options_.check_peer_baud) {
    // Both pty ends share one termios (§2.7): the speed the peer set is the one it "sends" at.
    auto peer = pty_.PeerBaud();
    peer_baud = peer.ok() ? *peer : -1;
  }
  for (size_t i = 0; i < units_.size(); ++i) {
    Unit& u = units_[i];
    if (options_.check_peer_baud && !BaudMatches(peer_baud, u.controller.globals().baud_divisor)) {
      // At the wrong speed a UART sees framing errors, not words: the bytes are noise and the
      // partial word is lost (L273, L832, CT-08, decision 1045).
      u.words.Clear();
      if (i == 0) counters_.noise_bytes += bytes.size();
      continue;
    }
    const uint16_t t41 = u.controller.globals().packet_timeout;
    const Duration timeout = t41 == 0 ? options_.default_packet_timeout : Duration(kTick * t41);
    u.words.Feed(bytes, now, timeout,
                 [&](const drivegw::trinamic::Command& c) { ImpairWordLocked(u, c, now); });
  }
  FlushLocked(now);
}

void TrinamicServer::Run() {
  while (!stop_) {
    auto bytes = pty_.ReadAvailable(std::chrono::milliseconds(5));
    std::lock_guard lock(mu_);
    AdvanceLocked();
    if (bytes.ok() && !bytes->empty()) ReceiveLocked(*bytes);
  }
}

}  // namespace drivegw::sim::trinamic
