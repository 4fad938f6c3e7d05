// LinMotServer: the UDP side of the simulated drive (linmot-linudp.md)
// plus reply impairment and link-loss hooks; physics advanced to the injected clock.
#include "sim/linmot/server.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "adapters/core/log.h"
#include "adapters/linmot/linudp/codec.h"
#include "sim/linmot/device.h"
#include "sim/linmot/io_loop.h"

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
  if (absl::Status s = SharedIoLoop::Instance().Add(server->socket_.native_handle(),
                                                    [p = server.get()] { return p->OnReadable(); });
      !s.ok()) {
    server->running_ = false;
    return s;
  }
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
      last_advance_(clock.Now()) {
  for (size_t i = 0; i < kReceiveSlots; ++i) receive_slots_[i].buffer = receive_buffers_[i];
}

LinMotServer::~LinMotServer() { Stop(); }

void LinMotServer::Stop() {
  if (running_.exchange(false)) {
    SharedIoLoop::Instance().Remove(socket_.native_handle());  // no handler runs after this
    socket_.Shutdown();
    log::Info("linmot_sim.stopped", log::Fields().Add("drive", options_.name));
  }
}

bool LinMotServer::OnReadable() {
  std::lock_guard lock(mu_);
  AdvanceLocked();
  absl::StatusOr<size_t> received = socket_.TryReceiveBatch(receive_slots_);
  if (!received.ok()) {
    if (!absl::IsCancelled(received.status())) {
      log::Warn(
          "linmot_sim.receive_failed",
          log::Fields().Add("drive", options_.name).Add("error", received.status().message()));
    }
  } else {
    for (size_t i = 0; i < *received; ++i) {
      const transport::DatagramSlot& d = receive_slots_[i];
      ImpairRequestLocked(d.from, std::span<const uint8_t>(d.buffer.data(), d.size));
    }
  }
  FlushDueLocked();
  return !pending_.empty();
}

void LinMotServer::AdvanceLocked() {
  const TimePoint now = clock_.Now();
  if (now > last_advance_) {
    device_->Advance(now - last_advance_);
    last_advance_ = now;
  }
}

void LinMotServer::ImpairRequestLocked(const transport::Endpoint& from,
                                       std::span<const uint8_t> bytes) {
  if (!request_impairment_) {
    HandleDatagramLocked(from, bytes);
    return;
  }
  const transport::ImpairmentDecision d = request_impairment_->Decide();
  if (d.drop) {
    ++counters_.requests_dropped;
    return;
  }
  std::vector<uint8_t> copy(bytes.begin(), bytes.end());
  if (d.corrupt) {
    ++counters_.requests_corrupted;
    copy.resize(transport::TruncatedLength(copy.size(), d.corrupt_bits));
  }
  if (d.reorder && !held_request_) {
    ++counters_.requests_reordered;
    held_request_ = HeldRequest{from, std::move(copy)};
    return;
  }
  HandleDatagramLocked(from, copy);
  if (d.duplicate) {
    ++counters_.requests_duplicated;
    HandleDatagramLocked(from, copy);
  }
  if (held_request_) {
    HeldRequest held = std::move(*held_request_);
    held_request_.reset();
    HandleDatagramLocked(held.from, held.bytes);
  }
}

void LinMotServer::HandleDatagramLocked(const transport::Endpoint& from,
                                        std::span<const uint8_t> bytes) {
  ++counters_.datagrams_received;
  // only the configured master port is answered (0 = any port, tests).
  if (options_.master_port != 0 && from.port != options_.master_port) {
    ++counters_.dropped_wrong_port;
    return;
  }
  // A-15 master filter.
  if ((options_.master_filter == MasterFilter::kSingleMasterFixIp &&
       from.ipv4 != options_.master_ip) ||
      (options_.master_filter == MasterFilter::kSingleMaster && latched_master_ip_ &&
       *latched_master_ip_ != from.ipv4)) {
    ++counters_.dropped_filtered;
    return;
  }
  if (!answering_) {
    ++counters_.dropped_not_answering;
    return;
  }
  // a datagram too short for its flagged blocks is counted and dropped.
  auto request = linudp::DecodeRequest(bytes);
  if (!request.ok()) {
    ++counters_.malformed;
    log::Debug("linmot_sim.malformed", log::Fields()
                                           .Add("drive", options_.name)
                                           .Add("from", from.ToString())
                                           .Add("error", request.status().message()));
    return;
  }
  if (options_.master_filter == MasterFilter::kSingleMaster && !latched_master_ip_) {
    latched_master_ip_ = from.ipv4;
  }
  auto reply = device_->Handle(*request);
  if (!reply) {
    ++counters_.dropped_not_answering;  // booting
    return;
  }
  // the reply goes to <source ip>:<master port>; A-06: zero fill to the minimum payload.
  const transport::Endpoint to{from.ipv4,
                               options_.master_port != 0 ? options_.master_port : from.port};
  QueueReplyLocked(to, linudp::EncodeReply(*reply, options_.min_reply_payload));
}

void LinMotServer::QueueReplyLocked(const transport::Endpoint& to, std::vector<uint8_t> bytes) {
  transport::ImpairmentDecision decision;
  if (impairment_) decision = impairment_->Decide();
  if (decision.drop) {
    ++counters_.replies_dropped;
    return;
  }
  if (decision.corrupt) {
    ++counters_.replies_corrupted;
    bytes.resize(transport::TruncatedLength(bytes.size(), decision.corrupt_bits));
  }
  if (decision.reorder && !held_reply_) {
    ++counters_.replies_reordered;
    held_reply_ = HeldReply{to, std::move(bytes)};
    return;
  }
  const TimePoint now = clock_.Now();
  auto enqueue = [&](Duration delay, std::vector<uint8_t> b, const transport::Endpoint& dest) {
    if (delay <= Duration{0}) {
      if (socket_.SendTo(dest, b).ok()) {
        ++counters_.replies_sent;
      } else {
        ++counters_.send_errors;
      }
      return;
    }
    PendingReply p{now + delay, dest, std::move(b)};
    auto it = std::upper_bound(pending_.begin(), pending_.end(), p.due,
                               [](TimePoint t, const PendingReply& q) { return t < q.due; });
    pending_.insert(it, std::move(p));
  };
  const Duration first = reply_delay_ + decision.delay;
  if (first > Duration{0}) ++counters_.replies_delayed;
  if (decision.duplicate) {
    ++counters_.replies_duplicated;
    enqueue(reply_delay_ + decision.duplicate_delay, bytes, to);
  }
  enqueue(first, std::move(bytes), to);
  if (held_reply_) {  // explicit reorder: the held reply goes right after this one
    HeldReply held = std::move(*held_reply_);
    held_reply_.reset();
    enqueue(first, std::move(held.bytes), held.to);
  }
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

absl::Status LinMotServer::SetRequestImpairment(const transport::Impairment& impairment) {
  if (absl::Status s = transport::ImpairedLink::Validate(impairment); !s.ok()) return s;
  std::lock_guard lock(mu_);
  request_impairment_.emplace(impairment);
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
