// TrinamicServer: pty loop, 9-byte word assembly with the `$41` packet timeout, replies and
// fault injection for the simulated SIXpack (trinamic-sixpack.md §2.3-2.6, §7).
#include "sim/trinamic/server.h"

#include <utility>

#include "adapters/trinamic/codec.h"

namespace drivegw::sim::trinamic {

absl::StatusOr<std::unique_ptr<TrinamicServer>> TrinamicServer::Start(const ServerOptions& options,
                                                                      const Clock& clock) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  auto controller = Controller::Create(options.controller);
  if (!controller.ok()) return controller.status();
  auto pty = transport::PseudoTerminal::Open(options.pty_path);
  if (!pty.ok()) return pty.status();
  std::unique_ptr<TrinamicServer> server(
      new TrinamicServer(options, clock, *std::move(pty), *std::move(controller)));
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  return server;
}

TrinamicServer::TrinamicServer(const ServerOptions& options, const Clock& clock,
                               transport::PseudoTerminal pty, Controller controller)
    : options_(options),
      clock_(clock),
      pty_(std::move(pty)),
      controller_(std::move(controller)),
      start_(clock.Now()),
      advanced_to_(start_) {}

TrinamicServer::~TrinamicServer() { Stop(); }

void TrinamicServer::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

ServerCounters TrinamicServer::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

void TrinamicServer::SetSilent(bool silent) {
  std::lock_guard lock(mu_);
  options_.faults.silent = silent;
}

void TrinamicServer::LoseSteps(int motor, int64_t steps) {
  WithController([&](Controller& c) { c.LoseSteps(motor, steps); });
}

void TrinamicServer::SetStuckSwitch(int motor, std::optional<bool> level) {
  WithController([&](Controller& c) { c.SetStuckSwitch(motor, level); });
}

void TrinamicServer::WithController(const std::function<void(Controller&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(controller_);
}

void TrinamicServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (options_.faults.reset_after && !reset_done_ && now >= start_ + *options_.faults.reset_after) {
    // Physics up to the power loss, then defaults, reset flag and the stray 00 byte (L228).
    controller_.Advance(start_ + *options_.faults.reset_after - advanced_to_);
    advanced_to_ = start_ + *options_.faults.reset_after;
    controller_.Reset();
    partial_.clear();
    reset_done_ = true;
    ++counters_.resets;
    SendLocked({0x00});
  }
  if (now > advanced_to_) {
    controller_.Advance(now - advanced_to_);
    advanced_to_ = now;
  }
  if (auto delayed = controller_.TakeDelayedReply(); delayed && !options_.faults.silent) {
    SendLocked(*delayed);
  }
}

void TrinamicServer::SendLocked(const std::vector<uint8_t>& bytes) {
  if (pty_.Write(bytes).ok()) ++counters_.replies;
}

void TrinamicServer::ReceiveLocked(const std::vector<uint8_t>& bytes) {
  const TimePoint now = clock_.Now();
  const uint16_t t41 = controller_.globals().packet_timeout;
  const Duration timeout =
      t41 == 0 ? options_.default_packet_timeout : Duration(std::chrono::milliseconds(2) * t41);
  counters_.bytes_in += bytes.size();
  for (uint8_t b : bytes) {
    // A word must be complete within the packet timeout, measured from its first byte (L279).
    if (!partial_.empty() && now - partial_since_ > timeout) {
      partial_.clear();
      ++counters_.partial_timeouts;
    }
    if (partial_.empty()) partial_since_ = now;
    partial_.push_back(b);
    if (partial_.size() < drivegw::trinamic::kCommandSize) continue;
    auto command = drivegw::trinamic::DecodeCommand(partial_);
    partial_.clear();
    if (!command.ok()) {
      ++counters_.words_dropped;  // not executed, no answer (L279, G-06)
      continue;
    }
    ++counters_.words;
    auto reply = controller_.Handle(*command);
    if (reply && !options_.faults.silent) SendLocked(*reply);
  }
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
