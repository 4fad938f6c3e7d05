// SlaveNode PDOs and SYNC: synchronous TPDOs every n-th SYNC, acyclic (type 0) and RTR-sampled
// (type 252) ones, event-driven TPDOs (254/255) with inhibit time and event timer, RPDOs applied
// on reception or, when synchronous, at the next SYNC, RPDO length and deadline errors.
// Source: CiA 301 v4.2.0 §7.2.2 (PDO, transmission types, Figure 14), §7.2.5 (SYNC),
// §7.5.2.35-38; decisions 1128, 1132.
#include <utility>

#include "adapters/canopen/emcy.h"
#include "adapters/canopen/sync.h"
#include "sim/canopen/node.h"

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;
using co::PdoKind;

// §7.4.7.1 dummy entries (RPDO only): data is skipped.
bool IsDummy(const co::PdoMappingEntry& e) {
  return e.index >= 0x0001 && e.index <= 0x0007 && e.sub == 0;
}

Duration InhibitTime(uint16_t units_100us) { return std::chrono::microseconds(100) * units_100us; }

}  // namespace

absl::Status SlaveNode::ConfigureDefaultPdo(PdoKind kind, uint16_t number,
                                            const co::PdoCommParams& comm,
                                            std::span<const co::PdoMappingEntry> mapping) {
  if (absl::Status s = SetDefaultPdo(od_, kind, number, options_.node_id, comm, mapping); !s.ok()) {
    return s;
  }
  if (kind == PdoKind::kTpdo) {
    tpdo_[number - 1] = {};
  } else {
    rpdo_[number - 1] = {};
  }
  return absl::OkStatus();
}

void SlaveNode::ResetPdoRuntime() {
  tpdo_ = {};
  rpdo_ = {};
}

void SlaveNode::RequestTpdo(uint16_t number) {
  if (number < 1 || number > kPdoCount) return;
  tpdo_[number - 1].requested = true;
  if (booted_ && state_ == NmtState::kOperational) RunEventTpdos();
}

absl::StatusOr<std::vector<uint8_t>> SlaveNode::PackTpdo(const PdoConfig& config) {
  std::vector<uint64_t> values;
  values.reserve(config.mapping.size());
  for (const co::PdoMappingEntry& e : config.mapping) {
    // The bus read path: read hooks let the model supply the value at this instant.
    auto bytes = od_.Read(e.index, e.sub);
    if (!bytes.ok()) return bytes.status();
    uint64_t v = 0;
    for (size_t i = 0; i < bytes->size() && i < 8; ++i) {
      v |= static_cast<uint64_t>((*bytes)[i]) << (8 * i);
    }
    if (e.bits < 64) v &= (uint64_t{1} << e.bits) - 1;
    values.push_back(v);
  }
  return co::PackPdoRaw(config.mapping, values);
}

void SlaveNode::SendTpdo(const PdoConfig& config, std::vector<uint8_t> payload) {
  TpdoState& st = tpdo_[config.number - 1];
  // The node's view does not depend on whether a fault swallows the frame.
  if (Emit(transport::MakeCanFrame(config.can_id, payload))) ++counters_.tpdos_sent;
  st.last_sent = now_;
  st.last_payload = std::move(payload);
  st.syncs = 0;
  st.requested = false;
  if (config.event_ms != 0) {
    st.next_event = now_ + std::chrono::milliseconds(config.event_ms);
  } else {
    st.next_event.reset();
  }
}

void SlaveNode::RunEventTpdos() {
  for (uint16_t n = 1; n <= kPdoCount; ++n) {
    auto config = ReadPdoConfig(od_, PdoKind::kTpdo, n);
    if (!config.ok() || !config->valid ||
        config->transmission_type < co::kTransmissionEventManufacturer) {
      continue;
    }
    TpdoState& st = tpdo_[n - 1];
    auto payload = PackTpdo(*config);
    if (!payload.ok()) continue;
    // Events (decision 1128): an application request, a change of the mapped data against the
    // last transmission (also the first transmission after entering OPERATIONAL), the event
    // timer.
    const bool event = st.requested || !st.last_payload || *st.last_payload != *payload ||
                       (st.next_event && now_ >= *st.next_event);
    if (!event) continue;
    // §7.5.2.37 sub 3: no transmission within the inhibit time of the last one; the event is
    // kept and sent with the data current when it ends.
    if (config->inhibit_100us != 0 && st.last_sent &&
        now_ < *st.last_sent + InhibitTime(config->inhibit_100us)) {
      continue;
    }
    SendTpdo(*config, *std::move(payload));
  }
}

void SlaveNode::HandleSync(const transport::CanFrame& frame) {
  if (state_ != NmtState::kOperational) {
    ++counters_.frames_ignored;  // Table 86: SYNC acts in OPERATIONAL only
    return;
  }
  // No 1019h: the counter byte of a 1-byte SYNC is accepted and ignored; longer SYNCs are
  // refused with EMCY 8240h (§7.2.5; decision 1132).
  auto sync = co::DecodeSync(frame, static_cast<uint16_t>(frame.id));
  if (!sync.ok()) {
    RaiseEmcy(co::emcy_code::kUnexpectedSyncLength, co::error_register::kCommunication);
    return;
  }
  ++counters_.syncs;
  // Figure 14: inputs are sampled at the SYNC for synchronous TPDOs, before the synchronous
  // RPDOs received in the last cycle are actuated (decision 1128).
  for (uint16_t n = 1; n <= kPdoCount; ++n) {
    auto config = ReadPdoConfig(od_, PdoKind::kTpdo, n);
    if (!config.ok() || !config->valid) continue;
    TpdoState& st = tpdo_[n - 1];
    const uint8_t type = config->transmission_type;
    if (type == co::kTransmissionSyncAcyclic) {
      auto payload = PackTpdo(*config);
      if (payload.ok() && (st.requested || !st.last_payload || *st.last_payload != *payload)) {
        SendTpdo(*config, *std::move(payload));
      }
    } else if (type <= co::kTransmissionSyncEveryMax) {
      if (++st.syncs >= type) {
        auto payload = PackTpdo(*config);
        if (payload.ok()) SendTpdo(*config, *std::move(payload));
      }
    } else if (type == co::kTransmissionSyncRtr) {
      auto payload = PackTpdo(*config);
      if (payload.ok()) st.rtr_sample = *std::move(payload);
    }
  }
  for (uint16_t n = 1; n <= kPdoCount; ++n) {
    RpdoState& st = rpdo_[n - 1];
    if (!st.pending) continue;
    std::vector<uint8_t> payload = *std::move(st.pending);
    st.pending.reset();
    auto config = ReadPdoConfig(od_, PdoKind::kRpdo, n);
    if (config.ok() && config->valid &&
        config->transmission_type <= co::kTransmissionSyncEveryMax) {
      ApplyRpdo(*config, payload);
    }
  }
}

bool SlaveNode::HandlePdo(const transport::CanFrame& frame) {
  if (state_ != NmtState::kOperational) return false;
  if (frame.rtr) {
    for (uint16_t n = 1; n <= kPdoCount; ++n) {
      auto config = ReadPdoConfig(od_, PdoKind::kTpdo, n);
      if (!config.ok() || !config->valid || config->can_id != frame.id) continue;
      if (!config->rtr_allowed) return false;  // COB-ID bit 30: RTR not answered
      TpdoState& st = tpdo_[n - 1];
      if (config->transmission_type == co::kTransmissionSyncRtr) {
        if (st.rtr_sample) SendTpdo(*config, *st.rtr_sample);
      } else {
        auto payload = PackTpdo(*config);
        if (payload.ok()) SendTpdo(*config, *std::move(payload));
      }
      return true;
    }
    return false;
  }
  for (uint16_t n = 1; n <= kPdoCount; ++n) {
    auto config = ReadPdoConfig(od_, PdoKind::kRpdo, n);
    if (!config.ok() || !config->valid || config->can_id != frame.id) continue;
    const auto payload = frame.payload();
    if (payload.size() < co::MappingBytes(config->mapping)) {
      // §7.2.2.2: too short an RPDO is not processed; EMCY 8210h.
      RaiseEmcy(co::emcy_code::kPdoLengthError, co::error_register::kCommunication);
      return true;
    }
    ++counters_.rpdos_received;
    RpdoState& st = rpdo_[n - 1];
    if (config->event_ms != 0) {
      // Deadline monitoring starts with the first RPDO (§7.5.2.35 sub 5).
      st.deadline = now_ + std::chrono::milliseconds(config->event_ms);
      st.deadline_missed = false;
    }
    if (config->transmission_type <= co::kTransmissionSyncEveryMax) {
      st.pending.emplace(payload.begin(), payload.end());  // the latest one before the SYNC
    } else {
      ApplyRpdo(*config, payload);
    }
    return true;
  }
  return false;
}

void SlaveNode::ApplyRpdo(const PdoConfig& config, std::span<const uint8_t> payload) {
  auto values = co::UnpackPdoRaw(config.mapping, payload);
  if (!values.ok()) return;
  for (size_t i = 0; i < config.mapping.size(); ++i) {
    const co::PdoMappingEntry& e = config.mapping[i];
    if (IsDummy(e)) continue;
    std::vector<uint8_t> bytes(e.bits / 8);
    for (size_t b = 0; b < bytes.size(); ++b) {
      bytes[b] = static_cast<uint8_t>((*values)[i] >> (8 * b));
    }
    // The bus write path: range checks and the model's write hooks apply as for SDO.
    if (!od_.Write(e.index, e.sub, bytes).ok()) ++counters_.rpdo_write_errors;
  }
  ++counters_.rpdos_applied;
  if (model_ != nullptr) model_->OnRpdoWritten(*this, config.number);
}

}  // namespace drivegw::sim::canopen
