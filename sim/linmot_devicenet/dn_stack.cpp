// DnStack: DeviceNet network start-up, connection management, explicit messaging and I/O of the
// simulated drive (linmot-devicenet.md §5, §12.2-§12.4; decisions 955, 956).
#include "sim/linmot_devicenet/dn_stack.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/commands.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

constexpr uint16_t kDefaultExplicitEprMs = 2500;  // §5.6 life cycle 1 [SPEC-M]
constexpr uint16_t kExplicitConnectionSize = 64;  // attr 7/8 of the explicit connection

Duration Ms(uint32_t ms) { return std::chrono::milliseconds(ms); }

dn::ExplicitResponse Ok(dn::ExplicitHeader header, uint8_t service,
                        std::vector<uint8_t> data = {}) {
  return dn::ExplicitResponse{header, service, std::move(data)};
}

std::vector<uint8_t> Usint(uint8_t v) { return {v}; }

}  // namespace

const char* NetworkStateName(NetworkState s) {
  switch (s) {
    case NetworkState::kDisabled:
      return "disabled";
    case NetworkState::kDuplicateCheck:
      return "duplicate-check";
    case NetworkState::kOnline:
      return "online";
    case NetworkState::kCommunicationFaulted:
      return "communication-faulted";
    case NetworkState::kBusOff:
      return "bus-off";
  }
  return "unknown";
}

const char* ConnectionStateName(ConnectionState s) {
  switch (s) {
    case ConnectionState::kNonExistent:
      return "non-existent";
    case ConnectionState::kConfiguring:
      return "configuring";
    case ConnectionState::kWaitingForId:
      return "waiting-for-id";
    case ConnectionState::kEstablished:
      return "established";
    case ConnectionState::kTimedOut:
      return "timed-out";
    case ConnectionState::kDeferredDelete:
      return "deferred-delete";
  }
  return "unknown";
}

DnStack::DnStack(const DnSimOptions& options, IoApplication& app)
    : options_(options),
      app_(app),
      mac_(ResolvedMacId(options)),
      ids_(dn::PredefinedSetIds(ResolvedMacId(options)).value_or(dn::PredefinedIds{})) {
  explicit_.instance = dn::kInstanceExplicit;
  poll_.instance = dn::kInstancePoll;
  cos_.instance = dn::kInstanceCosCyclic;
  DropAllConnections();
}

// ---------------------------------------------------------------------------------------------
// Output.

void DnStack::Emit(std::vector<OutFrame>& out, uint16_t id, std::span<const uint8_t> bytes,
                   TimePoint due) {
  auto frame = dn::MakeFrame(id, bytes);
  if (!frame.ok()) {
    log::Error("linmot_dn_sim.emit_failed",
               log::Fields().Add("drive", options_.name).Add("error", frame.status().message()));
    return;
  }
  out.push_back(OutFrame{*frame, due});
  ++counters_.frames_sent;
}

// ---------------------------------------------------------------------------------------------
// Network start-up (§5.7, §12.2).

std::vector<OutFrame> DnStack::Start(TimePoint now) {
  std::vector<OutFrame> out;
  DropAllConnections();
  if (!options_.dn_enable) {
    network_ = NetworkState::kDisabled;  // §10.2: sends nothing, ignores all frames
    return out;
  }
  StartDuplicateCheck(out, now);
  return out;
}

void DnStack::StartDuplicateCheck(std::vector<OutFrame>& out, TimePoint now) {
  network_ = NetworkState::kDuplicateCheck;
  dup_requests_sent_ = 0;
  lonely_reported_ = false;
  bus_off_since_.reset();
  SendDuplicateCheck(out, /*response=*/false, now);
  dup_requests_sent_ = 1;
  dup_next_ = now + options_.duplicate_check_wait;
}

void DnStack::SendDuplicateCheck(std::vector<OutFrame>& out, bool response, TimePoint now) {
  dn::DuplicateMacCheck m;
  m.response = response;
  m.vendor_id = options_.identity.vendor_id;
  m.serial_number = options_.identity.serial_number + mac_;
  auto bytes = dn::EncodeDuplicateMacCheck(m);
  if (!bytes.ok()) return;
  Emit(out, ids_.duplicate_mac_check, *bytes, now);
  if (response) {
    ++counters_.duplicate_mac_responses_sent;
  } else {
    ++counters_.duplicate_mac_requests_sent;
  }
}

std::vector<OutFrame> DnStack::Restart(TimePoint now) {
  std::vector<OutFrame> out;
  ++counters_.network_restarts;
  DropAllConnections();
  if (!options_.dn_enable) return out;
  StartDuplicateCheck(out, now);
  return out;
}

void DnStack::GoBusOff(TimePoint now) {
  if (network_ == NetworkState::kDisabled || network_ == NetworkState::kBusOff) return;
  network_ = NetworkState::kBusOff;
  bus_off_since_ = now;
  if (bus_off_count_ < 255) ++bus_off_count_;  // attr 4 saturates (§5.10)
  ++counters_.bus_off_events;
  DropAllConnections();
  app_.RaiseCodedError(dn::kCodedCanBusOff);
  log::Warn("linmot_dn_sim.bus_off",
            log::Fields().Add("drive", options_.name).Add("mac", static_cast<int>(mac_)));
}

std::vector<OutFrame> DnStack::RecoverBusOff(TimePoint now) {
  std::vector<OutFrame> out;
  if (network_ != NetworkState::kBusOff) return out;
  ++counters_.network_restarts;
  StartDuplicateCheck(out, now);
  return out;
}

std::vector<OutFrame> DnStack::InjectDuplicateMac(TimePoint now) {
  std::vector<OutFrame> out;
  if (network_ == NetworkState::kDisabled) return out;
  DropAllConnections();
  StartDuplicateCheck(out, now);
  network_ = NetworkState::kCommunicationFaulted;
  ++counters_.duplicate_mac_detected;
  app_.RaiseCodedError(dn::kCodedMacIdInUse);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Connections.

void DnStack::DropAllConnections() {
  for (Connection* c : {&explicit_, &poll_, &cos_}) {
    const uint8_t instance = c->instance;
    *c = Connection{};
    c->instance = instance;
  }
  allocated_ = 0;
  owner_.reset();
  UpdateIoConnected();
}

// Connection objects of the released bits go away; the set has no owner once none is left
// (D-13 default; the alternative ends it with the explicit connection).
void DnStack::ReleaseBits(uint8_t bits) {
  auto reset = [](Connection& c) {
    const uint8_t instance = c.instance;
    c = Connection{};
    c.instance = instance;
  };
  if (bits & dn::kAllocExplicit) reset(explicit_);
  if (bits & dn::kAllocPolled) reset(poll_);
  if (bits & (dn::kAllocChangeOfState | dn::kAllocCyclic)) reset(cos_);
  allocated_ &= static_cast<uint8_t>(~bits);
  if (!(allocated_ & (dn::kAllocChangeOfState | dn::kAllocCyclic))) {
    allocated_ &= static_cast<uint8_t>(~dn::kAllocAckSuppression);
  }
  if ((allocated_ &
       (dn::kAllocExplicit | dn::kAllocPolled | dn::kAllocChangeOfState | dn::kAllocCyclic)) == 0) {
    allocated_ = 0;
    owner_.reset();
  }
  UpdateIoConnected();
}

bool DnStack::Consuming(const Connection& c) const {
  if (&c == &poll_) return (allocated_ & dn::kAllocPolled) != 0;
  // CoS/cyclic carries master data only when polled I/O is not allocated (seed line 148).
  if (&c == &cos_) return !(allocated_ & dn::kAllocPolled) && c.consumed_size > 0;
  return false;
}

void DnStack::UpdateIoConnected() {
  const bool connected = (Consuming(poll_) && poll_.state == ConnectionState::kEstablished) ||
                         (Consuming(cos_) && cos_.state == ConnectionState::kEstablished);
  if (connected != io_connected_) {
    io_connected_ = connected;
    app_.SetIoConnected(connected);
  }
}

DnStack::Connection* DnStack::ConnectionByInstance(uint16_t instance) {
  if (instance == dn::kInstanceExplicit && (allocated_ & dn::kAllocExplicit)) return &explicit_;
  if (instance == dn::kInstancePoll && (allocated_ & dn::kAllocPolled)) return &poll_;
  if (instance == dn::kInstanceCosCyclic &&
      (allocated_ & (dn::kAllocChangeOfState | dn::kAllocCyclic))) {
    return &cos_;
  }
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Receive.

std::vector<OutFrame> DnStack::HandleFrame(const dn::Frame& frame, TimePoint now) {
  std::vector<OutFrame> out;
  ++counters_.frames_received;
  if (network_ == NetworkState::kDisabled || network_ == NetworkState::kBusOff ||
      network_ == NetworkState::kCommunicationFaulted) {
    ++counters_.ignored_offline;
    return out;
  }
  auto id = dn::DecodeIdentifier(frame.id);
  if (!id.ok()) {
    ++counters_.malformed;
    return out;
  }
  const auto payload = frame.payload();
  if (id->group == dn::MessageGroup::kGroup3 && id->message_id == dn::kG3UcmmRequest) {
    OnUcmm(id->mac_id, payload, out, now);
    return out;
  }
  if (id->group != dn::MessageGroup::kGroup2 || id->mac_id != mac_) {
    ++counters_.not_for_us;
    return out;
  }
  if (id->message_id == dn::kG2DuplicateMacCheck) {
    OnDuplicateMac(payload, out, now);
    return out;
  }
  if (network_ != NetworkState::kOnline) {
    ++counters_.ignored_offline;  // §5.7: not online before the check has passed
    return out;
  }
  switch (id->message_id) {
    case dn::kG2UnconnectedRequest:
      OnUnconnected(payload, out, now);
      break;
    case dn::kG2ExplicitRequest:
      OnExplicit(payload, out, now);
      break;
    case dn::kG2PollCommand:
      OnIo(payload, out, now);
      break;
    case dn::kG2CosAcknowledge:
      OnCosAck(now);
      break;
    default:
      ++counters_.not_for_us;  // master I/O bit-strobe / multicast poll, or our own ids
  }
  return out;
}

// §5.7: during the check any frame on our duplicate-MAC id means another node has our MAC; once
// online a request for our MAC is answered with a response.
void DnStack::OnDuplicateMac(std::span<const uint8_t> payload, std::vector<OutFrame>& out,
                             TimePoint now) {
  auto check = dn::DecodeDuplicateMacCheck(payload);
  if (!check.ok()) {
    ++counters_.malformed;
    return;
  }
  if (network_ == NetworkState::kDuplicateCheck) {
    network_ = NetworkState::kCommunicationFaulted;
    ++counters_.duplicate_mac_detected;
    app_.RaiseCodedError(dn::kCodedMacIdInUse);  // seed line 906: 8101
    log::Error("linmot_dn_sim.duplicate_mac",
               log::Fields().Add("drive", options_.name).Add("mac", static_cast<int>(mac_)));
    return;
  }
  if (!check->response) SendDuplicateCheck(out, /*response=*/true, now);
}

// Group 2 message 6: only Allocate / Release of the predefined set (§5.5, D-14).
void DnStack::OnUnconnected(std::span<const uint8_t> payload, std::vector<OutFrame>& out,
                            TimePoint now) {
  auto request = dn::DecodeExplicitRequest(payload);
  if (!request.ok()) {
    ++counters_.malformed;
    if (payload.size() >= 2 && !(payload[0] & 0x80) && !(payload[1] & dn::kResponseBit)) {
      SendExplicit(Error(dn::DecodeExplicitHeader(payload[0]), dn::kErrNotEnoughData, dn::kAddNone),
                   out, now);
    }
    return;
  }
  ++counters_.explicit_requests;
  dn::ExplicitResponse response;
  if (request->service == dn::kServiceAllocate) {
    response = Allocate(*request, now);
  } else if (request->service == dn::kServiceRelease) {
    response = Release(*request);
  } else {
    response =
        Error(request->header, dn::kErrServiceNotSupported, dn::kAddInvalidGroup2OnlyRequest);
  }
  SendExplicit(response, out, now);
}

void DnStack::OnExplicit(std::span<const uint8_t> payload, std::vector<OutFrame>& out,
                         TimePoint now) {
  if (payload.empty()) {
    ++counters_.malformed;
    return;
  }
  const dn::ExplicitHeader header = dn::DecodeExplicitHeader(payload[0]);
  if (!(allocated_ & dn::kAllocExplicit) || explicit_.state != ConnectionState::kEstablished) {
    ++counters_.no_connection_dropped;
    return;
  }
  if (owner_ != header.mac_id) {
    ++counters_.second_master_dropped;  // §5.5 / line 142: one explicit connection, one master
    return;
  }
  explicit_.last_activity = now;
  ++explicit_.received;
  std::vector<uint8_t> message;
  if (header.fragmented) {
    // §5.8: an acknowledge of our fragmented response, or a fragment of a request.
    if (dn::IsFragmentAck(payload)) {
      if (!explicit_.fragmenter) {
        ++counters_.fragment_errors;
        return;
      }
      if (!explicit_.fragmenter->AcceptAck(payload).ok()) {
        ++counters_.fragment_errors;
        explicit_.fragmenter.reset();
        return;
      }
      if (explicit_.fragmenter->done()) {
        explicit_.fragmenter.reset();
        return;
      }
      auto next = explicit_.fragmenter->Next();
      if (next.ok()) {
        Emit(out, ids_.explicit_response, *next, now);
        ++explicit_.sent;
      }
      return;
    }
    auto fed = explicit_.reassembler.FeedExplicit(payload);
    if (!fed.ok()) {
      ++counters_.fragment_errors;
      return;
    }
    if (payload.size() >= 2) {
      auto ack =
          dn::EncodeFragmentAck(dn::FragmentAck{dn::ExplicitHeader{true, header.xid, header.mac_id},
                                                dn::FragmentCountOf(payload[1]), dn::kAckSuccess});
      if (ack.ok()) Emit(out, ids_.explicit_response, *ack, now);
    }
    if (!fed->has_value()) return;
    message = std::move(**fed);
  } else {
    message.assign(payload.begin(), payload.end());
  }
  auto request = dn::DecodeExplicitRequest(message);
  if (!request.ok()) {
    ++counters_.malformed;
    if (message.size() >= 2 && !(message[1] & dn::kResponseBit)) {
      SendExplicit(Error(header, dn::kErrNotEnoughData, dn::kAddNone), out, now);
    }
    return;
  }
  ++counters_.explicit_requests;
  explicit_.fragmenter.reset();  // a new request abandons an unacknowledged response
  bool reset_after = false;
  SendExplicit(Service(*request, now, &reset_after), out, now);
  if (reset_after) {
    app_.ResetController();
    auto restart = Restart(now);
    out.insert(out.end(), restart.begin(), restart.end());
  }
}

void DnStack::OnIo(std::span<const uint8_t> payload, std::vector<OutFrame>& out, TimePoint now) {
  Connection* c = nullptr;
  IoConnection which = IoConnection::kPoll;
  if (Consuming(poll_)) {
    c = &poll_;
  } else if (Consuming(cos_)) {
    c = &cos_;
    which = IoConnection::kCos;
  }
  if (c == nullptr || c->state != ConnectionState::kEstablished) {
    ++counters_.no_connection_dropped;
    return;
  }
  c->last_activity = now;  // §5.6: every message received restarts the watchdog
  std::vector<uint8_t> message;
  if (c->consumed_size > dn::kMaxFrameData) {
    auto fed = c->reassembler.FeedIo(payload);
    if (!fed.ok()) {
      ++counters_.fragment_errors;  // §5.8: discarded on a sequence error (TC-46)
      return;
    }
    if (!fed->has_value()) return;
    message = std::move(**fed);
  } else {
    message.assign(payload.begin(), payload.end());
  }
  if (message.size() != c->consumed_size) {
    ++counters_.polls_wrong_size;  // D-24: discard without answer
    return;
  }
  ++c->received;
  if (which == IoConnection::kPoll) ++counters_.polls_received;
  if (which == IoConnection::kCos) ++counters_.cos_consumed;
  if (faults_.drop_polls || faults_.drop_next_polls > 0) {
    if (faults_.drop_next_polls > 0) --faults_.drop_next_polls;
    ++counters_.polls_dropped_injected;
    return;
  }
  if (app_.Consume(which, message) == ConsumeOutcome::kResetController) {
    // Seed line 984: no response; the controller restarts (the device has reset itself).
    auto restart = Restart(now);
    out.insert(out.end(), restart.begin(), restart.end());
    return;
  }
  if (which == IoConnection::kPoll) {
    Produce(poll_, IoConnection::kPoll, ids_.poll_response, out, now, /*apply_faults=*/true);
  } else if (!(allocated_ & dn::kAllocAckSuppression)) {
    // §12.4 [SPEC-M]: master CoS/cyclic data is acknowledged on 0x3C0|n with DLC 0.
    Emit(out, ids_.poll_response, {}, now);
  }
  RunCos(out, now);
}

void DnStack::OnCosAck(TimePoint now) {
  if (!(allocated_ & (dn::kAllocChangeOfState | dn::kAllocCyclic))) {
    ++counters_.no_connection_dropped;
    return;
  }
  ++counters_.cos_acks_received;
  cos_.last_activity = now;
}

// §5.9 / D-11 (decision 955): UCMM Open allocates the explicit connection of the predefined
// set (group 2 messages 4/3, instance 1); Close releases it.
void DnStack::OnUcmm(uint8_t client, std::span<const uint8_t> payload, std::vector<OutFrame>& out,
                     TimePoint now) {
  if (payload.size() < 2) {
    ++counters_.malformed;
    return;
  }
  const dn::ExplicitHeader header = dn::DecodeExplicitHeader(payload[0]);
  if (header.mac_id != mac_) {
    ++counters_.not_for_us;
    return;
  }
  if (network_ != NetworkState::kOnline) {
    ++counters_.ignored_offline;
    return;
  }
  if (!options_.ucmm) {
    ++counters_.not_for_us;  // a Group-2-only drive does not answer UCMM
    return;
  }
  const uint16_t response_id = static_cast<uint16_t>(0x600 | (dn::kG3UcmmResponse << 6) | mac_);
  const dn::ExplicitHeader reply{false, header.xid, client};
  auto send = [&](std::vector<uint8_t> bytes) { Emit(out, response_id, bytes, now); };
  auto error = [&](uint8_t general, uint8_t additional) {
    ++counters_.error_responses;
    send({dn::EncodeExplicitHeader(reply), static_cast<uint8_t>(dn::kResponseBit | 0x14), general,
          additional});
  };
  ++counters_.explicit_requests;
  if (payload[1] == dn::kServiceAllocate) {
    auto open = dn::DecodeUcmmOpenRequest(payload);
    if (!open.ok()) {
      ++counters_.malformed;
      error(dn::kErrNotEnoughData, dn::kAddNone);
      return;
    }
    if (owner_ && *owner_ != client) {
      ++counters_.second_master_rejected;
      error(dn::kErrObjectStateConflict, dn::kAddAllocationConflict);
      return;
    }
    if (allocated_ & dn::kAllocExplicit) {
      error(dn::kErrResourceUnavailable, dn::kAddNone);
      return;
    }
    owner_ = client;
    allocated_ |= dn::kAllocExplicit;
    explicit_.state = ConnectionState::kEstablished;
    explicit_.epr_ms = kDefaultExplicitEprMs;
    explicit_.watchdog_action = 1;
    explicit_.produced_size = explicit_.consumed_size = kExplicitConnectionSize;
    explicit_.last_activity = now;
    ++counters_.allocations;
    dn::UcmmOpenResponse r;
    r.header = reply;
    r.actual_format = dn::BodyFormat::k8_8;
    r.destination_message_id = dn::kG2ExplicitRequest;
    r.source_message_id = dn::kG2ExplicitResponse;
    r.connection_instance = dn::kInstanceExplicit;
    auto bytes = dn::EncodeUcmmOpenResponse(r);
    if (bytes.ok()) send(*bytes);
    return;
  }
  if (payload[1] == dn::kServiceRelease) {
    if (payload.size() < 4) {
      error(dn::kErrNotEnoughData, dn::kAddNone);
      return;
    }
    const uint16_t instance = static_cast<uint16_t>(payload[2] | (payload[3] << 8));
    if (instance != dn::kInstanceExplicit || !(allocated_ & dn::kAllocExplicit)) {
      error(dn::kErrObjectDoesNotExist, dn::kAddNone);
      return;
    }
    if (owner_ != client) {
      ++counters_.second_master_rejected;
      error(dn::kErrObjectStateConflict, dn::kAddAllocationConflict);
      return;
    }
    ReleaseBits(dn::kAllocExplicit);
    ++counters_.releases;
    send({dn::EncodeExplicitHeader(reply), static_cast<uint8_t>(dn::kResponseBit | 0x4C)});
    return;
  }
  error(dn::kErrServiceNotSupported, dn::kAddNone);
}

// ---------------------------------------------------------------------------------------------
// Explicit services.

dn::ExplicitResponse DnStack::Error(dn::ExplicitHeader header, uint8_t general,
                                    uint8_t additional) {
  ++counters_.error_responses;
  return dn::ErrorResponseMessage(header, dn::ErrorResponse{general, additional});
}

void DnStack::SendExplicit(const dn::ExplicitResponse& response, std::vector<OutFrame>& out,
                           TimePoint now) {
  auto bytes = dn::EncodeExplicitResponse(response);
  if (!bytes.ok()) {
    log::Error("linmot_dn_sim.explicit_encode",
               log::Fields().Add("drive", options_.name).Add("error", bytes.status().message()));
    return;
  }
  if (bytes->size() <= dn::kMaxFrameData) {
    Emit(out, ids_.explicit_response, *bytes, now);
    ++explicit_.sent;
    return;
  }
  // §5.8 [SPEC-M]: longer responses go out fragment by fragment, each after the master's ack.
  auto fragmenter = dn::Fragmenter::ForExplicit(*bytes);
  if (!fragmenter.ok()) return;
  explicit_.fragmenter = *std::move(fragmenter);
  auto first = explicit_.fragmenter->Next();
  if (first.ok()) {
    Emit(out, ids_.explicit_response, *first, now);
    ++explicit_.sent;
  }
}

// §5.5 and D-14: ownership, supported choices, already allocated.
dn::ExplicitResponse DnStack::Allocate(const dn::ExplicitRequest& request, TimePoint now) {
  const dn::ExplicitHeader reply{false, request.header.xid, request.header.mac_id};
  auto params = dn::DecodeAllocate(request);
  if (!params.ok()) {
    if (request.class_id != dn::kClassDeviceNet || request.instance_id != 1) {
      return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
    }
    return Error(reply, dn::kErrNotEnoughData, dn::kAddNone);
  }
  const uint8_t choice = params->choice;
  const uint8_t master = params->allocator_mac;
  if (owner_ && *owner_ != master) {
    ++counters_.second_master_rejected;
    log::Info("linmot_dn_sim.allocate_rejected", log::Fields()
                                                     .Add("drive", options_.name)
                                                     .Add("owner", static_cast<int>(*owner_))
                                                     .Add("requester", static_cast<int>(master)));
    return Error(reply, dn::kErrObjectStateConflict, dn::kAddAllocationConflict);
  }
  const uint8_t connections =
      dn::kAllocExplicit | dn::kAllocPolled | dn::kAllocChangeOfState | dn::kAllocCyclic;
  const bool bad_bits = !dn::ValidateAllocationChoice(choice).ok() ||
                        (choice & (dn::kAllocBitStrobed | dn::kAllocMulticastPoll)) != 0;
  const bool not_configured =
      ((choice & dn::kAllocPolled) && !options_.io_polled) ||
      ((choice & (dn::kAllocChangeOfState | dn::kAllocCyclic)) && !options_.io_cos);
  const bool cos_mix = ((choice | allocated_) & dn::kAllocChangeOfState) &&
                       ((choice | allocated_) & dn::kAllocCyclic);
  const bool lone_suppression =
      (choice & dn::kAllocAckSuppression) &&
      !((choice | allocated_) & (dn::kAllocChangeOfState | dn::kAllocCyclic));
  if (choice == 0 || bad_bits || not_configured || cos_mix || lone_suppression) {
    return Error(reply, dn::kErrResourceUnavailable, dn::kAddInvalidChoice);
  }
  if ((choice & allocated_ & (connections | dn::kAllocAckSuppression)) != 0) {
    return Error(reply, dn::kErrAlreadyInRequestedState, dn::kAddInvalidChoice);
  }
  owner_ = master;
  allocated_ |= choice;
  const dn::IoLayout poll_layout = PollLayout(options_);
  const dn::IoLayout cos_layout = CosLayout(options_);
  if (choice & dn::kAllocExplicit) {
    explicit_.state = ConnectionState::kEstablished;  // §5.6 life cycle 1
    explicit_.epr_ms = kDefaultExplicitEprMs;
    explicit_.watchdog_action = 1;  // auto delete
    explicit_.produced_size = explicit_.consumed_size = kExplicitConnectionSize;
    explicit_.last_activity = now;
  }
  if (choice & dn::kAllocPolled) {
    poll_.state = ConnectionState::kConfiguring;
    poll_.epr_ms = 0;
    poll_.watchdog_action = 0;  // timed out
    poll_.produced_size = static_cast<uint16_t>(dn::ProducedSize(poll_layout));
    poll_.consumed_size = static_cast<uint16_t>(dn::ConsumedSize(poll_layout));
    poll_.reassembler = dn::Reassembler(std::max<size_t>(poll_.consumed_size, dn::kMaxFrameData));
  }
  if (choice & (dn::kAllocChangeOfState | dn::kAllocCyclic)) {
    cos_.state = ConnectionState::kConfiguring;
    cos_.epr_ms = 0;
    cos_.watchdog_action = 0;
    cos_.produced_size = static_cast<uint16_t>(dn::ProducedSize(cos_layout));
    cos_.consumed_size = static_cast<uint16_t>(dn::ConsumedSize(cos_layout));
    cos_.reassembler = dn::Reassembler(std::max<size_t>(cos_.consumed_size, dn::kMaxFrameData));
  }
  ++counters_.allocations;
  log::Info("linmot_dn_sim.allocated", log::Fields()
                                           .Add("drive", options_.name)
                                           .Add("master", static_cast<int>(master))
                                           .Add("choice", dn::AllocationChoiceText(choice)));
  return dn::AllocateResponse(reply, dn::BodyFormat::k8_8);
}

dn::ExplicitResponse DnStack::Release(const dn::ExplicitRequest& request) {
  const dn::ExplicitHeader reply{false, request.header.xid, request.header.mac_id};
  auto choice = dn::DecodeRelease(request);
  if (!choice.ok()) {
    if (request.class_id != dn::kClassDeviceNet || request.instance_id != 1) {
      return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
    }
    return Error(reply, dn::kErrNotEnoughData, dn::kAddNone);
  }
  if (owner_ && *owner_ != request.header.mac_id) {
    ++counters_.second_master_rejected;
    return Error(reply, dn::kErrObjectStateConflict, dn::kAddAllocationConflict);
  }
  if (*choice == 0 || (*choice & ~allocated_) != 0) {
    return Error(reply, dn::kErrAlreadyInRequestedState, dn::kAddInvalidChoice);
  }
  ReleaseBits(*choice);
  ++counters_.releases;
  return dn::ReleaseResponse(reply);
}

dn::ExplicitResponse DnStack::Service(const dn::ExplicitRequest& request, TimePoint now,
                                      bool* reset_after) {
  const dn::ExplicitHeader reply{false, request.header.xid, request.header.mac_id};
  switch (request.service) {
    case dn::kServiceGetAttributeSingle:
      return GetAttribute(request);
    case dn::kServiceSetAttributeSingle:
      return SetAttribute(request, now);
    case dn::kServiceAllocate:
      return Allocate(request, now);  // [SPEC-M]: also over the explicit connection
    case dn::kServiceRelease:
      return Release(request);
    case dn::kServiceReset:
      if (request.class_id == dn::kClassIdentity && request.instance_id == 1) {
        *reset_after = true;  // §5.11: respond, then restart like 0x0F
        return Ok(reply, dn::kServiceReset);
      }
      if (request.class_id == dn::kClassConnection) {
        Connection* c = ConnectionByInstance(request.instance_id);
        if (c == nullptr || c == &explicit_) {
          return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
        }
        if (c->state == ConnectionState::kConfiguring) {
          return Error(reply, dn::kErrObjectStateConflict, dn::kAddNone);
        }
        // §5.6 life cycle 4: the master re-establishes a timed-out connection by a reset.
        c->state = ConnectionState::kEstablished;
        c->last_activity = now;
        c->reassembler.Reset();
        UpdateIoConnected();
        return Ok(reply, dn::kServiceReset);
      }
      return Error(reply, dn::kErrServiceNotSupported, dn::kAddNone);
    case dn::kServiceApplyAttributes: {
      Connection* c = request.class_id == dn::kClassConnection
                          ? ConnectionByInstance(request.instance_id)
                          : nullptr;
      if (c == nullptr || c == &explicit_) {
        return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      }
      c->state = ConnectionState::kEstablished;
      c->last_activity = now;
      UpdateIoConnected();
      return Ok(reply, dn::kServiceApplyAttributes);
    }
    default:
      return Error(reply, dn::kErrServiceNotSupported, dn::kAddNone);
  }
}

dn::ExplicitResponse DnStack::GetAttribute(const dn::ExplicitRequest& r) {
  const dn::ExplicitHeader reply{false, r.header.xid, r.header.mac_id};
  const uint8_t attr = r.attribute_id.value_or(0);
  auto value = [&](std::vector<uint8_t> data) {
    return Ok(reply, dn::kServiceGetAttributeSingle, std::move(data));
  };
  switch (r.class_id) {
    case dn::kClassIdentity: {  // §5.11, D-12
      if (!options_.identity_readable)
        return Error(reply, dn::kErrServiceNotSupported, dn::kAddNone);
      if (r.instance_id != 1) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      const IdentityOptions& id = options_.identity;
      switch (attr) {
        case dn::kAttrIdentityVendorId:
          return value(dn::UintValue(id.vendor_id));
        case dn::kAttrIdentityDeviceType:
          return value(dn::UintValue(id.device_type));
        case dn::kAttrIdentityProductCode:
          return value(dn::UintValue(id.product_code));
        case dn::kAttrIdentityRevision:
          return value({id.revision_major, id.revision_minor});
        case dn::kAttrIdentityStatus: {
          // WORD: bit 0 owned (a master owns the set), bit 2 configured.
          const uint16_t status = static_cast<uint16_t>((owner_ ? 0x0001 : 0) | 0x0004);
          return value(dn::UintValue(status));
        }
        case dn::kAttrIdentitySerialNumber: {
          const uint32_t s = id.serial_number + mac_;
          return value({static_cast<uint8_t>(s), static_cast<uint8_t>(s >> 8),
                        static_cast<uint8_t>(s >> 16), static_cast<uint8_t>(s >> 24)});
        }
        case dn::kAttrIdentityProductName: {
          std::vector<uint8_t> name{static_cast<uint8_t>(id.product_name.size())};
          name.insert(name.end(), id.product_name.begin(), id.product_name.end());
          return value(std::move(name));
        }
        default:
          return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
      }
    }
    case dn::kClassDeviceNet: {  // §5.11
      if (r.instance_id != 1) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      switch (attr) {
        case dn::kAttrDnMacId:
          return value(Usint(mac_));
        case dn::kAttrDnBaudRate:
          return value(Usint(options_.baud == BaudRate::k125   ? 0
                             : options_.baud == BaudRate::k250 ? 1
                                                               : 2));
        case dn::kAttrDnBusOffInterrupt:
          return value(Usint(boi_ ? 1 : 0));
        case dn::kAttrDnBusOffCounter:
          return value(Usint(bus_off_count_));
        case dn::kAttrDnAllocationInformation:
          return value({allocated_, owner_.value_or(0xFF)});
        case 6:  // MAC ID switch changed since start-up: the switches are read once
        case 7:  // baud rate switch changed
          return value(Usint(0));
        case 8:  // MAC ID switch value
          return value(Usint(options_.mac_switches));
        case 9:  // baud rate switch value (the rate is a LinTalk parameter, no switch)
          return value(Usint(options_.baud == BaudRate::k125   ? 0
                             : options_.baud == BaudRate::k250 ? 1
                                                               : 2));
        default:
          return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
      }
    }
    case dn::kClassConnection: {  // §5.6, D-13
      if (!options_.connection_attributes_readable) {
        return Error(reply, dn::kErrServiceNotSupported, dn::kAddNone);
      }
      const Connection* c = ConnectionByInstance(r.instance_id);
      if (c == nullptr) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      const bool is_explicit = c == &explicit_;
      switch (attr) {
        case dn::kAttrConnState:
          return value(Usint(static_cast<uint8_t>(c->state)));
        case dn::kAttrConnInstanceType:
          return value(Usint(is_explicit ? 0 : 1));
        case dn::kAttrConnTransportClassTrigger: {
          uint8_t t = 0x82;  // poll server, class 2
          if (is_explicit) t = 0x83;
          if (c == &cos_) {
            const uint8_t cls = (allocated_ & dn::kAllocAckSuppression) ? 0x00 : 0x02;
            t = static_cast<uint8_t>(((allocated_ & dn::kAllocChangeOfState) ? 0x10 : 0x00) | cls);
          }
          return value(Usint(t));
        }
        case dn::kAttrConnProducedConnectionId:
          return value(dn::UintValue(is_explicit   ? ids_.explicit_response
                                     : c == &poll_ ? ids_.poll_response
                                                   : ids_.cos_response));
        case dn::kAttrConnConsumedConnectionId:
          return value(dn::UintValue(is_explicit     ? ids_.explicit_request
                                     : c == &poll_   ? ids_.poll_command
                                     : Consuming(*c) ? ids_.poll_command
                                                     : ids_.cos_acknowledge));
        case dn::kAttrConnInitialCommCharacteristics:
          return value(Usint(is_explicit ? 0x21 : c == &poll_ ? 0x01 : 0x0F));
        case dn::kAttrConnProducedSize:
          return value(dn::UintValue(c->produced_size));
        case dn::kAttrConnConsumedSize:
          return value(dn::UintValue(c->consumed_size));
        case dn::kAttrConnExpectedPacketRate:
          return value(dn::UintValue(c->epr_ms));
        case dn::kAttrConnWatchdogTimeoutAction:
          return value(Usint(c->watchdog_action));
        case dn::kAttrConnProductionInhibitTime:
          if (c != &cos_) return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
          return value(dn::UintValue(c->inhibit_ms));
        default:
          return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
      }
    }
    case dn::kClassMessageRouter:
    case dn::kClassAssembly:
      // Seed lines 126, 130: no attribute of these objects is accessible.
      return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
    default:
      // Application objects (line 134: no attributes) and everything else.
      return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
  }
}

dn::ExplicitResponse DnStack::SetAttribute(const dn::ExplicitRequest& r, TimePoint now) {
  const dn::ExplicitHeader reply{false, r.header.xid, r.header.mac_id};
  const uint8_t attr = r.attribute_id.value_or(0);
  switch (r.class_id) {
    case dn::kClassIdentity:
      if (r.instance_id != 1) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      return Error(
          reply,
          attr >= 1 && attr <= 7 ? dn::kErrAttributeNotSettable : dn::kErrAttributeNotSupported,
          dn::kAddNone);
    case dn::kClassDeviceNet:
      if (r.instance_id != 1) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      if (attr == dn::kAttrDnBusOffInterrupt) {
        if (r.data.size() != 1) {
          return Error(reply, r.data.empty() ? dn::kErrNotEnoughData : dn::kErrTooMuchData,
                       dn::kAddNone);
        }
        if (r.data[0] > 1) return Error(reply, dn::kErrInvalidAttributeValue, dn::kAddNone);
        boi_ = r.data[0] == 1;
        return Ok(reply, dn::kServiceSetAttributeSingle);
      }
      if (attr == dn::kAttrDnBusOffCounter) {
        bus_off_count_ = 0;  // §5.11: writing the counter resets it
        return Ok(reply, dn::kServiceSetAttributeSingle);
      }
      // MAC ID and baud rate come from LinTalk only (§2 consequence 2).
      return Error(
          reply,
          attr >= 1 && attr <= 9 ? dn::kErrAttributeNotSettable : dn::kErrAttributeNotSupported,
          dn::kAddNone);
    case dn::kClassConnection: {
      Connection* c = ConnectionByInstance(r.instance_id);
      if (c == nullptr) return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
      if (attr == dn::kAttrConnExpectedPacketRate) {
        auto ms = dn::DecodeUintValue(r.data);
        if (!ms.ok()) {
          return Error(reply, r.data.size() < 2 ? dn::kErrNotEnoughData : dn::kErrTooMuchData,
                       dn::kAddNone);
        }
        // D-13: granted = requested rounded up to the timer resolution; 0 switches it off.
        const uint32_t res = options_.epr_resolution_ms;
        const uint32_t granted =
            std::min<uint32_t>((*ms + res - 1) / res * res, 0xFFFF / res * res);
        c->epr_ms = static_cast<uint16_t>(granted);
        c->last_activity = now;
        if (c != &explicit_) {
          // §5.6 life cycle 2: setting the EPR establishes an I/O connection (again).
          c->state = ConnectionState::kEstablished;
          c->reassembler.Reset();
          c->last_production.reset();
          c->last_produced.clear();
        }
        UpdateIoConnected();
        return Ok(reply, dn::kServiceSetAttributeSingle, dn::UintValue(c->epr_ms));
      }
      if (attr == dn::kAttrConnWatchdogTimeoutAction) {
        if (r.data.size() != 1) return Error(reply, dn::kErrNotEnoughData, dn::kAddNone);
        if (r.data[0] > 3 || (c == &explicit_ && r.data[0] != 1 && r.data[0] != 3)) {
          return Error(reply, dn::kErrInvalidAttributeValue, dn::kAddNone);
        }
        c->watchdog_action = r.data[0];
        return Ok(reply, dn::kServiceSetAttributeSingle);
      }
      if (attr == dn::kAttrConnProductionInhibitTime && c == &cos_) {
        auto ms = dn::DecodeUintValue(r.data);
        if (!ms.ok()) return Error(reply, dn::kErrNotEnoughData, dn::kAddNone);
        c->inhibit_ms = *ms;
        return Ok(reply, dn::kServiceSetAttributeSingle);
      }
      return Error(
          reply,
          attr >= 1 && attr <= 16 ? dn::kErrAttributeNotSettable : dn::kErrAttributeNotSupported,
          dn::kAddNone);
    }
    case dn::kClassMessageRouter:
    case dn::kClassAssembly:
      return Error(reply, dn::kErrAttributeNotSupported, dn::kAddNone);
    default:
      return Error(reply, dn::kErrObjectDoesNotExist, dn::kAddNone);
  }
}

// ---------------------------------------------------------------------------------------------
// Production.

void DnStack::Produce(Connection& c, IoConnection which, uint16_t id, std::vector<OutFrame>& out,
                      TimePoint now, bool apply_faults) {
  std::vector<uint8_t> image = app_.Produce(which);
  const TimePoint due = now + options_.response_delay + faults_.response_delay;
  if (apply_faults && faults_.response_length_delta != 0) {
    const int size = std::max(0, static_cast<int>(image.size()) + faults_.response_length_delta);
    image.resize(static_cast<size_t>(size), 0);
  }
  auto frames = dn::EncodeIoMessage(id, image, image.size());
  if (!frames.ok()) return;
  if (apply_faults && faults_.corrupt_fragments && frames->size() > 1) {
    // §12.8 corrupted fragment sequence: the first middle fragment (or the last) goes missing.
    frames->erase(frames->begin() + 1);
  }
  for (const dn::Frame& f : *frames) {
    out.push_back(OutFrame{f, due});
    ++counters_.frames_sent;
  }
  ++c.sent;
  if (which == IoConnection::kPoll) {
    ++counters_.poll_responses_sent;
  } else {
    ++counters_.cos_sent;
  }
}

// §5.6 / §12.4: CoS on change (not within the inhibit time) and at least every EPR (heartbeat);
// cyclic every EPR. D-27: any change of the CoS image counts.
void DnStack::RunCos(std::vector<OutFrame>& out, TimePoint now) {
  if (network_ != NetworkState::kOnline || cos_.state != ConnectionState::kEstablished) return;
  const bool cyclic = (allocated_ & dn::kAllocCyclic) != 0;
  const Duration epr = Ms(cos_.epr_ms);
  const bool heartbeat_due =
      cos_.epr_ms > 0 && (!cos_.last_production || now - *cos_.last_production >= epr);
  bool send = heartbeat_due;
  std::vector<uint8_t> image;
  if (!cyclic) {
    image = app_.Produce(IoConnection::kCos);
    const bool inhibit_over =
        !cos_.last_production || now - *cos_.last_production >= Ms(cos_.inhibit_ms);
    send = send || (image != cos_.last_produced && inhibit_over);
  }
  if (!send) return;
  Produce(cos_, IoConnection::kCos, ids_.cos_response, out, now, /*apply_faults=*/false);
  cos_.last_produced = cyclic ? std::vector<uint8_t>() : std::move(image);
  cos_.last_production = now;
}

// ---------------------------------------------------------------------------------------------
// Timers.

void DnStack::RunWatchdogs(TimePoint now) {
  for (Connection* c : {&explicit_, &poll_, &cos_}) {
    if (c->state != ConnectionState::kEstablished || c->epr_ms == 0) continue;
    // CoS with acknowledge suppression and no master data receives nothing: no watchdog.
    if (c == &cos_ && !Consuming(*c) && (allocated_ & dn::kAllocAckSuppression)) continue;
    if (now - c->last_activity < 4 * Ms(c->epr_ms)) continue;  // §5.6: 4 x EPR
    ++c->timeouts;
    ++counters_.watchdog_timeouts;
    log::Info("linmot_dn_sim.watchdog", log::Fields()
                                            .Add("drive", options_.name)
                                            .Add("instance", static_cast<int>(c->instance))
                                            .Add("epr_ms", c->epr_ms)
                                            .Add("action", static_cast<int>(c->watchdog_action)));
    if (c == &explicit_) {
      // Auto delete [SPEC-M]; D-13: the set stays owned while another connection exists.
      if (options_.ownership_ends_with_explicit) {
        DropAllConnections();
        return;
      }
      ReleaseBits(dn::kAllocExplicit);
      continue;
    }
    const uint8_t bits = c == &poll_
                             ? dn::kAllocPolled
                             : static_cast<uint8_t>(dn::kAllocChangeOfState | dn::kAllocCyclic);
    switch (c->watchdog_action) {
      case 0:
        c->state = ConnectionState::kTimedOut;
        c->reassembler.Reset();
        UpdateIoConnected();
        break;
      case 2:
        c->last_activity = now;  // auto reset
        break;
      default:
        ReleaseBits(bits);  // auto delete, deferred delete
    }
  }
}

std::vector<OutFrame> DnStack::Advance(TimePoint now) {
  std::vector<OutFrame> out;
  switch (network_) {
    case NetworkState::kDisabled:
    case NetworkState::kCommunicationFaulted:
      return out;
    case NetworkState::kBusOff:
      // D-16: hold, or recover after the configured time (also with BOI = 1).
      if ((options_.bus_off_recovery == BusOffRecovery::kAutoRecover || boi_) && bus_off_since_ &&
          now - *bus_off_since_ >= options_.bus_off_recover_after) {
        ++counters_.network_restarts;
        StartDuplicateCheck(out, now);
      }
      return out;
    case NetworkState::kDuplicateCheck:
      if (now < dup_next_) return out;
      if (dup_requests_sent_ < 2) {
        SendDuplicateCheck(out, false, now);
        ++dup_requests_sent_;
        dup_next_ = now + options_.duplicate_check_wait;
        return out;
      }
      if (faults_.lonely_node) {
        // §5.7 / §10.2: nobody acknowledges; the drive keeps retransmitting, 0x8143.
        if (!lonely_reported_) {
          lonely_reported_ = true;
          app_.RaiseCodedError(dn::kCodedCanAckError);
        }
        SendDuplicateCheck(out, false, now);
        dup_next_ = now + options_.duplicate_check_wait;
        return out;
      }
      network_ = NetworkState::kOnline;
      log::Info("linmot_dn_sim.online",
                log::Fields().Add("drive", options_.name).Add("mac", static_cast<int>(mac_)));
      return out;
    case NetworkState::kOnline:
      RunWatchdogs(now);
      RunCos(out, now);
      return out;
  }
  return out;
}

std::optional<TimePoint> DnStack::NextDeadline() const {
  std::optional<TimePoint> next;
  auto consider = [&](TimePoint t) {
    if (!next || t < *next) next = t;
  };
  switch (network_) {
    case NetworkState::kDuplicateCheck:
      consider(dup_next_);
      break;
    case NetworkState::kBusOff:
      if (bus_off_since_) consider(*bus_off_since_ + options_.bus_off_recover_after);
      break;
    case NetworkState::kOnline:
      for (const Connection* c : {&explicit_, &poll_, &cos_}) {
        if (c->state == ConnectionState::kEstablished && c->epr_ms > 0) {
          consider(c->last_activity + 4 * Ms(c->epr_ms));
        }
      }
      if (cos_.state == ConnectionState::kEstablished && cos_.epr_ms > 0) {
        consider(cos_.last_production.value_or(TimePoint{}) + Ms(cos_.epr_ms));
      }
      break;
    default:
      break;
  }
  return next;
}

StackSnapshot DnStack::Snapshot() const {
  StackSnapshot s;
  s.network = network_;
  s.mac_id = mac_;
  s.owner = owner_;
  s.allocation_choice = allocated_;
  auto conn = [](const Connection& c) {
    ConnectionSnapshot o;
    o.instance = c.instance;
    o.state = c.state;
    o.expected_packet_rate_ms = c.epr_ms;
    o.watchdog_timeout_action = c.watchdog_action;
    o.production_inhibit_ms = c.inhibit_ms;
    o.produced_size = c.produced_size;
    o.consumed_size = c.consumed_size;
    o.messages_received = c.received;
    o.messages_sent = c.sent;
    o.watchdog_timeouts = c.timeouts;
    return o;
  };
  s.explicit_connection = conn(explicit_);
  s.poll_connection = conn(poll_);
  s.cos_connection = conn(cos_);
  s.poll_produced_size = static_cast<uint16_t>(dn::ProducedSize(PollLayout(options_)));
  s.poll_consumed_size = static_cast<uint16_t>(dn::ConsumedSize(PollLayout(options_)));
  s.cos_produced_size = static_cast<uint16_t>(dn::ProducedSize(CosLayout(options_)));
  s.cos_consumed_size = static_cast<uint16_t>(dn::ConsumedSize(CosLayout(options_)));
  s.boi = boi_;
  s.bus_off_count = bus_off_count_;
  s.counters = counters_;
  return s;
}

}  // namespace drivegw::sim::linmot_devicenet
