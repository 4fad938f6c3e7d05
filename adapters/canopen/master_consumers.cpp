// CanopenMaster consumers: heartbeat / boot-up (error control 700h + n), EMCY (080h + n) and TPDO
// frames turned into node notifications; the heartbeat producer and 1029h helpers.
// Source: CiA 301 v4.2.0 §7.2.8.3.2 (heartbeat, boot-up), §7.2.7.3.1 (EMCY), §7.2.2 (PDO);
// decisions 1113-1115.
#include <algorithm>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/master.h"
#include "adapters/core/log.h"

namespace drivegw::canopen {
namespace {

int64_t Ms(Duration d) { return std::chrono::duration_cast<std::chrono::milliseconds>(d).count(); }

}  // namespace

void CanopenMaster::HandleErrorControlLocked(const transport::CanFrame& frame, TimePoint now) {
  absl::StatusOr<ErrorControl> ec = DecodeErrorControl(frame);
  if (!ec.ok()) {
    ++counters_.malformed;
    log::Debug("canopen_malformed", log::Fields()
                                        .Add("bus", bus_name_)
                                        .Add("frame", transport::FormatCanFrame(frame))
                                        .Add("error", ec.status().message()));
    return;
  }
  // Our own heartbeat looped back by the bus is no node's (decision 1483).
  if (own_node_ != 0 && ec->node == own_node_) return;
  Node& n = nodes_[ec->node];
  n.nmt = ec->state;
  Heartbeat& hb = n.heartbeat;
  Notification note;
  note.node = ec->node;
  if (ec->state == NmtState::kBootUp) {
    // CiA 301 §7.2.8.3.2.3: the node (re)started with its default configuration. Supervision
    // waits for its first heartbeat again (decision 1114).
    ++counters_.bootups;
    hb.state = Heartbeat::State::kWaiting;
    note.kind = Notification::Kind::kBootUp;
    note.event = NodeEventInfo{NodeEvent::kBootUp, ec->node, now,
                               absl::StrCat("node ", ec->node, " sent its boot-up message")};
    log::Info("canopen_boot_up",
              log::Fields().Add("bus", bus_name_).Add("node", static_cast<int>(ec->node)));
  } else {
    ++counters_.heartbeats;
    const bool was_lost = hb.state == Heartbeat::State::kLost;
    hb.state = Heartbeat::State::kAlive;
    hb.last = now;
    if (was_lost && hb.consumer_time > Duration::zero()) {
      Notification back;
      back.kind = Notification::Kind::kLink;
      back.node = ec->node;
      back.event = NodeEventInfo{NodeEvent::kHeartbeatResumed, ec->node, now,
                                 absl::StrCat("heartbeat of node ", ec->node, " back (",
                                              std::string(NmtStateName(ec->state)), ")")};
      log::Warn("canopen_heartbeat_resumed",
                log::Fields().Add("bus", bus_name_).Add("node", static_cast<int>(ec->node)));
      if (HasObserverLocked(ec->node)) pending_.push_back(std::move(back));
    }
    note.kind = Notification::Kind::kHeartbeat;
    note.state = ec->state;
    note.event.at = now;
  }
  if (HasObserverLocked(ec->node)) pending_.push_back(std::move(note));
}

void CanopenMaster::HandleEmcyLocked(const transport::CanFrame& frame, TimePoint now) {
  absl::StatusOr<Emcy> emcy = DecodeEmcy(frame);
  if (!emcy.ok()) {
    ++counters_.malformed;
    log::Debug("canopen_malformed", log::Fields()
                                        .Add("bus", bus_name_)
                                        .Add("frame", transport::FormatCanFrame(frame))
                                        .Add("error", emcy.status().message()));
    return;
  }
  ++counters_.emcy;
  Notification note;
  note.kind = Notification::Kind::kEmcy;
  note.node = emcy->node;
  note.emcy = EmcyEvent{*emcy, EmcyCodeName(emcy->error_code), now};
  log::Warn("canopen_emcy",
            log::Fields()
                .Add("bus", bus_name_)
                .Add("node", static_cast<int>(emcy->node))
                .Add("code", "\"" + note.emcy.name + "\"")
                .Add("error_register", absl::StrFormat("0x%02X", emcy->error_register)));
  if (HasObserverLocked(emcy->node)) pending_.push_back(std::move(note));
}

void CanopenMaster::HandleTpdoLocked(uint8_t node, uint16_t number,
                                     const transport::CanFrame& frame, TimePoint now) {
  ++counters_.tpdo_received;
  if (!HasObserverLocked(node)) return;
  Notification note;
  note.kind = Notification::Kind::kTpdo;
  note.node = node;
  note.tpdo.node = node;
  note.tpdo.number = number;
  note.tpdo.cob_id = static_cast<uint16_t>(frame.id);
  note.tpdo.size = static_cast<uint8_t>(frame.payload().size());
  std::copy(frame.payload().begin(), frame.payload().end(), note.tpdo.data.begin());
  note.tpdo.at = now;
  pending_.push_back(std::move(note));
}

// ---------------------------------------------------------------------------------------------
// Heartbeat consumer and producer, 1029h.

absl::Status CanopenMaster::SetHeartbeatConsumer(uint8_t node, Duration consumer_time) {
  if (absl::Status s = ValidateNodeId(node, "heartbeat.node_id"); !s.ok()) return s;
  if (consumer_time < Duration::zero()) {
    return absl::InvalidArgumentError(absl::StrCat("canopen heartbeat.consumer_time of node ", node,
                                                   ": ", Ms(consumer_time), " ms is negative"));
  }
  {
    std::lock_guard lock(mu_);
    Heartbeat& hb = nodes_[node].heartbeat;
    hb.consumer_time = consumer_time;
    if (consumer_time == Duration::zero() && hb.state == Heartbeat::State::kLost) {
      hb.state = Heartbeat::State::kWaiting;
    }
  }
  WakeReceiver();  // the next expiry may be earlier than the thread's current wait
  return absl::OkStatus();
}

absl::Status CanopenMaster::StartOwnHeartbeat(uint8_t own_node, Duration period) {
  if (absl::Status s = ValidateNodeId(own_node, "master_node_id"); !s.ok()) return s;
  if (period <= Duration::zero()) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen own heartbeat of node ", own_node, ": period must be > 0"));
  }
  {
    std::lock_guard lock(mu_);
    if (own_node_ == own_node) return absl::OkStatus();
    if (own_node_ != 0) {
      return absl::FailedPreconditionError(absl::StrCat(
          "canopen master ", bus_name_, " already produces its heartbeat as node ", own_node_,
          "; node ", own_node, " asked (one master node ID per bus, decision 1483)"));
    }
    own_node_ = own_node;
    own_period_ = period;
    next_own_heartbeat_ = clock_.Now();  // the first one at once: consumers start on it
    log::Info("canopen_own_heartbeat", log::Fields()
                                           .Add("bus", bus_name_)
                                           .Add("node", static_cast<int>(own_node))
                                           .Add("period_ms", Ms(period)));
  }
  WakeReceiver();
  return absl::OkStatus();
}

absl::Status CanopenMaster::ConfigureHeartbeatConsumer(uint8_t node, uint8_t producer,
                                                       uint16_t time_ms, TimePoint deadline,
                                                       uint8_t sub) {
  // CiA 301 §7.5.2.19: 1016h sub 1..n u32, bits 23..16 producer node ID, 15..0 time in ms.
  const uint32_t value = static_cast<uint32_t>(producer) << 16 | time_ms;
  if (absl::Status s = WriteU32(node, 0x1016, sub, value, deadline, SdoRetry::kIdempotent);
      !s.ok()) {
    return s;
  }
  absl::StatusOr<uint32_t> back = ReadU32(node, 0x1016, sub, deadline);
  if (!back.ok()) return back.status();
  if (*back != value) {
    return absl::FailedPreconditionError(absl::StrCat(
        "canopen node ", node, " 1016h:", sub, " consumer heartbeat: wrote 0x",
        absl::Hex(value, absl::kZeroPad8), ", reads back 0x", absl::Hex(*back, absl::kZeroPad8)));
  }
  return absl::OkStatus();
}

absl::Status CanopenMaster::ConfigureHeartbeatProducer(uint8_t node, uint16_t period_ms,
                                                       TimePoint deadline) {
  // CiA 301 §7.5.2.20: 1017h u16 producer heartbeat time in ms, 0 = off.
  // Values, not commands: repeating a write after a time-out is harmless (decision 1481).
  if (absl::Status s = WriteU16(node, 0x1017, 0, period_ms, deadline, SdoRetry::kIdempotent);
      !s.ok()) {
    return s;
  }
  absl::StatusOr<uint16_t> back = ReadU16(node, 0x1017, 0, deadline);
  if (!back.ok()) return back.status();
  if (*back != period_ms) {
    return absl::FailedPreconditionError(absl::StrCat("canopen node ", node,
                                                      " 1017h producer heartbeat time: wrote ",
                                                      period_ms, " ms, reads back ", *back, " ms"));
  }
  return absl::OkStatus();
}

absl::Status CanopenMaster::ConfigureErrorBehaviour(uint8_t node, ErrorBehaviour behaviour,
                                                    TimePoint deadline, uint8_t sub) {
  // CiA 301 §7.5.2.32: 1029h sub 0 is the entry count; sub 1 communication error, 2.. profile or
  // manufacturer-specific error classes, each u8 0/1/2.
  if (sub == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen node ", node, " 1029h sub 0: the entry count, not a behaviour"));
  }
  return WriteU8(node, 0x1029, sub, static_cast<uint8_t>(behaviour), deadline,
                 SdoRetry::kIdempotent);
}

}  // namespace drivegw::canopen
