// SlaveNode: NMT slave state machine, SDO server, heartbeat producer/consumer, EMCY producer,
// 1029h error behaviour and fault injection (CiA 301 v4.2.0 §7.2.4, §7.2.7, §7.2.8, §7.5.2;
// decisions 1126-1133). PDOs and SYNC: node_pdo.cpp.
#include "sim/canopen/node.h"

#include <algorithm>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/emcy.h"

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;

constexpr uint8_t kAbortCommand = 0x80;  // cs 4 in byte 0 of an SDO abort frame

std::chrono::milliseconds Ms(int64_t ms) { return std::chrono::milliseconds(ms); }

}  // namespace

// The dictionary as the SDO server sees it: injected aborts first, and the data of an expedited
// download without size indication cut to the object's size (§7.2.4.3.3: with e = 1, s = 0 the
// server takes the size from the object; decision 1127).
class SlaveNode::SdoObjects : public co::ObjectAccess {
 public:
  explicit SdoObjects(SlaveNode& node) : node_(node) {}

  absl::StatusOr<std::vector<uint8_t>> Read(uint16_t index, uint8_t sub) override {
    if (absl::Status s = Injected(index, sub); !s.ok()) return s;
    return node_.od_.Read(index, sub);
  }
  absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) override {
    if (absl::Status s = Injected(index, sub); !s.ok()) return s;
    if (node_.unsized_expedited_) {
      if (const ObjectDef* def = node_.od_.Find(index, sub); def != nullptr) {
        const size_t size = DataTypeSize(def->type);
        if (size != 0 && size < data.size()) data = data.first(size);
      }
    }
    return node_.od_.Write(index, sub, data);
  }

 private:
  absl::Status Injected(uint16_t index, uint8_t sub) const {
    auto it = node_.injected_aborts_.find({index, sub});
    if (it == node_.injected_aborts_.end()) return absl::OkStatus();
    return co::SdoAbortStatus(it->second, ObjectLabel(index, sub) + ": injected fault");
  }
  SlaveNode& node_;
};

absl::StatusOr<std::unique_ptr<SlaveNode>> SlaveNode::Create(const SlaveNodeOptions& options,
                                                             DeviceModel* model) {
  if (absl::Status s = co::ValidateNodeId(options.node_id, "options.node_id"); !s.ok()) return s;
  if (options.sdo_timeout <= Duration::zero()) {
    return absl::InvalidArgumentError("options.sdo_timeout: must be positive");
  }
  if (options.max_tick < Duration::zero()) {
    return absl::InvalidArgumentError("options.max_tick: must not be negative");
  }
  if (options.master_node != 0) {
    if (absl::Status s = co::ValidateNodeId(options.master_node, "options.master_node"); !s.ok()) {
      return s;
    }
    if (options.master_node == options.node_id) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.master_node: ", options.master_node, " is this node's own id"));
    }
  }
  // A private constructor: make_unique cannot reach it.
  std::unique_ptr<SlaveNode> node(new SlaveNode(options, model));
  ObjectDictionary& od = node->od_;
  if (absl::Status s = AddCommunicationObjects(od, options.node_id, options.identity); !s.ok()) {
    return s;
  }
  absl::Status s = od.SetDefaultInt(0x1017, 0, options.heartbeat_ms);
  if (s.ok()) s = od.SetDefaultInt(0x1029, 1, static_cast<int64_t>(options.error_behaviour));
  if (s.ok() && options.master_node != 0 && options.master_heartbeat_ms != 0) {
    s = od.SetDefaultInt(
        0x1016, 1, static_cast<int64_t>(options.master_node) << 16 | options.master_heartbeat_ms);
  }
  if (!s.ok()) return s;
  auto channel = co::DefaultSdoChannel(options.node_id);
  if (!channel.ok()) return channel.status();
  node->sdo_objects_ = std::make_unique<SdoObjects>(*node);
  node->sdo_.emplace(*channel, *node->sdo_objects_, options.sdo_max_download);
  SlaveNode* self = node.get();
  od.AddWriteObserver([self](uint16_t index, uint8_t sub) { self->OnDictionaryWrite(index, sub); });
  if (model != nullptr) {
    if (absl::Status c = model->Configure(*node); !c.ok()) return c;
  }
  return node;
}

SlaveNode::SlaveNode(const SlaveNodeOptions& options, DeviceModel* model)
    : options_(options), model_(model) {}

SlaveNode::~SlaveNode() = default;

std::vector<transport::CanFrame> SlaveNode::TakeFrames() { return std::exchange(outbox_, {}); }

bool SlaveNode::Emit(const transport::CanFrame& frame) {
  if (silent_) {
    ++counters_.suppressed;
    return false;
  }
  outbox_.push_back(frame);
  return true;
}

bool SlaveNode::EmitErrorControl(NmtState state) {
  if (heartbeat_lost_ && state != NmtState::kBootUp) {
    ++counters_.suppressed;
    return false;
  }
  auto frame = co::EncodeErrorControl({options_.node_id, state, false});
  return frame.ok() && Emit(*frame);
}

void SlaveNode::ScheduleHeartbeat() {
  // §7.2.8.3.2.3: the producer starts right after the boot-up message; a new 1017h value
  // restarts it from now (decision 1129).
  const int64_t ms = od_.GetInt(0x1017, 0).value_or(0);
  if (ms == 0) {
    next_heartbeat_.reset();
  } else {
    next_heartbeat_ = now_ + Ms(ms);
  }
}

void SlaveNode::Boot(TimePoint now) {
  if (booted_) return;
  booted_ = true;
  now_ = now;
  ticked_to_ = now;
  state_ = NmtState::kBootUp;
  if (EmitErrorControl(NmtState::kBootUp)) ++counters_.boot_ups;
  ScheduleHeartbeat();
  SetState(NmtState::kPreOperational);
}

void SlaveNode::Reboot(TimePoint now) {
  Advance(now);
  if (!booted_) {
    Boot(now);
    return;
  }
  ResetNode(/*application=*/true);
}

void SlaveNode::ResetNode(bool application) {
  // Figure 48: reset application (2000h..9FFFh) includes reset communication (1000h..1FFFh);
  // both end with the boot-up message and PRE-OPERATIONAL (§7.2.8.2.2.4).
  const NmtState from = state_;
  state_ = NmtState::kBootUp;
  if (application) od_.ResetToDefaults(0x2000, 0x9FFF);
  od_.ResetToDefaults(0x1000, 0x1FFF);
  sdo_.emplace(*co::DefaultSdoChannel(options_.node_id), *sdo_objects_, options_.sdo_max_download);
  sdo_deadline_.reset();
  consumers_.clear();
  ResetPdoRuntime();
  if (model_ != nullptr && from != NmtState::kBootUp) {
    model_->OnNmtChange(*this, from, NmtState::kBootUp);
  }
  if (application && model_ != nullptr) model_->OnResetApplication(*this);
  if (EmitErrorControl(NmtState::kBootUp)) ++counters_.boot_ups;
  ScheduleHeartbeat();
  SetState(NmtState::kPreOperational);
}

void SlaveNode::SetState(NmtState to) {
  if (to == state_) return;
  const NmtState from = state_;
  state_ = to;
  if (from == NmtState::kOperational || to == NmtState::kOperational) {
    // PDOs exist only in OPERATIONAL (Table 86): leaving drops buffered synchronous RPDOs and
    // deadlines; entering starts SYNC counting afresh and sends event-driven TPDOs once
    // (decision 1128).
    ResetPdoRuntime();
  }
  if (to == NmtState::kStopped) {
    // No SDO in STOPPED (Table 86): a transfer in progress is dropped without an abort.
    sdo_.emplace(*co::DefaultSdoChannel(options_.node_id), *sdo_objects_,
                 options_.sdo_max_download);
    sdo_deadline_.reset();
  }
  if (model_ != nullptr) model_->OnNmtChange(*this, from, to);
}

void SlaveNode::TickModel(TimePoint now) {
  if (now <= ticked_to_) return;
  Duration left = now - ticked_to_;
  ticked_to_ = now;
  if (model_ == nullptr) return;
  const Duration step = options_.max_tick > Duration::zero() ? options_.max_tick : left;
  while (left > Duration::zero()) {
    const Duration dt = std::min(step, left);
    model_->Tick(*this, dt);
    left -= dt;
  }
}

void SlaveNode::Advance(TimePoint now) {
  now = std::max(now, now_);
  if (!booted_) {
    now_ = now;
    ticked_to_ = now;
    return;
  }
  TickModel(now);
  now_ = now;
  RunTimers();
}

void SlaveNode::RunTimers() {
  if (next_heartbeat_ && now_ >= *next_heartbeat_) {
    if (EmitErrorControl(state_)) ++counters_.heartbeats_sent;
    // Missed periods are not replayed: a producer that was late sends once (decision 1129).
    const int64_t ms = od_.GetInt(0x1017, 0).value_or(0);
    if (ms == 0) {
      next_heartbeat_.reset();
    } else {
      *next_heartbeat_ += Ms(ms);
      if (*next_heartbeat_ <= now_) next_heartbeat_ = now_ + Ms(ms);
    }
  }
  if (sdo_deadline_ && now_ >= *sdo_deadline_) {
    sdo_deadline_.reset();
    if (auto abort = sdo_->Timeout()) {
      ++counters_.sdo_aborts;
      Emit(*abort);
    }
  }
  for (const HeartbeatConsumer& c : ReadHeartbeatConsumers(od_)) {
    ConsumerState& st = consumers_[c.node];
    if (st.last && !st.timed_out && now_ - *st.last > Ms(c.time_ms)) {
      // §7.2.8.3.2.3: heartbeat event; a communication error for 1029h (decision 1130).
      st.timed_out = true;
      CommunicationError(co::emcy_code::kLifeGuardHeartbeat, c.node);
    }
  }
  if (state_ == NmtState::kOperational) {
    for (RpdoState& st : rpdo_) {
      if (st.deadline && !st.deadline_missed && now_ > *st.deadline) {
        st.deadline_missed = true;
        RaiseEmcy(co::emcy_code::kRpdoTimeout, co::error_register::kCommunication);
      }
    }
    RunEventTpdos();
  }
}

void SlaveNode::OnFrame(const transport::CanFrame& frame, TimePoint now) {
  ++counters_.frames_in;
  Advance(now);
  if (!booted_ || silent_ || frame.error || frame.extended) {
    ++counters_.frames_ignored;
    return;
  }
  const uint16_t sync_id = static_cast<uint16_t>(od_.GetInt(0x1005, 0).value_or(0x80) & 0x7FF);
  const uint32_t sdo_id = 0x600u + options_.node_id;
  if (frame.id == 0 && !frame.rtr) {
    HandleNmt(frame);
  } else if (frame.id == sync_id && !frame.rtr) {
    HandleSync(frame);
  } else if (frame.id == sdo_id) {
    HandleSdo(frame);
  } else if (frame.id > 0x700 && frame.id <= 0x77F) {
    HandleHeartbeat(frame);
  } else if (!HandlePdo(frame)) {
    ++counters_.frames_ignored;
  }
  // A frame may have changed values an event-driven TPDO maps (an RPDO, an SDO download).
  if (state_ == NmtState::kOperational) RunEventTpdos();
}

void SlaveNode::HandleNmt(const transport::CanFrame& frame) {
  auto nmt = co::DecodeNmt(frame);
  if (!nmt.ok() || (nmt->node != 0 && nmt->node != options_.node_id)) {
    ++counters_.frames_ignored;
    return;
  }
  ++counters_.nmt_commands;
  switch (nmt->command) {
    case co::NmtCommand::kStart:
      SetState(NmtState::kOperational);
      break;
    case co::NmtCommand::kStop:
      SetState(NmtState::kStopped);
      break;
    case co::NmtCommand::kEnterPreOperational:
      SetState(NmtState::kPreOperational);
      break;
    case co::NmtCommand::kResetNode:
      ResetNode(/*application=*/true);
      break;
    case co::NmtCommand::kResetCommunication:
      ResetNode(/*application=*/false);
      break;
  }
}

void SlaveNode::HandleSdo(const transport::CanFrame& frame) {
  if (state_ != NmtState::kPreOperational && state_ != NmtState::kOperational) {
    ++counters_.frames_ignored;  // Table 86: no SDO in STOPPED
    return;
  }
  ++counters_.sdo_requests;
  const auto payload = frame.payload();
  // Initiate download (ccs 1) with e = 1 and s = 0: the data size is the object's.
  unsized_expedited_ = !frame.rtr && payload.size() == co::kSdoFrameSize &&
                       (payload[0] >> 5) == 1 && (payload[0] & 0x03) == 0x02;
  auto response = sdo_->OnFrame(frame);
  unsized_expedited_ = false;
  if (response) {
    if (response->dlc > 0 && response->data[0] == kAbortCommand) ++counters_.sdo_aborts;
    Emit(*response);
  }
  // decision 1103: the client's next segment is due within sdo_timeout of our last answer.
  if (sdo_->busy()) {
    sdo_deadline_ = now_ + options_.sdo_timeout;
  } else {
    sdo_deadline_.reset();
  }
}

void SlaveNode::HandleHeartbeat(const transport::CanFrame& frame) {
  const uint8_t node = static_cast<uint8_t>(frame.id - 0x700);
  bool monitored = false;
  for (const HeartbeatConsumer& c : ReadHeartbeatConsumers(od_)) monitored |= c.node == node;
  if (!monitored || frame.rtr || node == options_.node_id) {
    ++counters_.frames_ignored;  // not monitored, or a node-guarding request (not offered)
    return;
  }
  auto hb = co::DecodeErrorControl(frame);
  if (!hb.ok()) {
    ++counters_.frames_ignored;
    return;
  }
  ConsumerState& st = consumers_[node];
  st.timed_out = false;
  if (hb->state == NmtState::kBootUp) {
    st.last.reset();  // the producer restarted: monitoring begins again with its next heartbeat
  } else {
    st.last = now_;
  }
}

void SlaveNode::OnDictionaryWrite(uint16_t index, uint8_t sub) {
  (void)sub;
  if (index == 0x1017) {
    ScheduleHeartbeat();
  } else if (index == 0x1016) {
    consumers_.clear();  // new consumer times: monitoring restarts with the next heartbeats
  } else if (index >= 0x1400 && index < 0x1400 + kPdoCount) {
    rpdo_[index - 0x1400] = {};
  } else if (index >= 0x1600 && index < 0x1600 + kPdoCount) {
    rpdo_[index - 0x1600] = {};
  } else if (index >= 0x1800 && index < 0x1800 + kPdoCount) {
    tpdo_[index - 0x1800] = {};
  } else if (index >= 0x1A00 && index < 0x1A00 + kPdoCount) {
    tpdo_[index - 0x1A00] = {};
  }
}

void SlaveNode::RaiseEmcy(uint16_t code, uint8_t register_bits, std::array<uint8_t, 5> msef) {
  // §7.5.2.2: the generic bit is set whenever any error is present.
  const uint8_t reg = static_cast<uint8_t>(od_.GetInt(0x1001, 0).value_or(0) | register_bits |
                                           co::error_register::kGeneric);
  (void)od_.SetInt(0x1001, 0, reg);
  // §7.5.2.4: the newest error at sub 1, older ones move down, the oldest falls off; bits
  // 16..31 (additional information) stay 0 (decision 1125).
  const int64_t count = od_.GetInt(0x1003, 0).value_or(0);
  const int64_t new_count = std::min<int64_t>(count + 1, kErrorHistoryDepth);
  for (int64_t i = new_count; i >= 2; --i) {
    (void)od_.SetInt(0x1003, static_cast<uint8_t>(i),
                     od_.GetInt(0x1003, static_cast<uint8_t>(i - 1)).value_or(0));
  }
  (void)od_.SetInt(0x1003, 1, code);
  (void)od_.SetInt(0x1003, 0, new_count);
  SendEmcy(code, reg, msef);
}

void SlaveNode::ClearErrors() {
  (void)od_.SetInt(0x1001, 0, 0);
  SendEmcy(co::emcy_code::kNoError, 0, {});
}

void SlaveNode::SendEmcy(uint16_t code, uint8_t error_register,
                         const std::array<uint8_t, 5>& msef) {
  // Table 86: EMCY in PRE-OPERATIONAL and OPERATIONAL only; 1014h bit 31 disables it.
  if (!booted_ || state_ == NmtState::kStopped || state_ == NmtState::kBootUp) return;
  const auto cob = static_cast<uint32_t>(od_.GetInt(0x1014, 0).value_or(0x80000000));
  if ((cob & 0x80000000) != 0) return;
  auto frame = co::EncodeEmcy({options_.node_id, code, error_register, msef});
  if (!frame.ok()) return;
  frame->id = cob & 0x7FF;
  if (Emit(*frame)) ++counters_.emcys_sent;
}

void SlaveNode::CommunicationError(uint16_t code, uint8_t producer) {
  RaiseEmcy(code, co::error_register::kCommunication);
  if (model_ != nullptr) model_->OnCommunicationError(*this, code, producer);
  switch (static_cast<ErrorBehaviour>(od_.GetInt(0x1029, 1).value_or(0))) {
    case ErrorBehaviour::kPreOperational:
      if (state_ == NmtState::kOperational) SetState(NmtState::kPreOperational);
      break;
    case ErrorBehaviour::kStopped:
      SetState(NmtState::kStopped);
      break;
    case ErrorBehaviour::kNoChange:
      break;
  }
}

void SlaveNode::InjectSdoAbort(uint16_t index, uint8_t sub, co::SdoAbortCode code) {
  injected_aborts_[{index, sub}] = code;
}

}  // namespace drivegw::sim::canopen
