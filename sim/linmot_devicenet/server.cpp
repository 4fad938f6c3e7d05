// LinMotDnServer: the CAN side of the simulated LinMot DeviceNet drive: one I/O thread, the
// device advanced to the injected clock, delayed responses, frame recording and fault hooks
// (linmot-devicenet.md §12.7, §12.8; decision 957).
#include "sim/linmot_devicenet/server.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "adapters/linmot/devicenet/codec_can.h"
#include "adapters/linmot/devicenet/commands.h"
#include "sim/linmot_devicenet/device.h"
#include "sim/linmot_devicenet/dn_stack.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

// How often the thread re-reads the injected clock when the bus is quiet: timers (duplicate MAC
// check, watchdogs, CoS) then fire at most this late in real time.
constexpr auto kIdleWait = std::chrono::milliseconds(5);
constexpr auto kPendingWait = std::chrono::milliseconds(1);

}  // namespace

absl::StatusOr<std::unique_ptr<LinMotDnServer>> LinMotDnServer::Start(
    const DnSimOptions& options, const Clock& clock,
    std::unique_ptr<transport::CanChannel> channel) {
  auto device = LinMotDnDevice::Create(options);
  if (!device.ok()) return device.status();
  if (channel == nullptr) {
    auto opened = transport::OpenCanChannel(options.can);
    if (!opened.ok()) {
      return absl::Status(opened.status().code(), "linmot-devicenet sim '" + options.name + "': " +
                                                      std::string(opened.status().message()));
    }
    channel = *std::move(opened);
  }
  auto stack = std::make_unique<DnStack>(options, **device);
  std::unique_ptr<LinMotDnServer> server(
      new LinMotDnServer(options, clock, std::move(channel), *std::move(device), std::move(stack)));
  {
    std::lock_guard lock(server->mu_);
    server->SendLocked(server->stack_->Start(clock.Now()));
  }
  server->running_ = true;
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  log::Info("linmot_dn_sim.started", log::Fields()
                                         .Add("drive", options.name)
                                         .Add("bus", server->channel_->name())
                                         .Add("mac", static_cast<int>(server->mac_id_))
                                         .Add("enabled", options.dn_enable ? "yes" : "no")
                                         .Add("consumed", dn::ConsumedSize(PollLayout(options)))
                                         .Add("produced", dn::ProducedSize(PollLayout(options))));
  return server;
}

LinMotDnServer::LinMotDnServer(const DnSimOptions& options, const Clock& clock,
                               std::unique_ptr<transport::CanChannel> channel,
                               std::unique_ptr<LinMotDnDevice> device,
                               std::unique_ptr<DnStack> stack)
    : options_(options),
      clock_(clock),
      mac_id_(ResolvedMacId(options)),
      channel_(std::move(channel)),
      device_(std::move(device)),
      stack_(std::move(stack)),
      last_advance_(clock.Now()) {}

LinMotDnServer::~LinMotDnServer() { Stop(); }

void LinMotDnServer::Stop() {
  if (running_.exchange(false)) channel_->Wake();
  if (thread_.joinable()) {
    thread_.join();
    log::Info("linmot_dn_sim.stopped", log::Fields().Add("drive", options_.name));
  }
}

std::string LinMotDnServer::bus_name() const { return channel_->name(); }

void LinMotDnServer::Run() {
  std::mutex backoff_mu;
  std::condition_variable backoff_cv;
  while (running_.load()) {
    Duration wait = kIdleWait;
    {
      std::lock_guard lock(mu_);
      if (!pending_.empty()) wait = kPendingWait;
    }
    auto received = channel_->Receive(wait);
    if (!received.ok()) {
      {
        std::lock_guard lock(mu_);
        ++counters_.receive_errors;
      }
      log::Warn(
          "linmot_dn_sim.receive_failed",
          log::Fields().Add("drive", options_.name).Add("error", received.status().message()));
      // A broken channel must not become a busy loop; real time, not simulated time.
      std::unique_lock lock(backoff_mu);
      backoff_cv.wait_for(lock, std::chrono::milliseconds(100),
                          [this] { return !running_.load(); });
      continue;
    }
    std::lock_guard lock(mu_);
    AdvanceLocked();
    // §5.10 on real hardware: our own controller went bus-off (SocketCAN error frames).
    if (channel_->state() == transport::CanBusState::kBusOff &&
        stack_->network() != NetworkState::kBusOff &&
        stack_->network() != NetworkState::kDisabled) {
      stack_->GoBusOff(clock_.Now());
      pending_.clear();
    }
    if (received->has_value()) HandleFrameLocked(**received);
    FlushDueLocked();
  }
}

void LinMotDnServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (now > last_advance_) {
    device_->Advance(now - last_advance_);
    last_advance_ = now;
  }
  SendLocked(stack_->Advance(now));
}

void LinMotDnServer::HandleFrameLocked(const transport::CanFrame& can) {
  ++counters_.frames_received;
  auto frame = dn::FromCanFrame(can);
  if (!frame.ok()) {
    // STYLE §6: a bad frame is counted, traced and dropped; the server survives.
    ++counters_.malformed;
    log::Debug("linmot_dn_sim.malformed",
               log::Fields().Add("drive", options_.name).Add("error", frame.status().message()));
    return;
  }
  RecordLocked(false, *frame);
  SendLocked(stack_->HandleFrame(*frame, clock_.Now()));
}

void LinMotDnServer::SendLocked(const std::vector<OutFrame>& frames) {
  const TimePoint now = clock_.Now();
  for (const OutFrame& f : frames) {
    if (f.due <= now) {
      if (channel_->Send(dn::ToCanFrame(f.frame)).ok()) {
        ++counters_.frames_sent;
        RecordLocked(true, f.frame);
      } else {
        ++counters_.send_errors;
      }
      continue;
    }
    ++counters_.responses_delayed;
    Pending p{f.due, f.frame};
    auto it = std::upper_bound(pending_.begin(), pending_.end(), p.due,
                               [](TimePoint t, const Pending& q) { return t < q.due; });
    pending_.insert(it, std::move(p));
  }
}

void LinMotDnServer::FlushDueLocked() {
  const TimePoint now = clock_.Now();
  while (!pending_.empty() && pending_.front().due <= now) {
    if (stack_->network() == NetworkState::kOnline &&
        channel_->Send(dn::ToCanFrame(pending_.front().frame)).ok()) {
      ++counters_.frames_sent;
      RecordLocked(true, pending_.front().frame);
    } else {
      ++counters_.send_errors;
    }
    pending_.pop_front();
  }
}

void LinMotDnServer::RecordLocked(bool transmitted, const dn::Frame& frame) {
  frames_.push_back(FrameRecord{clock_.Now(), transmitted, frame});
  while (frames_.size() > max_frames_) frames_.pop_front();
}

DnSimSnapshot LinMotDnServer::Snapshot() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  return DnSimSnapshot{device_->Snapshot(), stack_->Snapshot(), counters_};
}

std::vector<FrameRecord> LinMotDnServer::Frames() const {
  std::lock_guard lock(mu_);
  return std::vector<FrameRecord>(frames_.begin(), frames_.end());
}

void LinMotDnServer::ClearFrames() {
  std::lock_guard lock(mu_);
  frames_.clear();
}

void LinMotDnServer::SetDropPolls(bool drop) {
  std::lock_guard lock(mu_);
  stack_->faults().drop_polls = drop;
}

void LinMotDnServer::DropNextPolls(uint32_t n) {
  std::lock_guard lock(mu_);
  stack_->faults().drop_next_polls = n;
}

void LinMotDnServer::SetResponseDelay(Duration delay) {
  std::lock_guard lock(mu_);
  stack_->faults().response_delay = std::max(delay, Duration{0});
}

void LinMotDnServer::SetCorruptFragments(bool corrupt) {
  std::lock_guard lock(mu_);
  stack_->faults().corrupt_fragments = corrupt;
}

void LinMotDnServer::SetResponseLengthDelta(int delta) {
  std::lock_guard lock(mu_);
  stack_->faults().response_length_delta = delta;
}

void LinMotDnServer::GoBusOff() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  stack_->GoBusOff(clock_.Now());
  pending_.clear();  // a bus-off controller transmits nothing, queued frames included
}

void LinMotDnServer::RecoverBusOff() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  SendLocked(stack_->RecoverBusOff(clock_.Now()));
}

void LinMotDnServer::SetLonelyNode(bool lonely) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  stack_->faults().lonely_node = lonely;
}

void LinMotDnServer::InjectDuplicateMac() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  pending_.clear();
  SendLocked(stack_->InjectDuplicateMac(clock_.Now()));
}

absl::Status LinMotDnServer::RaiseCodedError(uint16_t code) {
  if (dn::FindCodedError(code) == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        "linmot_dn_sim.raise_coded_error: ", dn::CodedErrorText(code), " is not in §8.6"));
  }
  std::lock_guard lock(mu_);
  AdvanceLocked();
  device_->RaiseCodedError(code);
  return absl::OkStatus();
}

void LinMotDnServer::PowerCycle() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  pending_.clear();
  device_->ResetController();
  SendLocked(stack_->Restart(clock_.Now()));
}

void LinMotDnServer::WithDevice(const std::function<void(LinMotDnDevice&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(*device_);
}

void LinMotDnServer::WithStack(const std::function<void(DnStack&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(*stack_);
}

}  // namespace drivegw::sim::linmot_devicenet
