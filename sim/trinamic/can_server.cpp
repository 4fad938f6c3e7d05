// TrinamicCanServer: CAN receive loop, command queue, replies to RA << 3, the serial endpoint
// with takeover and tunnel, and fault injection for the simulated SIXpack (trinamic-sixpack.md
// §3, §7; decisions 1038, 1041, 1042).
#include "sim/trinamic/can_server.h"

#include <algorithm>
#include <span>
#include <utility>

#include "adapters/trinamic/codec.h"
#include "sim/common/can_receive_loop.h"

namespace drivegw::sim::trinamic {
namespace {

namespace codec = drivegw::trinamic;

// Real time between clock re-reads while the bus is idle.
constexpr auto kIdleWait = std::chrono::milliseconds(5);

}  // namespace

absl::StatusOr<std::unique_ptr<TrinamicCanServer>> TrinamicCanServer::Start(
    const CanServerOptions& options, const Clock& clock,
    std::unique_ptr<transport::CanChannel> channel) {
  CanServerOptions o = options;
  // The controller answers in R9 so that every reply carries its RA (the CAN identifier).
  o.controller.framing = ReplyFraming::kR9;
  ServerOptions check;
  check.controller = o.controller;
  check.faults = o.faults;
  if (absl::Status s = ValidateOptions(check); !s.ok()) return s;
  auto controller = Controller::Create(o.controller);
  if (!controller.ok()) return controller.status();
  auto id = codec::CommandCanId(o.controller.address);
  if (!id.ok()) return id.status();
  if (o.command_time < Duration::zero()) {
    return absl::InvalidArgumentError("options.command_time: must not be negative");
  }
  std::optional<transport::PseudoTerminal> pty;
  if (o.serial_endpoint) {
    auto opened = transport::PseudoTerminal::Open(o.serial_pty_path);
    if (!opened.ok()) return opened.status();
    pty.emplace(*std::move(opened));
  } else if (!o.serial_pty_path.empty()) {
    return absl::InvalidArgumentError("options.serial_pty_path: needs serial_endpoint");
  }
  if (channel == nullptr) {
    auto opened = transport::OpenCanChannel(o.can);
    if (!opened.ok()) return opened.status();
    channel = *std::move(opened);
  }
  std::vector<transport::CanFilter> filters = {{*id, transport::kCanStandardIdMax, false}};
  if (pty) filters.push_back({*id + 1u, transport::kCanStandardIdMax, false});  // tunnel (L315)
  if (absl::Status s = channel->SetFilters(filters); !s.ok()) return s;
  std::unique_ptr<TrinamicCanServer> server(
      new TrinamicCanServer(o, clock, std::move(channel), *std::move(controller)));
  server->command_id_ = *id;
  if (pty) server->tunnel_id_ = static_cast<uint16_t>(*id + 1);
  server->pty_ = std::move(pty);
  server->resets_seen_ = server->controller_.reset_count();
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  return server;
}

TrinamicCanServer::TrinamicCanServer(const CanServerOptions& options, const Clock& clock,
                                     std::unique_ptr<transport::CanChannel> channel,
                                     Controller controller)
    : options_(options),
      clock_(clock),
      channel_(std::move(channel)),
      controller_(std::move(controller)),
      start_(clock.Now()),
      advanced_to_(start_) {}

TrinamicCanServer::~TrinamicCanServer() { Stop(); }

void TrinamicCanServer::Stop() {
  if (!stop_.exchange(true) && channel_ != nullptr) channel_->Wake();
  if (thread_.joinable()) thread_.join();
}

CanServerCounters TrinamicCanServer::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

bool TrinamicCanServer::can_mode() const {
  std::lock_guard lock(mu_);
  return can_mode_;
}

void TrinamicCanServer::SetSilent(bool silent) {
  std::lock_guard lock(mu_);
  options_.faults.silent = silent;
}

void TrinamicCanServer::LoseSteps(int motor, int64_t steps) {
  WithController([&](Controller& c) { c.LoseSteps(motor, steps); });
}

void TrinamicCanServer::SetStuckSwitch(int motor, std::optional<bool> level) {
  WithController([&](Controller& c) { c.SetStuckSwitch(motor, level); });
}

void TrinamicCanServer::WithController(const std::function<void(Controller&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(controller_);
}

void TrinamicCanServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (options_.faults.reset_after && !reset_done_ && now >= start_ + *options_.faults.reset_after) {
    // Physics up to the power loss, then defaults and the reset flag. No stray 00 byte on CAN:
    // that is the RS-232 receiver's artefact (L228, decision 1038); the serial endpoint gets it.
    AdvanceControllerLocked(start_ + *options_.faults.reset_after);
    controller_.Reset();
    reset_done_ = true;
    ++counters_.resets;
    AfterResetLocked();
  }
  ProcessQueueLocked(now);
  AdvanceControllerLocked(now);
  if (auto delayed = controller_.TakeDelayedReply(); delayed && !options_.faults.silent) {
    SendReplyLocked(*delayed);
  }
  TunnelFlushLocked(now, false);
}

void TrinamicCanServer::AdvanceControllerLocked(TimePoint to) {
  if (to > advanced_to_) {
    controller_.Advance(to - advanced_to_);
    advanced_to_ = to;
  }
}

void TrinamicCanServer::ProcessQueueLocked(TimePoint now) {
  // One command per `command_time`, in arrival order; each executes on a controller advanced to
  // the instant its processing ends (L303, decision 1041).
  while (!queue_.empty()) {
    const TimePoint done = std::max(queue_.front().first, busy_until_) + options_.command_time;
    if (done > now) return;
    AdvanceControllerLocked(done);
    busy_until_ = done;
    const codec::Command command = queue_.front().second;
    queue_.pop_front();
    ExecuteLocked(command);
  }
}

void TrinamicCanServer::ExecuteLocked(const codec::Command& command) {
  auto reply = controller_.Handle(command);
  if (controller_.reset_count() != resets_seen_) AfterResetLocked();
  if (reply && !options_.faults.silent) SendReplyLocked(*reply);
}

void TrinamicCanServer::AfterResetLocked() {
  // After `$CC` or a power loss the rotary switches and interfaces start afresh: serial control
  // again until the next CAN instruction (G-28), queue and tunnel empty, the stray `00` on the
  // RS-232 (L228, L902).
  resets_seen_ = controller_.reset_count();
  controller_.SetFraming(ReplyFraming::kR9);
  can_mode_ = false;
  words_.Clear();
  tunnel_rx_.clear();
  if (pty_) (void)pty_->Write(std::vector<uint8_t>{0x00});
}

Duration TrinamicCanServer::PacketTimeoutLocked() const {
  const uint16_t t41 = controller_.globals().packet_timeout;
  return t41 == 0 ? options_.default_packet_timeout : Duration(kTick * t41);
}

void TrinamicCanServer::SerialLocked(const std::vector<uint8_t>& bytes) {
  const TimePoint now = clock_.Now();
  counters_.serial_bytes_in += bytes.size();
  if (!can_mode_) {
    // Serial control (L275-279): words executed directly, replies in the serial framing.
    words_.Feed(bytes, now, PacketTimeoutLocked(), [&](const codec::Command& c) {
      ++counters_.serial_words;
      auto reply = controller_.Handle(c);
      if (controller_.reset_count() != resets_seen_) AfterResetLocked();
      if (!reply || options_.faults.silent) return;
      std::vector<uint8_t> out = *std::move(reply);  // R9 from the controller
      if (options_.serial_framing == ReplyFraming::kR8) out.erase(out.begin());
      (void)pty_->Write(out);
    });
    return;
  }
  // CAN mode: the RS-232 is a transparent port; its bytes are no commands any more (L317).
  const uint8_t size = controller_.globals().tunnel_packet_size;
  for (uint8_t b : bytes) {
    if (size == 0 || controller_.globals().tunnel_address == 0) {
      ++counters_.tunnel_dropped;  // forwarding disabled (L864)
      continue;
    }
    if (tunnel_rx_.empty()) tunnel_since_ = now;
    tunnel_rx_.push_back(b);
    if (tunnel_rx_.size() >= size) TunnelFlushLocked(now, true);
  }
}

void TrinamicCanServer::TunnelFlushLocked(TimePoint now, bool force) {
  // Packets of `$44` P2 bytes; fewer when the `$41` timeout, counted from the first byte of the
  // packet, expires (L317, L838, decision 1042).
  if (tunnel_rx_.empty()) return;
  if (!force && now - tunnel_since_ < PacketTimeoutLocked()) return;
  auto id = codec::TunnelReceiveCanId(controller_.globals().tunnel_address);
  if (id.ok() && !options_.faults.silent &&
      channel_->Send(transport::MakeCanFrame(*id, tunnel_rx_)).ok()) {
    ++counters_.tunnel_frames;
  } else {
    ++counters_.send_errors;
  }
  tunnel_rx_.clear();
}

void TrinamicCanServer::SendReplyLocked(const std::vector<uint8_t>& r9) {
  auto reply = codec::DecodeReply(r9, ReplyFraming::kR9);
  if (!reply.ok()) {
    ++counters_.send_errors;
    return;
  }
  auto frame = codec::EncodeReplyCan(*reply);
  if (!frame.ok()) {
    ++counters_.send_errors;
    return;
  }
  const transport::CanFrame out = transport::MakeCanFrame(frame->id, frame->data);
  if (channel_->Send(out).ok()) {
    ++counters_.replies;
  } else {
    ++counters_.send_errors;
  }
}

void TrinamicCanServer::HandleFrameLocked(const transport::CanFrame& frame) {
  ++counters_.frames_in;
  if (pty_ && !frame.extended && !frame.rtr && !frame.error && frame.id == tunnel_id_) {
    // Host -> RS-232: every data byte goes out on the serial port, in CAN mode only (L315).
    if (!can_mode_) {
      counters_.tunnel_dropped += frame.dlc;
      return;
    }
    const std::vector<uint8_t> bytes(frame.data.begin(), frame.data.begin() + frame.dlc);
    if (pty_->Write(bytes).ok()) counters_.tunnel_bytes_out += bytes.size();
    return;
  }
  if (!frame.extended && !frame.rtr && !frame.error && frame.id != command_id_) {
    ++counters_.foreign;  // an injected channel without filtering, or another PACK's command
    return;
  }
  if (frame.extended || frame.rtr || frame.error) {
    ++counters_.malformed;  // CAN 2.0A data frames only (L289)
    return;
  }
  codec::CanFrame in;
  in.id = static_cast<uint16_t>(frame.id);
  in.dlc = frame.dlc;
  in.data = frame.data;
  auto command = codec::DecodeCommandCan(in);
  if (!command.ok()) {
    ++counters_.malformed;  // wrong DLC or unknown opcode: not executed, no answer (G-06, G-27)
    return;
  }
  ++counters_.commands;
  can_mode_ = true;  // the first valid CAN instruction ends serial control (L291)
  if (queue_.size() >= kCanQueueSize) {
    ++counters_.queue_overflows;  // the 17th waiting command is lost (G-27, decision 1041)
    return;
  }
  const TimePoint now = clock_.Now();
  queue_.emplace_back(now, *command);
  ProcessQueueLocked(now);
}

void TrinamicCanServer::Run() {
  auto count_error = [this] {
    std::lock_guard lock(mu_);
    ++counters_.receive_errors;
  };
  RunCanReceiveLoop(*channel_, kIdleWait, stop_, count_error, [this](const auto& received) {
    std::lock_guard lock(mu_);
    AdvanceLocked();
    if (received.has_value()) HandleFrameLocked(*received);
    if (pty_) {
      auto bytes = pty_->ReadAvailable(Duration::zero());
      if (bytes.ok() && !bytes->empty()) SerialLocked(*bytes);
    }
  });
}

}  // namespace drivegw::sim::trinamic
