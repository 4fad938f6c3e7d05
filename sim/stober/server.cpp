// AxisServer: SlaveServer + AxisDevice (decision 1181).
#include "sim/stober/server.h"

#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::stober {

absl::StatusOr<std::unique_ptr<AxisServer>> AxisServer::Start(
    const AxisServerOptions& options, const Clock& clock,
    std::unique_ptr<transport::CanChannel> channel) {
  if (options.node_id < 1 || options.node_id > 127) {
    return absl::InvalidArgumentError(
        absl::StrCat("stober node id: ", options.node_id, " outside 1..127"));
  }
  if (absl::Status s = AxisDevice::Validate(options.axis); !s.ok()) return s;
  // Private constructor: make_unique cannot reach it.
  std::unique_ptr<AxisServer> server(new AxisServer(std::make_unique<AxisDevice>(options.axis)));
  server->device_->SetAbortListener(options.on_abort);
  canopen::SlaveServerOptions so;
  so.can = options.can;
  so.node.node_id = options.node_id;
  so.node.heartbeat_ms = options.heartbeat_ms;
  so.node.identity.device_type = kDeviceTypeServo;
  so.node.identity.device_name = "drivegw simulated STOBER axis";
  auto slave = canopen::SlaveServer::Start(so, clock, server->device_.get(), std::move(channel));
  if (!slave.ok()) return slave.status();
  server->slave_ = *std::move(slave);
  return server;
}

AxisServer::~AxisServer() { Stop(); }

void AxisServer::Stop() {
  if (slave_) slave_->Stop();
}

void AxisServer::WithAxis(const std::function<void(MotionCore&)>& fn) {
  slave_->WithNode([&](canopen::SlaveNode&) { fn(device_->core()); });
}

absl::StatusOr<int64_t> AxisServer::ReadObject(uint16_t index, uint8_t sub) {
  absl::StatusOr<int64_t> value = absl::NotFoundError("no node");
  slave_->WithNode([&](canopen::SlaveNode& node) { value = node.dictionary().GetInt(index, sub); });
  return value;
}

void AxisServer::ForceLimitSwitch(bool positive, std::optional<bool> active) {
  slave_->WithNode([&](canopen::SlaveNode&) { device_->ForceLimitSwitch(positive, active); });
}

void AxisServer::InjectFollowingError() {
  slave_->WithNode([&](canopen::SlaveNode& node) { device_->InjectFollowingError(node); });
}

void AxisServer::InjectSdoAbort(uint16_t index, uint8_t sub, drivegw::canopen::SdoAbortCode code) {
  slave_->InjectSdoAbort(index, sub, code);
}
void AxisServer::ClearSdoAborts() { slave_->ClearSdoAborts(); }
void AxisServer::SetHeartbeatLoss(bool lost) { slave_->SetHeartbeatLoss(lost); }
void AxisServer::SetSilent(bool silent) { slave_->SetSilent(silent); }
void AxisServer::Reboot() { slave_->Reboot(); }

void AxisServer::SetIgnoreExecute(bool ignore) {
  slave_->WithNode([&](canopen::SlaveNode&) { device_->SetIgnoreExecute(ignore); });
}
void AxisServer::DropNextExecuteEdge() {
  slave_->WithNode([&](canopen::SlaveNode&) { device_->DropNextExecuteEdge(); });
}
uint64_t AxisServer::dropped_execute_edges() {
  uint64_t n = 0;
  slave_->WithNode([&](canopen::SlaveNode&) { n = device_->dropped_edges(); });
  return n;
}

}  // namespace drivegw::sim::stober
