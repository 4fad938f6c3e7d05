// TrinamicCanServer: CAN receive loop, command decoding, replies to RA << 3 and fault
// injection for the simulated SIXpack (trinamic-sixpack.md §3, §7; decision 1038).
#include "sim/trinamic/can_server.h"

#include <condition_variable>
#include <span>
#include <utility>

#include "adapters/trinamic/codec.h"

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
  if (channel == nullptr) {
    auto opened = transport::OpenCanChannel(o.can);
    if (!opened.ok()) return opened.status();
    channel = *std::move(opened);
  }
  const transport::CanFilter filter{*id, transport::kCanStandardIdMax, false};
  if (absl::Status s = channel->SetFilters(std::span<const transport::CanFilter>(&filter, 1));
      !s.ok()) {
    return s;
  }
  std::unique_ptr<TrinamicCanServer> server(
      new TrinamicCanServer(o, clock, std::move(channel), *std::move(controller)));
  server->command_id_ = *id;
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
    // Physics up to the power loss, then defaults and the reset flag. No stray 00 byte: that is
    // the RS-232 receiver's artefact (L228), a CAN controller sends nothing (decision 1038).
    controller_.Advance(start_ + *options_.faults.reset_after - advanced_to_);
    advanced_to_ = start_ + *options_.faults.reset_after;
    controller_.Reset();
    controller_.SetFraming(ReplyFraming::kR9);
    reset_done_ = true;
    ++counters_.resets;
  }
  if (now > advanced_to_) {
    controller_.Advance(now - advanced_to_);
    advanced_to_ = now;
  }
  if (auto delayed = controller_.TakeDelayedReply(); delayed && !options_.faults.silent) {
    SendReplyLocked(*delayed);
  }
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
  auto reply = controller_.Handle(*command);
  if (reply && !options_.faults.silent) SendReplyLocked(*reply);
}

void TrinamicCanServer::Run() {
  std::mutex backoff_mu;
  std::condition_variable backoff_cv;
  while (!stop_.load()) {
    auto received = channel_->Receive(kIdleWait);
    if (!received.ok()) {
      {
        std::lock_guard lock(mu_);
        ++counters_.receive_errors;
      }
      // A broken channel must not become a busy loop (real time; Stop still joins promptly).
      std::unique_lock lock(backoff_mu);
      backoff_cv.wait_for(lock, std::chrono::milliseconds(20), [this] { return stop_.load(); });
      continue;
    }
    std::lock_guard lock(mu_);
    AdvanceLocked();
    if (received->has_value()) HandleFrameLocked(**received);
  }
}

}  // namespace drivegw::sim::trinamic
