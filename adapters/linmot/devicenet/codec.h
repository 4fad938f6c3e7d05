// DeviceNet link layer codec: CAN identifiers, explicit messages, fragmentation, duplicate MAC ID
// check and I/O (poll / change-of-state) frames; pure (no I/O, no clock).
// Source of truth: shared/protocols/linmot-devicenet.md §5 (DeviceNet specification summary,
// confidence tags [SPEC-H/M/L]); decisions in docs/decisions/9NN-*.md.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::linmot::devicenet {

// ---------------------------------------------------------------------------------------------
// CAN frame as this codec sees it (§5.1: classic CAN 2.0A data frames, 11-bit identifiers, DLC
// 0..8, no remote frames). codec_can.h converts to and from transport::CanFrame (decision 901).

inline constexpr uint8_t kMaxMacId = 63;           // §3.1 (seed lines 85, 202)
inline constexpr uint16_t kMaxIdentifier = 0x7FF;  // 11 bits
inline constexpr size_t kMaxFrameData = 8;

struct Frame {
  uint16_t id = 0;
  uint8_t dlc = 0;                // 0..8
  std::array<uint8_t, 8> data{};  // bytes beyond dlc are zero

  std::span<const uint8_t> payload() const { return {data.data(), dlc <= 8 ? dlc : size_t{8}}; }
  friend bool operator==(const Frame&, const Frame&) = default;
};

// InvalidArgument if id > 0x7FF or more than 8 bytes ("devicenet frame: 9 data bytes exceed 8").
absl::StatusOr<Frame> MakeFrame(uint16_t id, std::span<const uint8_t> bytes);
// candump-style text: "42D#02.00.11.10.00.14" (§0.4); "42A#" for DLC 0.
std::string FrameToString(const Frame& frame);
// Parses the §0.4 notation ("42D#02.00.11.10.00.14"; dots optional: "42D#020011100014").
absl::StatusOr<Frame> ParseFrame(std::string_view text);

// ---------------------------------------------------------------------------------------------
// Identifiers (§5.1 [SPEC-H]).

enum class MessageGroup : uint8_t { kGroup1 = 1, kGroup2 = 2, kGroup3 = 3, kGroup4 = 4 };

// Group 1 message IDs of the predefined master/slave set (§5.2); 4 bits, source = slave MAC.
inline constexpr uint8_t kG1MulticastPollResponse = 0xC;
inline constexpr uint8_t kG1ChangeOfState = 0xD;  // slave CoS / cyclic data (0x340 | n)
inline constexpr uint8_t kG1BitStrobeResponse = 0xE;
inline constexpr uint8_t kG1PollResponse = 0xF;  // poll response / slave's CoS ack (0x3C0 | n)
// Group 2 message IDs (§5.2); 3 bits, MAC = slave (destination) except 0, 1 (master source).
inline constexpr uint8_t kG2BitStrobeCommand = 0;
inline constexpr uint8_t kG2MulticastPollCommand = 1;
inline constexpr uint8_t kG2CosAcknowledge = 2;      // master's ack of slave CoS data, DLC 0
inline constexpr uint8_t kG2ExplicitResponse = 3;    // slave explicit / unconnected response
inline constexpr uint8_t kG2ExplicitRequest = 4;     // master explicit request
inline constexpr uint8_t kG2PollCommand = 5;         // master poll command / CoS / cyclic data
inline constexpr uint8_t kG2UnconnectedRequest = 6;  // Group-2-only Allocate / Release
inline constexpr uint8_t kG2DuplicateMacCheck = 7;
// Group 3 message IDs (§5.9 [SPEC-M]); 0..6, source MAC.
inline constexpr uint8_t kG3UcmmResponse = 5;
inline constexpr uint8_t kG3UcmmRequest = 6;

struct Identifier {
  MessageGroup group = MessageGroup::kGroup2;
  uint8_t mac_id = 0;      // 0..63; 0 for group 4 (no MAC field)
  uint8_t message_id = 0;  // G1 0..15, G2 0..7, G3 0..6, G4 0..0x2F
  friend constexpr bool operator==(Identifier, Identifier) = default;
};

// Errors name the field and its limit: "devicenet identifier.mac_id: 64 exceeds 63",
// "devicenet identifier.message_id: 7 exceeds group 3 limit 6".
absl::StatusOr<uint16_t> EncodeIdentifier(const Identifier& identifier);
// InvalidArgument for id > 0x7FF ("exceeds 11 bits"), 0x7C0|0x30..0x7FF (invalid range
// 0x7F0-0x7FF and group 4 IDs above 0x2F) and group 3 message ID 7 (0x7C0-0x7FF are group 4).
absl::StatusOr<Identifier> DecodeIdentifier(uint16_t id);

// The predefined master/slave connection set identifiers for slave MAC n (§5.2).
struct PredefinedIds {
  uint16_t cos_response;         // G1 0xD: 0x340 | n
  uint16_t poll_response;        // G1 0xF: 0x3C0 | n
  uint16_t cos_acknowledge;      // G2 2:   0x400 | n << 3 | 2
  uint16_t explicit_response;    // G2 3
  uint16_t explicit_request;     // G2 4
  uint16_t poll_command;         // G2 5
  uint16_t unconnected_request;  // G2 6
  uint16_t duplicate_mac_check;  // G2 7
  friend constexpr bool operator==(PredefinedIds, PredefinedIds) = default;
};
absl::StatusOr<PredefinedIds> PredefinedSetIds(uint8_t slave_mac);

// ---------------------------------------------------------------------------------------------
// Explicit messages (§5.3-§5.5 [SPEC-H]).

// Byte 0 of every explicit message: bit 7 Frag, bit 6 XID, bits 5..0 MAC ID of the other end.
struct ExplicitHeader {
  bool fragmented = false;
  bool xid = false;
  uint8_t mac_id = 0;  // 0..63
  friend constexpr bool operator==(ExplicitHeader, ExplicitHeader) = default;
};
constexpr uint8_t EncodeExplicitHeader(ExplicitHeader h) {
  return static_cast<uint8_t>((h.fragmented ? 0x80 : 0) | (h.xid ? 0x40 : 0) | (h.mac_id & 0x3F));
}
constexpr ExplicitHeader DecodeExplicitHeader(uint8_t b) {
  return ExplicitHeader{(b & 0x80) != 0, (b & 0x40) != 0, static_cast<uint8_t>(b & 0x3F)};
}

// Service codes (§5.3); byte 1 bits 6..0; bit 7 = R/R (1 = response).
inline constexpr uint8_t kServiceGetAttributesAll = 0x01;
inline constexpr uint8_t kServiceReset = 0x05;
inline constexpr uint8_t kServiceApplyAttributes = 0x0D;  // §5.6 [SPEC-M]
inline constexpr uint8_t kServiceGetAttributeSingle = 0x0E;
inline constexpr uint8_t kServiceSetAttributeSingle = 0x10;
inline constexpr uint8_t kServiceErrorResponse = 0x14;  // 0x94 on the wire
inline constexpr uint8_t kServiceAllocate =
    0x4B;                                         // Allocate_Master/Slave_Connection_Set; UCMM open
inline constexpr uint8_t kServiceRelease = 0x4C;  // Release_Master/Slave_Connection_Set; UCMM close
inline constexpr uint8_t kServiceDeviceHeartbeat = 0x4D;
inline constexpr uint8_t kServiceDeviceShutdown = 0x4E;
inline constexpr uint8_t kResponseBit = 0x80;
// "Get_Attribute_Single"; "unknown service" for codes §5.3 does not list.
const char* ServiceName(uint8_t service);

// General error codes (§5.3 [SPEC-H]).
inline constexpr uint8_t kErrResourceUnavailable = 0x02;
inline constexpr uint8_t kErrServiceNotSupported = 0x08;
inline constexpr uint8_t kErrInvalidAttributeValue = 0x09;
inline constexpr uint8_t kErrAlreadyInRequestedState = 0x0B;
inline constexpr uint8_t kErrObjectStateConflict = 0x0C;
inline constexpr uint8_t kErrAttributeNotSettable = 0x0E;
inline constexpr uint8_t kErrDeviceStateConflict = 0x10;
inline constexpr uint8_t kErrReplyDataTooLarge = 0x11;
inline constexpr uint8_t kErrNotEnoughData = 0x13;
inline constexpr uint8_t kErrAttributeNotSupported = 0x14;
inline constexpr uint8_t kErrTooMuchData = 0x15;
inline constexpr uint8_t kErrObjectDoesNotExist = 0x16;
inline constexpr uint8_t kErrVendorSpecific = 0x1F;
inline constexpr uint8_t kErrInvalidParameter = 0x20;
// Additional codes of the DeviceNet object for Allocate/Release (§5.5 [SPEC-M], D-14).
inline constexpr uint8_t kAddAllocationConflict = 0x01;
inline constexpr uint8_t kAddInvalidChoice = 0x02;
inline constexpr uint8_t kAddInvalidGroup2OnlyRequest = 0x03;
inline constexpr uint8_t kAddResourceUnavailable = 0x04;
inline constexpr uint8_t kAddNone = 0xFF;
// "object state conflict"; "unknown general error" otherwise.
const char* GeneralErrorName(uint8_t general);
// DeviceNet-object additional codes ("allocation conflict"), "none" for 0xFF, else "unknown".
const char* AdditionalErrorName(uint8_t additional);

// Object classes, instances and attributes the gateway and the simulator use (§5.6, §5.11).
inline constexpr uint8_t kClassIdentity = 0x01;
inline constexpr uint8_t kClassMessageRouter = 0x02;
inline constexpr uint8_t kClassDeviceNet = 0x03;
inline constexpr uint8_t kClassAssembly = 0x04;
inline constexpr uint8_t kClassConnection = 0x05;
inline constexpr uint8_t kInstanceExplicit = 1;  // connection instances of the predefined set
inline constexpr uint8_t kInstancePoll = 2;
inline constexpr uint8_t kInstanceBitStrobe = 3;
inline constexpr uint8_t kInstanceCosCyclic = 4;
inline constexpr uint8_t kInstanceMulticastPoll = 5;
inline constexpr uint8_t kAttrConnState = 1;
inline constexpr uint8_t kAttrConnInstanceType = 2;
inline constexpr uint8_t kAttrConnTransportClassTrigger = 3;
inline constexpr uint8_t kAttrConnProducedConnectionId = 4;
inline constexpr uint8_t kAttrConnConsumedConnectionId = 5;
inline constexpr uint8_t kAttrConnInitialCommCharacteristics = 6;
inline constexpr uint8_t kAttrConnProducedSize = 7;
inline constexpr uint8_t kAttrConnConsumedSize = 8;
inline constexpr uint8_t kAttrConnExpectedPacketRate = 9;
inline constexpr uint8_t kAttrConnWatchdogTimeoutAction = 12;
inline constexpr uint8_t kAttrConnProductionInhibitTime = 17;
inline constexpr uint8_t kAttrIdentityVendorId = 1;
inline constexpr uint8_t kAttrIdentityDeviceType = 2;
inline constexpr uint8_t kAttrIdentityProductCode = 3;
inline constexpr uint8_t kAttrIdentityRevision = 4;
inline constexpr uint8_t kAttrIdentityStatus = 5;
inline constexpr uint8_t kAttrIdentitySerialNumber = 6;
inline constexpr uint8_t kAttrIdentityProductName = 7;
inline constexpr uint8_t kAttrDnMacId = 1;
inline constexpr uint8_t kAttrDnBaudRate = 2;
inline constexpr uint8_t kAttrDnBusOffInterrupt = 3;
inline constexpr uint8_t kAttrDnBusOffCounter = 4;
inline constexpr uint8_t kAttrDnAllocationInformation = 5;

// Allocation / release choice bits (§5.5 [SPEC-H]; bit 3 [SPEC-M]).
inline constexpr uint8_t kAllocExplicit = 0x01;
inline constexpr uint8_t kAllocPolled = 0x02;
inline constexpr uint8_t kAllocBitStrobed = 0x04;
inline constexpr uint8_t kAllocMulticastPoll = 0x08;
inline constexpr uint8_t kAllocChangeOfState = 0x10;
inline constexpr uint8_t kAllocCyclic = 0x20;
inline constexpr uint8_t kAllocAckSuppression = 0x40;
// OK unless bit 7 (reserved) is set or CoS and cyclic are both set (§5.5, mutually exclusive):
// "allocate.choice: 0x30 sets both change_of_state and cyclic".
absl::Status ValidateAllocationChoice(uint8_t choice);
// "explicit|polled|cos" style list of the set bits, for messages.
std::string AllocationChoiceText(uint8_t choice);

// Message body format: class / instance widths (§5.5 response byte 2 low nibble).
enum class BodyFormat : uint8_t { k8_8 = 0, k8_16 = 1, k16_16 = 2, k16_8 = 3 };

// Request: header, service (R/R = 0), class, instance, then for Get/Set_Attribute_Single the
// attribute, then service data (§5.3, §5.4).
struct ExplicitRequest {
  ExplicitHeader header;  // fragmented must be false; fragments come from Fragmenter
  uint8_t service = 0;    // 0..0x7F
  uint16_t class_id = 0;
  uint16_t instance_id = 0;
  std::optional<uint8_t> attribute_id;  // present iff service is Get/Set_Attribute_Single
  std::vector<uint8_t> data;            // service data after the path
  friend bool operator==(const ExplicitRequest&, const ExplicitRequest&) = default;
};

// Response: header, 0x80 | service, service data (§5.3). Error response: service 0x14 and data
// = general, additional.
struct ExplicitResponse {
  ExplicitHeader header;
  uint8_t service = 0;  // without the R/R bit
  std::vector<uint8_t> data;
  bool is_error() const { return service == kServiceErrorResponse; }
  friend bool operator==(const ExplicitResponse&, const ExplicitResponse&) = default;
};

struct ErrorResponse {
  uint8_t general = 0;
  uint8_t additional = kAddNone;
  friend constexpr bool operator==(ErrorResponse, ErrorResponse) = default;
};

// Full message bytes (header first). Lengths above 8 need the Fragmenter. Errors:
// "devicenet explicit_request.class_id: 256 exceeds 8-bit body format 8/8"; mac_id > 63;
// service > 0x7F; attribute present/absent against the service; header.fragmented set.
absl::StatusOr<std::vector<uint8_t>> EncodeExplicitRequest(const ExplicitRequest& request,
                                                           BodyFormat format = BodyFormat::k8_8);
// InvalidArgument naming the missing field ("devicenet explicit_request: 4 bytes, class,
// instance and attribute need 5"), a response bit set or a fragmented header.
absl::StatusOr<ExplicitRequest> DecodeExplicitRequest(std::span<const uint8_t> bytes,
                                                      BodyFormat format = BodyFormat::k8_8);
absl::StatusOr<std::vector<uint8_t>> EncodeExplicitResponse(const ExplicitResponse& response);
// InvalidArgument for fewer than 2 bytes, R/R bit clear, a fragmented header, or an error
// response whose data is not exactly 2 bytes (general, additional).
absl::StatusOr<ExplicitResponse> DecodeExplicitResponse(std::span<const uint8_t> bytes);

// Builders (master MAC in the header, §5.3 byte 0 note; XID chosen by the session).
ExplicitRequest AllocateRequest(uint8_t master_mac, bool xid, uint8_t choice);
ExplicitRequest ReleaseRequest(uint8_t master_mac, bool xid, uint8_t choice);
ExplicitRequest GetAttributeSingleRequest(uint8_t master_mac, bool xid, uint16_t class_id,
                                          uint16_t instance_id, uint8_t attribute_id);
ExplicitRequest SetAttributeSingleRequest(uint8_t master_mac, bool xid, uint16_t class_id,
                                          uint16_t instance_id, uint8_t attribute_id,
                                          std::vector<uint8_t> value);
// Set of connection attribute 9 (expected packet rate, UINT ms, low byte first).
ExplicitRequest SetExpectedPacketRateRequest(uint8_t master_mac, bool xid, uint8_t instance,
                                             uint16_t epr_ms);
ExplicitResponse ErrorResponseMessage(ExplicitHeader header, ErrorResponse error);
// Allocate success response: data = [body format in the low nibble] (§5.5).
ExplicitResponse AllocateResponse(ExplicitHeader header, BodyFormat format = BodyFormat::k8_8);
ExplicitResponse ReleaseResponse(ExplicitHeader header);

// Decoded Allocate / Release request (class 3, instance 1; §5.5).
struct AllocateParams {
  uint8_t choice = 0;
  uint8_t allocator_mac = 0;  // Allocate only; Release carries none
  friend constexpr bool operator==(AllocateParams, AllocateParams) = default;
};
// InvalidArgument unless service 0x4B, class 3, instance 1 and data = choice, allocator MAC
// (<= 63): "devicenet allocate.allocator_mac: 64 exceeds 63".
absl::StatusOr<AllocateParams> DecodeAllocate(const ExplicitRequest& request);
// InvalidArgument unless service 0x4C, class 3, instance 1 and data = choice.
absl::StatusOr<uint8_t> DecodeRelease(const ExplicitRequest& request);
// Body format of an Allocate success response (service 0x4B, 1 byte of data).
absl::StatusOr<BodyFormat> DecodeAllocateResponse(const ExplicitResponse& response);
// The (general, additional) pair of an error response; InvalidArgument if not one.
absl::StatusOr<ErrorResponse> DecodeErrorResponse(const ExplicitResponse& response);
// "object state conflict (0x0C), additional allocation conflict (0x01)".
std::string ErrorResponseText(ErrorResponse error);
// A failed explicit request as a Status: FailedPrecondition "devicenet Allocate_Master/Slave_
// Connection_Set: error response object state conflict (0x0C), additional allocation conflict
// (0x01)", with the pair attached as payload (kErrorResponsePayloadUrl, value "0C01").
absl::Status ErrorResponseStatus(uint8_t request_service, ErrorResponse error);
inline constexpr char kErrorResponsePayloadUrl[] = "type.drivegw.dev/devicenet.ErrorResponse";
std::optional<ErrorResponse> GetErrorResponse(const absl::Status& status);

// UINT / UDINT attribute values, little-endian (§0.3 [SPEC-H]).
std::vector<uint8_t> UintValue(uint16_t v);
// InvalidArgument unless exactly 2 bytes: "devicenet attribute: 1 bytes, UINT needs 2".
absl::StatusOr<uint16_t> DecodeUintValue(std::span<const uint8_t> data);

// ---------------------------------------------------------------------------------------------
// UCMM Open / Close Explicit Messaging Connection (Group 3, §5.9 [SPEC-M], D-11).

struct UcmmOpenRequest {
  ExplicitHeader header;  // MAC = server (drive) MAC
  BodyFormat requested_format = BodyFormat::k8_8;
  uint8_t group_select = 1;       // 0 = G1, 1 = G2, 3 = G3 (high nibble of byte 3)
  uint8_t source_message_id = 0;  // low nibble of byte 3
  friend constexpr bool operator==(UcmmOpenRequest, UcmmOpenRequest) = default;
};
struct UcmmOpenResponse {
  ExplicitHeader header;  // MAC = client MAC
  BodyFormat actual_format = BodyFormat::k8_8;
  uint8_t destination_message_id = 0;  // high nibble of byte 3
  uint8_t source_message_id = 0;       // low nibble of byte 3
  uint16_t connection_instance = 0;    // UINT, low byte first
  friend constexpr bool operator==(UcmmOpenResponse, UcmmOpenResponse) = default;
};
absl::StatusOr<std::vector<uint8_t>> EncodeUcmmOpenRequest(const UcmmOpenRequest& request);
absl::StatusOr<UcmmOpenRequest> DecodeUcmmOpenRequest(std::span<const uint8_t> bytes);
absl::StatusOr<std::vector<uint8_t>> EncodeUcmmOpenResponse(const UcmmOpenResponse& response);
absl::StatusOr<UcmmOpenResponse> DecodeUcmmOpenResponse(std::span<const uint8_t> bytes);

// ---------------------------------------------------------------------------------------------
// Fragmentation (§5.8): protocol byte = type << 6 | count (count modulo 64).

enum class FragmentType : uint8_t { kFirst = 0, kMiddle = 1, kLast = 2, kAck = 3 };
const char* FragmentTypeName(FragmentType type);  // "first", "middle", "last", "ack"
constexpr uint8_t FragmentByte(FragmentType type, uint8_t count) {
  return static_cast<uint8_t>((static_cast<uint8_t>(type) << 6) | (count & 0x3F));
}
constexpr FragmentType FragmentTypeOf(uint8_t b) { return static_cast<FragmentType>(b >> 6); }
constexpr uint8_t FragmentCountOf(uint8_t b) { return b & 0x3F; }

inline constexpr size_t kIoFragmentData = 7;        // I/O: byte 0 protocol, 1..7 data
inline constexpr size_t kExplicitFragmentData = 6;  // explicit: header, protocol, 6 data bytes
// Largest message a Reassembler accepts by default: 64 fragments of 7 bytes (no wrap in one
// message; decision 904).
inline constexpr size_t kMaxFragmentedMessage = 64 * kIoFragmentData;

// Explicit fragment acknowledge (§5.8 [SPEC-M]): [header Frag=1] [0xC0 | count] [status].
inline constexpr uint8_t kAckSuccess = 0x00;
inline constexpr uint8_t kAckTooMuchData = 0x01;
struct FragmentAck {
  ExplicitHeader header;  // fragmented = true on the wire
  uint8_t count = 0;      // 0..63, the acknowledged fragment
  uint8_t status = kAckSuccess;
  friend constexpr bool operator==(FragmentAck, FragmentAck) = default;
};
absl::StatusOr<std::vector<uint8_t>> EncodeFragmentAck(const FragmentAck& ack);
// InvalidArgument unless 3 bytes, Frag = 1 and type ack.
absl::StatusOr<FragmentAck> DecodeFragmentAck(std::span<const uint8_t> bytes);
// True if `bytes` is an explicit frame with Frag = 1 and fragment type ack.
bool IsFragmentAck(std::span<const uint8_t> bytes);

// Splits one message into fragment payloads (each one CAN frame's data). I/O fragments are sent
// back-to-back; explicit fragments one at a time, each after the previous one's ack.
class Fragmenter {
 public:
  // InvalidArgument if the message fits in one unfragmented frame (<= 8 bytes) or needs more
  // than 64 fragments (decision 904).
  static absl::StatusOr<Fragmenter> ForIo(std::span<const uint8_t> message);
  // `message` = full explicit message, header byte first with Frag = 0 (InvalidArgument
  // otherwise); the fragments carry it with Frag = 1.
  static absl::StatusOr<Fragmenter> ForExplicit(std::span<const uint8_t> message);

  size_t fragment_count() const { return fragments_.size(); }
  bool done() const { return next_ >= fragments_.size(); }
  // Payload of fragment i (0-based).
  const std::vector<uint8_t>& fragment(size_t i) const { return fragments_[i]; }
  const std::vector<std::vector<uint8_t>>& fragments() const { return fragments_; }
  // The next fragment to send; FailedPrecondition when done, or (explicit) while the previous
  // fragment is not acknowledged.
  absl::StatusOr<std::vector<uint8_t>> Next();
  // Explicit only: the ack of the fragment sent last. InvalidArgument for a malformed ack,
  // FailedPrecondition for a wrong count ("ack count 2, expected 1") or a failure status.
  absl::Status AcceptAck(std::span<const uint8_t> ack_payload);

 private:
  Fragmenter(bool is_explicit, std::vector<std::vector<uint8_t>> fragments)
      : explicit_(is_explicit), fragments_(std::move(fragments)) {}
  bool explicit_ = false;
  bool awaiting_ack_ = false;
  size_t next_ = 0;
  std::vector<std::vector<uint8_t>> fragments_;
};

// Rebuilds one fragmented message. Any sequence error (fragment without a first, out of order,
// duplicate, missing, oversize, ack in the data stream) returns InvalidArgument naming the
// fragment counts and resets to idle; a first fragment always starts a new message (decision
// 904), so a first fragment that interrupts an unfinished message is reported and then kept.
class Reassembler {
 public:
  explicit Reassembler(size_t max_message_size = kMaxFragmentedMessage)
      : max_size_(max_message_size) {}

  // I/O fragment payload: [protocol] [data...]. Returns the message when the last fragment
  // arrived, nullopt while incomplete.
  absl::StatusOr<std::optional<std::vector<uint8_t>>> FeedIo(std::span<const uint8_t> payload);
  // Explicit fragment payload: [header Frag=1] [protocol] [body...]. The completed message is
  // [header with Frag=0] [body...], ready for DecodeExplicitRequest/Response. The caller sends
  // an ack for every accepted fragment (AckFor).
  absl::StatusOr<std::optional<std::vector<uint8_t>>> FeedExplicit(
      std::span<const uint8_t> payload);

  void Reset();
  bool idle() const { return !active_; }
  uint8_t next_count() const { return next_count_; }
  size_t buffered() const { return buffer_.size(); }
  size_t max_message_size() const { return max_size_; }

 private:
  absl::StatusOr<std::optional<std::vector<uint8_t>>> Feed(uint8_t protocol,
                                                           std::span<const uint8_t> data,
                                                           const char* where);
  size_t max_size_;
  bool active_ = false;
  uint8_t next_count_ = 0;
  std::optional<uint8_t> explicit_header_;
  std::vector<uint8_t> buffer_;
};

// ---------------------------------------------------------------------------------------------
// Duplicate MAC ID check (§5.7 [SPEC-H]): Group 2 msg 7, DLC 7.

struct DuplicateMacCheck {
  bool response = false;       // byte 0 bit 7
  uint8_t port = 0;            // byte 0 bits 6..0, physical port number
  uint16_t vendor_id = 0;      // bytes 1-2, low byte first
  uint32_t serial_number = 0;  // bytes 3-6, low byte first
  friend constexpr bool operator==(DuplicateMacCheck, DuplicateMacCheck) = default;
};
inline constexpr size_t kDuplicateMacCheckSize = 7;
// InvalidArgument for port > 127.
absl::StatusOr<std::vector<uint8_t>> EncodeDuplicateMacCheck(const DuplicateMacCheck& message);
// InvalidArgument unless exactly 7 bytes.
absl::StatusOr<DuplicateMacCheck> DecodeDuplicateMacCheck(std::span<const uint8_t> bytes);
// The whole frame on 0x400 | mac << 3 | 7.
absl::StatusOr<Frame> DuplicateMacCheckFrame(uint8_t mac, const DuplicateMacCheck& message);

// ---------------------------------------------------------------------------------------------
// I/O frames: poll command (G2 msg 5), poll response (G1 0xF), change of state / cyclic (G1
// 0xD), and the zero-length CoS acknowledges (§5.2, §5.6, §5.8).

// Frames carrying one I/O message of a connection of `connection_size` bytes on `id`: one frame
// if the size is <= 8, I/O fragments otherwise (§5.8). InvalidArgument when the message length
// differs from the connection size ("devicenet poll_command: 4 bytes, connection size 6").
absl::StatusOr<std::vector<Frame>> EncodeIoMessage(uint16_t id, std::span<const uint8_t> message,
                                                   size_t connection_size);
absl::StatusOr<std::vector<Frame>> EncodePollCommand(uint8_t slave_mac,
                                                     std::span<const uint8_t> image,
                                                     size_t connection_size);
absl::StatusOr<std::vector<Frame>> EncodePollResponse(uint8_t slave_mac,
                                                      std::span<const uint8_t> image,
                                                      size_t connection_size);
absl::StatusOr<std::vector<Frame>> EncodeChangeOfState(uint8_t slave_mac,
                                                       std::span<const uint8_t> image,
                                                       size_t connection_size);
// Master's ack of slave CoS data: 0x400 | n << 3 | 2, DLC 0 [SPEC-M].
absl::StatusOr<Frame> CosAcknowledgeFrame(uint8_t slave_mac);
// Slave's ack of master CoS data: 0x3C0 | n, DLC 0 [SPEC-M].
absl::StatusOr<Frame> SlaveCosAcknowledgeFrame(uint8_t slave_mac);

// Receives the frames of one I/O connection (one direction) and yields whole messages. With a
// connection size above 8 it reassembles; otherwise every frame is one message. A message whose
// length differs from the connection size is an InvalidArgument (D-24: counted and dropped by
// the caller).
class IoReceiver {
 public:
  explicit IoReceiver(size_t connection_size)
      : connection_size_(connection_size),
        reassembler_(connection_size > kMaxFrameData ? connection_size : kMaxFrameData) {}
  absl::StatusOr<std::optional<std::vector<uint8_t>>> Feed(std::span<const uint8_t> payload);
  void Reset() { reassembler_.Reset(); }
  size_t connection_size() const { return connection_size_; }
  bool fragmented() const { return connection_size_ > kMaxFrameData; }

 private:
  size_t connection_size_;
  Reassembler reassembler_;
};

}  // namespace drivegw::linmot::devicenet
