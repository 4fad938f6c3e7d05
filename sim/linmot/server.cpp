// LinMotServer: the UDP side of the simulated drive (linmot-linudp.md)
// plus reply impairment and link-loss hooks; physics advanced to the injected clock.
#include "sim/linmot/server.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "adapters/core/log.h"
#include "adapters/linmot/linudp/codec.h"
#include "sim/linmot/device.h"

namespace drivegw::sim::linmot {

absl::StatusOr<std::unique_ptr<LinMotServer>> LinMotServer::Start(const SimOptions& options,
                                                                  const Clock& clock) {
  auto device = LinMotDevice::Create(options);
  if (!device.ok()) return device.status();
  auto socket = transport::UdpSocket::Bind(options.bind);
  if (!socket.ok()) {
    return absl::Status(socket.status().code(), "linmot sim '" + options.name +
                                                    "': " + std::string(socket.status().message()));
  }
  std::unique_ptr<LinMotServer> server(
      new LinMotServer(options, clock, std::move(*socket), std::move(*device)));
  server->running_ = true;
  server->thread_ = std::thread([s = server.get()] { s->Run(); });
  log::Info("linmot_sim.started",
            log::Fields()
                .Add("drive", options.name)
                .Add("listen", server->local_.ToString())
                .Add("master_port", options.master_port)
                .Add("tick_us",
                     std::chrono::duration_cast<std::chrono::microseconds>(options.tick).count()));
  return server;
}

LinMotServer::LinMotServer(const SimOptions& options, const Clock& clock,
                           transport::UdpSocket socket, std::unique_ptr<LinMotDevice> device)
    : options_(options),
      clock_(clock),
      socket_(std::move(socket)),
      local_(socket_.local_endpoint()),
      device_(std::move(device)),
      last_advance_(clock.Now()) {}

LinMotServer::~LinMotServer() { Stop(); }

void LinMotServer::Stop() {
  if (running_.exchange(false)) {
    socket_.Shutdown();
  }
  if (thread_.joinable()) {
    thread_.join();
    log::Info("linmot_sim.stopped", log::Fields().Add("drive", options_.name));
  }
}

void LinMotServer::Run() {
  while (running_.load()) {
    Duration wait = std::chrono::milliseconds(50);
    {
      std::lock_guard lock(mu_);
      // Delayed replies are due on the injected clock, which may be a ManualClock: poll it.
      if (!pending_.empty()) wait = std::chrono::milliseconds(1);
    }
    auto received = socket_.Receive(wait);
    if (!received.ok()) {
      if (absl::IsCancelled(received.status())) break;
      log::Warn(
          "linmot_sim.receive_failed",
          log::Fields().Add("drive", options_.name).Add("error", received.status().message()));
      continue;
    }
    std::lock_guard lock(mu_);
    AdvanceLocked();
    if (received->has_value()) HandleDatagramLocked(**received);
    FlushDueLocked();
  }
}

void LinMotServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (now > last_advance_) {
    device_->Advance(now - last_advance_);
    last_advance_ = now;
  }
}

void LinMotServer::HandleDatagramLocked(const transport::Datagram& d) {
  ++counters_.datagrams_received;
  // only the configured master port is answered (0 = any port, tests).
  if (options_.master_port != 0 && d.from.port != options_.master_port) {
    ++counters_.dropped_wrong_port;
    return;
  }
  // A-15 master filter.
  if ((options_.master_filter == MasterFilter::kSingleMasterFixIp &&
       d.from.ipv4 != options_.master_ip) ||
      (options_.master_filter == MasterFilter::kSingleMaster && latched_master_ip_ &&
       *latched_master_ip_ != d.from.ipv4)) {
    ++counters_.dropped_filtered;
    return;
  }
  if (!answering_) {
    ++counters_.dropped_not_answering;
    return;
  }
  // a datagram too short for its flagged blocks is counted and dropped.
  auto request = linudp::DecodeRequest(d.bytes);
  if (!request.ok()) {
    ++counters_.malformed;
    log::Debug("linmot_sim.malformed", log::Fields()
                                           .Add("drive", options_.name)
                                           .Add("from", d.from.ToString())
                                           .Add("error", request.status().message()));
    return;
  }
  if (options_.master_filter == MasterFilter::kSingleMaster && !latched_master_ip_) {
    latched_master_ip_ = d.from.ipv4;
  }
  auto reply = device_->Handle(*request);
  if (!reply) {
    ++counters_.dropped_not_answering;  // booting
    return;
  }
  // the reply goes to <source ip>:<master port>; A-06: zero fill to the minimum payload.
  const transport::Endpoint to{d.from.ipv4,
                               options_.master_port != 0 ? options_.master_port : d.from.port};
  QueueReplyLocked(to, linudp::EncodeReply(*reply, options_.min_reply_payload));
}

void LinMotServer::QueueReplyLocked(const transport::Endpoint& to, std::vector<uint8_t> bytes) {
  transport::ImpairmentDecision decision;
  if (impairment_) decision = impairment_->Decide();
  if (decision.drop) {
    ++counters_.replies_dropped;
    return;
  }
  const TimePoint now = clock_.Now();
  auto enqueue = [&](Duration delay, std::vector<uint8_t> b) {
    if (delay <= Duration{0}) {
      if (socket_.SendTo(to, b).ok()) {
        ++counters_.replies_sent;
      } else {
        ++counters_.send_errors;
      }
      return;
    }
    PendingReply p{now + delay, to, std::move(b)};
    auto it = std::upper_bound(pending_.begin(), pending_.end(), p.due,
                               [](TimePoint t, const PendingReply& q) { return t < q.due; });
    pending_.insert(it, std::move(p));
  };
  const Duration first = reply_delay_ + decision.delay;
  if (first > Duration{0}) ++counters_.replies_delayed;
  if (decision.duplicate) {
    ++counters_.replies_duplicated;
    enqueue(reply_delay_ + decision.duplicate_delay, bytes);
  }
  enqueue(first, std::move(bytes));
}

void LinMotServer::FlushDueLocked() {
  const TimePoint now = clock_.Now();
  while (!pending_.empty() && pending_.front().due <= now) {
    if (socket_.SendTo(pending_.front().to, pending_.front().bytes).ok()) {
      ++counters_.replies_sent;
    } else {
      ++counters_.send_errors;
    }
    pending_.pop_front();
  }
}

SimSnapshot LinMotServer::Snapshot() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  return SimSnapshot{device_->Snapshot(), counters_};
}

ServerCounters LinMotServer::counters() const {
  std::lock_guard lock(mu_);
  return counters_;
}

absl::Status LinMotServer::RaiseError(uint16_t code) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  return device_->RaiseError(code);
}

void LinMotServer::SetInjectedWarnings(uint16_t warn_bits) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  device_->SetInjectedWarnings(warn_bits);
}

void LinMotServer::SetMotorBlocked(bool blocked) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  device_->SetMotorBlocked(blocked);
}

absl::Status LinMotServer::SetImpairment(const transport::Impairment& impairment) {
  if (absl::Status s = transport::ImpairedLink::Validate(impairment); !s.ok()) return s;
  std::lock_guard lock(mu_);
  impairment_.emplace(impairment);
  return absl::OkStatus();
}

void LinMotServer::SetReplyDelay(Duration delay) {
  std::lock_guard lock(mu_);
  reply_delay_ = std::max(delay, Duration{0});
}

void LinMotServer::SetAnswering(bool answering) {
  std::lock_guard lock(mu_);
  answering_ = answering;
}

void LinMotServer::WithDevice(const std::function<void(LinMotDevice&)>& fn) {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  fn(*device_);
}

}  // namespace drivegw::sim::linmot
