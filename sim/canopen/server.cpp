// SlaveServer: the CAN receive loop around a SlaveNode, clock-driven advancing and fault
// injection for a simulated CANopen slave (decisions 1133, 1134).
#include "sim/canopen/server.h"

#include <utility>

#include "adapters/canopen/emcy.h"
#include "sim/common/can_receive_loop.h"

namespace drivegw::sim::canopen {
namespace {

// Real time between clock re-reads while the bus is idle (as the Trinamic CAN server).
constexpr auto kIdleWait = std::chrono::milliseconds(5);

}  // namespace

absl::StatusOr<std::unique_ptr<SlaveServer>> SlaveServer::Start(
    const SlaveServerOptions& options, const Clock& clock, DeviceModel* model,
    std::unique_ptr<transport::CanChannel> channel) {
  auto node = SlaveNode::Create(options.node, model);
  if (!node.ok()) return node.status();
  if (channel == nullptr) {
    auto opened = transport::OpenCanChannel(options.can);
    if (!opened.ok()) return opened.status();
    channel = *std::move(opened);
  }
  // No acceptance filter: SYNC, PDO and heartbeat-consumer identifiers are re-configurable
  // over SDO; the node sorts every frame itself.
  if (absl::Status s = channel->SetFilters({}); !s.ok()) return s;
  // A private constructor: make_unique cannot reach it.
  std::unique_ptr<SlaveServer> server(new SlaveServer(clock, std::move(channel), *std::move(node)));
  {
    std::lock_guard lock(server->mu_);
    server->node_->Boot(clock.Now());
    server->FlushLocked();
  }
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  return server;
}

SlaveServer::SlaveServer(const Clock& clock, std::unique_ptr<transport::CanChannel> channel,
                         std::unique_ptr<SlaveNode> node)
    : clock_(clock),
      channel_(std::move(channel)),
      node_id_(node->node_id()),
      node_(std::move(node)) {}

SlaveServer::~SlaveServer() { Stop(); }

void SlaveServer::Stop() {
  if (!stop_.exchange(true) && channel_ != nullptr) channel_->Wake();
  if (thread_.joinable()) thread_.join();
}

NmtState SlaveServer::state() const {
  std::lock_guard lock(mu_);
  return node_->state();
}

SlaveServerCounters SlaveServer::counters() const {
  std::lock_guard lock(mu_);
  SlaveServerCounters c = counters_;
  c.node = node_->counters();
  return c;
}

void SlaveServer::FlushLocked() {
  for (const transport::CanFrame& frame : node_->TakeFrames()) {
    if (channel_->Send(frame).ok()) {
      ++counters_.frames_out;
    } else {
      ++counters_.send_errors;
    }
  }
}

void SlaveServer::WithNode(const std::function<void(SlaveNode&)>& fn) {
  std::lock_guard lock(mu_);
  node_->Advance(clock_.Now());
  fn(*node_);
  node_->Advance(clock_.Now());
  FlushLocked();
}

void SlaveServer::RaiseEmcy(uint16_t code, uint8_t register_bits, std::array<uint8_t, 5> msef) {
  WithNode([&](SlaveNode& n) { n.RaiseEmcy(code, register_bits, msef); });
}

void SlaveServer::ClearErrors() {
  WithNode([](SlaveNode& n) { n.ClearErrors(); });
}

void SlaveServer::SetSilent(bool silent) {
  WithNode([&](SlaveNode& n) { n.SetSilent(silent); });
}

void SlaveServer::SetHeartbeatLoss(bool lost) {
  WithNode([&](SlaveNode& n) { n.SetHeartbeatLoss(lost); });
}

void SlaveServer::InjectSdoAbort(uint16_t index, uint8_t sub, drivegw::canopen::SdoAbortCode code) {
  WithNode([&](SlaveNode& n) { n.InjectSdoAbort(index, sub, code); });
}

void SlaveServer::ClearSdoAborts() {
  WithNode([](SlaveNode& n) { n.ClearSdoAborts(); });
}

void SlaveServer::Reboot() {
  WithNode([&](SlaveNode& n) { n.Reboot(clock_.Now()); });
}

void SlaveServer::Run() {
  auto count_error = [this] {
    std::lock_guard lock(mu_);
    ++counters_.receive_errors;
  };
  RunCanReceiveLoop(*channel_, kIdleWait, stop_, count_error, [this](const auto& received) {
    std::lock_guard lock(mu_);
    const TimePoint now = clock_.Now();
    // Leaving bus-off is a communication error for 1029h, reported as EMCY 8140h once the
    // controller can send again (CiA 301 Table 21; decision 1130).
    const transport::CanBusState bus = channel_->state();
    if (bus_state_ == transport::CanBusState::kBusOff && bus != transport::CanBusState::kBusOff &&
        bus != transport::CanBusState::kDown) {
      node_->Advance(now);
      node_->CommunicationError(drivegw::canopen::emcy_code::kRecoveredFromBusOff);
    }
    bus_state_ = bus;
    if (received.has_value()) {
      ++counters_.frames_in;
      node_->OnFrame(*received, now);
    } else {
      node_->Advance(now);
    }
    FlushLocked();
  });
}

}  // namespace drivegw::sim::canopen
