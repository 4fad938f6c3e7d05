// DeviceNet link layer codec: identifiers, explicit messages, fragmentation, duplicate MAC ID
// check and I/O frames, byte by byte per linmot-devicenet.md §5.
#include "adapters/linmot/devicenet/codec.h"

#include <algorithm>
#include <utility>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"

namespace drivegw::linmot::devicenet {
namespace {

std::string Hex2(unsigned v) { return absl::StrFormat("0x%02X", v); }
std::string Hex3(unsigned v) { return absl::StrFormat("0x%03X", v); }

absl::Status Invalid(const std::string& where, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("devicenet ", where, ": ", what));
}

absl::Status CheckMac(const std::string& where, unsigned mac) {
  if (mac > kMaxMacId) return Invalid(where, absl::StrCat(mac, " exceeds ", kMaxMacId));
  return absl::OkStatus();
}

// Width in bytes of class / instance in a body format (§5.5).
size_t ClassWidth(BodyFormat f) {
  return (f == BodyFormat::k16_16 || f == BodyFormat::k16_8) ? 2 : 1;
}
size_t InstanceWidth(BodyFormat f) {
  return (f == BodyFormat::k8_16 || f == BodyFormat::k16_16) ? 2 : 1;
}
const char* BodyFormatName(BodyFormat f) {
  switch (f) {
    case BodyFormat::k8_8:
      return "8/8";
    case BodyFormat::k8_16:
      return "8/16";
    case BodyFormat::k16_16:
      return "16/16";
    case BodyFormat::k16_8:
      return "16/8";
  }
  return "?";
}

void PutField(std::vector<uint8_t>& out, uint16_t v, size_t width) {
  out.push_back(static_cast<uint8_t>(v));  // CIP: low byte first (§0.3 [SPEC-H])
  if (width == 2) out.push_back(static_cast<uint8_t>(v >> 8));
}
uint16_t GetField(std::span<const uint8_t> b, size_t at, size_t width) {
  return width == 2 ? static_cast<uint16_t>(b[at] | (b[at + 1] << 8)) : b[at];
}

bool HasAttribute(uint8_t service) {
  return service == kServiceGetAttributeSingle || service == kServiceSetAttributeSingle;
}

absl::StatusOr<std::vector<Frame>> FramesOf(uint16_t id,
                                            const std::vector<std::vector<uint8_t>>& payloads) {
  std::vector<Frame> frames;
  frames.reserve(payloads.size());
  for (const auto& p : payloads) {
    auto f = MakeFrame(id, p);
    if (!f.ok()) return f.status();
    frames.push_back(*f);
  }
  return frames;
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Frames.

absl::StatusOr<Frame> MakeFrame(uint16_t id, std::span<const uint8_t> bytes) {
  if (id > kMaxIdentifier) {
    return Invalid("frame.id", absl::StrCat(Hex3(id), " exceeds 11 bits (0x7FF)"));
  }
  if (bytes.size() > kMaxFrameData) {
    return Invalid("frame", absl::StrCat(bytes.size(), " data bytes exceed ", kMaxFrameData));
  }
  Frame f;
  f.id = id;
  f.dlc = static_cast<uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

std::string FrameToString(const Frame& frame) {
  std::string s = absl::StrFormat("%03X#", frame.id);
  for (size_t i = 0; i < frame.payload().size(); ++i) {
    if (i > 0) s += '.';
    absl::StrAppendFormat(&s, "%02X", frame.payload()[i]);
  }
  return s;
}

absl::StatusOr<Frame> ParseFrame(std::string_view text) {
  const size_t hash = text.find('#');
  if (hash == std::string_view::npos || hash == 0 || hash > 3) {
    return Invalid("frame", absl::StrCat("'", std::string(text), "' is not ID#DATA"));
  }
  unsigned id = 0;
  for (char c : text.substr(0, hash)) {
    const int d = HexDigit(c);
    if (d < 0) return Invalid("frame", absl::StrCat("bad identifier in '", std::string(text), "'"));
    id = id * 16 + static_cast<unsigned>(d);
  }
  std::vector<uint8_t> bytes;
  std::string_view rest = text.substr(hash + 1);
  size_t i = 0;
  while (i < rest.size()) {
    if (rest[i] == '.') {
      ++i;
      continue;
    }
    if (i + 1 >= rest.size() || HexDigit(rest[i]) < 0 || HexDigit(rest[i + 1]) < 0) {
      return Invalid("frame", absl::StrCat("bad data in '", std::string(text), "'"));
    }
    bytes.push_back(static_cast<uint8_t>(HexDigit(rest[i]) * 16 + HexDigit(rest[i + 1])));
    i += 2;
  }
  return MakeFrame(static_cast<uint16_t>(id), bytes);
}

// ---------------------------------------------------------------------------------------------
// Identifiers (§5.1).

absl::StatusOr<uint16_t> EncodeIdentifier(const Identifier& in) {
  const unsigned mac = in.mac_id;
  const unsigned msg = in.message_id;
  switch (in.group) {
    case MessageGroup::kGroup1:
      DGW_RETURN_IF_ERROR(CheckMac("identifier.mac_id", mac));
      if (msg > 0xF) {
        return Invalid("identifier.message_id", absl::StrCat(msg, " exceeds group 1 limit 15"));
      }
      return static_cast<uint16_t>((msg << 6) | mac);
    case MessageGroup::kGroup2:
      DGW_RETURN_IF_ERROR(CheckMac("identifier.mac_id", mac));
      if (msg > 7) {
        return Invalid("identifier.message_id", absl::StrCat(msg, " exceeds group 2 limit 7"));
      }
      return static_cast<uint16_t>(0x400 | (mac << 3) | msg);
    case MessageGroup::kGroup3:
      DGW_RETURN_IF_ERROR(CheckMac("identifier.mac_id", mac));
      if (msg > 6) {
        return Invalid("identifier.message_id", absl::StrCat(msg, " exceeds group 3 limit 6"));
      }
      return static_cast<uint16_t>(0x600 | (msg << 6) | mac);
    case MessageGroup::kGroup4:
      if (mac != 0) {
        return Invalid("identifier.mac_id", absl::StrCat(mac, ": group 4 has no MAC field"));
      }
      if (msg > 0x2F) {
        return Invalid("identifier.message_id",
                       absl::StrCat(Hex2(msg), " exceeds group 4 limit 0x2F"));
      }
      return static_cast<uint16_t>(0x7C0 | msg);
  }
  return Invalid("identifier.group", absl::StrCat(static_cast<int>(in.group), " is not 1-4"));
}

absl::StatusOr<Identifier> DecodeIdentifier(uint16_t id) {
  if (id > kMaxIdentifier) {
    return Invalid("identifier", absl::StrCat(Hex3(id), " exceeds 11 bits (0x7FF)"));
  }
  if (id < 0x400) {
    return Identifier{MessageGroup::kGroup1, static_cast<uint8_t>(id & 0x3F),
                      static_cast<uint8_t>(id >> 6)};
  }
  if (id < 0x600) {
    return Identifier{MessageGroup::kGroup2, static_cast<uint8_t>((id >> 3) & 0x3F),
                      static_cast<uint8_t>(id & 0x7)};
  }
  if (id < 0x7C0) {  // message ID 7 would be 0x7C0 and above: group 4
    return Identifier{MessageGroup::kGroup3, static_cast<uint8_t>(id & 0x3F),
                      static_cast<uint8_t>((id >> 6) & 0x7)};
  }
  if (id < 0x7F0) {
    return Identifier{MessageGroup::kGroup4, 0, static_cast<uint8_t>(id & 0x3F)};
  }
  return Invalid("identifier", absl::StrCat(Hex3(id), " is in the invalid range 0x7F0-0x7FF"));
}

absl::StatusOr<PredefinedIds> PredefinedSetIds(uint8_t n) {
  DGW_RETURN_IF_ERROR(CheckMac("predefined_set.slave_mac", n));
  const auto g2 = [n](unsigned msg) { return static_cast<uint16_t>(0x400 | (n << 3) | msg); };
  return PredefinedIds{
      static_cast<uint16_t>(0x340 | n), static_cast<uint16_t>(0x3C0 | n), g2(kG2CosAcknowledge),
      g2(kG2ExplicitResponse),          g2(kG2ExplicitRequest),           g2(kG2PollCommand),
      g2(kG2UnconnectedRequest),        g2(kG2DuplicateMacCheck),
  };
}

// ---------------------------------------------------------------------------------------------
// Names.

const char* ServiceName(uint8_t service) {
  switch (service & 0x7F) {
    case kServiceGetAttributesAll:
      return "Get_Attributes_All";
    case kServiceReset:
      return "Reset";
    case kServiceApplyAttributes:
      return "Apply_Attributes";
    case kServiceGetAttributeSingle:
      return "Get_Attribute_Single";
    case kServiceSetAttributeSingle:
      return "Set_Attribute_Single";
    case kServiceErrorResponse:
      return "Error_Response";
    case kServiceAllocate:
      return "Allocate_Master/Slave_Connection_Set";
    case kServiceRelease:
      return "Release_Master/Slave_Connection_Set";
    case kServiceDeviceHeartbeat:
      return "Device_Heartbeat";
    case kServiceDeviceShutdown:
      return "Device_Shutdown";
  }
  return "unknown service";
}

const char* GeneralErrorName(uint8_t general) {
  switch (general) {
    case kErrResourceUnavailable:
      return "resource unavailable";
    case kErrServiceNotSupported:
      return "service not supported";
    case kErrInvalidAttributeValue:
      return "invalid attribute value";
    case kErrAlreadyInRequestedState:
      return "already in requested mode/state";
    case kErrObjectStateConflict:
      return "object state conflict";
    case kErrAttributeNotSettable:
      return "attribute not settable";
    case kErrDeviceStateConflict:
      return "device state conflict";
    case kErrReplyDataTooLarge:
      return "reply data too large";
    case kErrNotEnoughData:
      return "not enough data";
    case kErrAttributeNotSupported:
      return "attribute not supported";
    case kErrTooMuchData:
      return "too much data";
    case kErrObjectDoesNotExist:
      return "object does not exist";
    case kErrVendorSpecific:
      return "vendor specific error";
    case kErrInvalidParameter:
      return "invalid parameter";
  }
  return "unknown general error";
}

const char* AdditionalErrorName(uint8_t additional) {
  switch (additional) {
    case kAddAllocationConflict:
      return "allocation conflict";
    case kAddInvalidChoice:
      return "invalid allocation/release choice";
    case kAddInvalidGroup2OnlyRequest:
      return "invalid Group-2-only request";
    case kAddResourceUnavailable:
      return "resource unavailable";
    case kAddNone:
      return "none";
  }
  return "unknown";
}

absl::Status ValidateAllocationChoice(uint8_t choice) {
  if (choice & 0x80) {
    return Invalid("allocate.choice", absl::StrCat(Hex2(choice), " sets reserved bit 7"));
  }
  if ((choice & kAllocChangeOfState) && (choice & kAllocCyclic)) {
    return Invalid("allocate.choice",
                   absl::StrCat(Hex2(choice), " sets both change_of_state and cyclic"));
  }
  return absl::OkStatus();
}

std::string AllocationChoiceText(uint8_t choice) {
  static constexpr const char* kNames[8] = {"explicit",        "polled",          "bit_strobed",
                                            "multicast_poll",  "change_of_state", "cyclic",
                                            "ack_suppression", "reserved7"};
  std::string s;
  for (int bit = 0; bit < 8; ++bit) {
    if ((choice >> bit) & 1u) absl::StrAppend(&s, s.empty() ? "" : "|", kNames[bit]);
  }
  return s.empty() ? "none" : s;
}

// ---------------------------------------------------------------------------------------------
// Explicit messages (§5.3-§5.5).

absl::StatusOr<std::vector<uint8_t>> EncodeExplicitRequest(const ExplicitRequest& r,
                                                           BodyFormat format) {
  const std::string name = ServiceName(r.service);
  if (r.header.fragmented) {
    return Invalid("explicit_request.header",
                   "fragmented is set; use Fragmenter for messages above 8 bytes");
  }
  DGW_RETURN_IF_ERROR(CheckMac("explicit_request.header.mac_id", r.header.mac_id));
  if (r.service > 0x7F) {
    return Invalid("explicit_request.service",
                   absl::StrCat(Hex2(r.service), " exceeds 0x7F (bit 7 is R/R)"));
  }
  const size_t cw = ClassWidth(format);
  const size_t iw = InstanceWidth(format);
  if (cw == 1 && r.class_id > 0xFF) {
    return Invalid("explicit_request.class_id",
                   absl::StrCat(r.class_id, " exceeds 8-bit body format ", BodyFormatName(format)));
  }
  if (iw == 1 && r.instance_id > 0xFF) {
    return Invalid(
        "explicit_request.instance_id",
        absl::StrCat(r.instance_id, " exceeds 8-bit body format ", BodyFormatName(format)));
  }
  if (HasAttribute(r.service) != r.attribute_id.has_value()) {
    return Invalid("explicit_request.attribute_id",
                   absl::StrCat(r.attribute_id ? "present" : "absent", " but ", name,
                                r.attribute_id ? " takes none" : " needs one"));
  }
  std::vector<uint8_t> out;
  out.push_back(EncodeExplicitHeader(r.header));
  out.push_back(r.service);
  PutField(out, r.class_id, cw);
  PutField(out, r.instance_id, iw);
  if (r.attribute_id) out.push_back(*r.attribute_id);
  out.insert(out.end(), r.data.begin(), r.data.end());
  return out;
}

absl::StatusOr<ExplicitRequest> DecodeExplicitRequest(std::span<const uint8_t> b,
                                                      BodyFormat format) {
  if (b.size() < 2) {
    return Invalid("explicit_request", absl::StrCat(b.size(), " bytes, header and service need 2"));
  }
  ExplicitRequest r;
  r.header = DecodeExplicitHeader(b[0]);
  if (r.header.fragmented) {
    return Invalid("explicit_request.header", "fragmented; reassemble first");
  }
  if (b[1] & kResponseBit) {
    return Invalid("explicit_request.service",
                   absl::StrCat(Hex2(b[1]), " has the R/R bit set (a response)"));
  }
  r.service = b[1];
  const size_t cw = ClassWidth(format);
  const size_t iw = InstanceWidth(format);
  const size_t need = 2 + cw + iw + (HasAttribute(r.service) ? 1 : 0);
  if (b.size() < need) {
    return Invalid(
        "explicit_request",
        absl::StrCat(b.size(), " bytes, ", ServiceName(r.service), " with class, instance",
                     HasAttribute(r.service) ? " and attribute" : "", " needs ", need));
  }
  r.class_id = GetField(b, 2, cw);
  r.instance_id = GetField(b, 2 + cw, iw);
  if (HasAttribute(r.service)) r.attribute_id = b[2 + cw + iw];
  r.data.assign(b.begin() + static_cast<std::ptrdiff_t>(need), b.end());
  return r;
}

absl::StatusOr<std::vector<uint8_t>> EncodeExplicitResponse(const ExplicitResponse& r) {
  if (r.header.fragmented) {
    return Invalid("explicit_response.header",
                   "fragmented is set; use Fragmenter for messages above 8 bytes");
  }
  DGW_RETURN_IF_ERROR(CheckMac("explicit_response.header.mac_id", r.header.mac_id));
  if (r.service > 0x7F) {
    return Invalid("explicit_response.service",
                   absl::StrCat(Hex2(r.service), " exceeds 0x7F (bit 7 is R/R)"));
  }
  if (r.is_error() && r.data.size() != 2) {
    return Invalid("explicit_response.data",
                   absl::StrCat(r.data.size(), " bytes, an error response carries 2"));
  }
  std::vector<uint8_t> out;
  out.push_back(EncodeExplicitHeader(r.header));
  out.push_back(static_cast<uint8_t>(kResponseBit | r.service));
  out.insert(out.end(), r.data.begin(), r.data.end());
  return out;
}

absl::StatusOr<ExplicitResponse> DecodeExplicitResponse(std::span<const uint8_t> b) {
  if (b.size() < 2) {
    return Invalid("explicit_response",
                   absl::StrCat(b.size(), " bytes, header and service need 2"));
  }
  ExplicitResponse r;
  r.header = DecodeExplicitHeader(b[0]);
  if (r.header.fragmented) {
    return Invalid("explicit_response.header", "fragmented; reassemble first");
  }
  if ((b[1] & kResponseBit) == 0) {
    return Invalid("explicit_response.service",
                   absl::StrCat(Hex2(b[1]), " has the R/R bit clear (a request)"));
  }
  r.service = static_cast<uint8_t>(b[1] & 0x7F);
  r.data.assign(b.begin() + 2, b.end());
  if (r.is_error() && r.data.size() != 2) {
    return Invalid("explicit_response", absl::StrCat("error response with ", r.data.size(),
                                                     " data bytes, needs 2 (general, additional)"));
  }
  return r;
}

ExplicitRequest AllocateRequest(uint8_t master_mac, bool xid, uint8_t choice) {
  return ExplicitRequest{
      {false, xid, master_mac}, kServiceAllocate, kClassDeviceNet, 1, std::nullopt,
      {choice, master_mac}};
}

ExplicitRequest ReleaseRequest(uint8_t master_mac, bool xid, uint8_t choice) {
  return ExplicitRequest{
      {false, xid, master_mac}, kServiceRelease, kClassDeviceNet, 1, std::nullopt, {choice}};
}

ExplicitRequest GetAttributeSingleRequest(uint8_t master_mac, bool xid, uint16_t class_id,
                                          uint16_t instance_id, uint8_t attribute_id) {
  return ExplicitRequest{{false, xid, master_mac},
                         kServiceGetAttributeSingle,
                         class_id,
                         instance_id,
                         attribute_id,
                         {}};
}

ExplicitRequest SetAttributeSingleRequest(uint8_t master_mac, bool xid, uint16_t class_id,
                                          uint16_t instance_id, uint8_t attribute_id,
                                          std::vector<uint8_t> value) {
  return ExplicitRequest{
      {false, xid, master_mac}, kServiceSetAttributeSingle, class_id, instance_id, attribute_id,
      std::move(value)};
}

ExplicitRequest SetExpectedPacketRateRequest(uint8_t master_mac, bool xid, uint8_t instance,
                                             uint16_t epr_ms) {
  return SetAttributeSingleRequest(master_mac, xid, kClassConnection, instance,
                                   kAttrConnExpectedPacketRate, UintValue(epr_ms));
}

ExplicitResponse ErrorResponseMessage(ExplicitHeader header, ErrorResponse error) {
  return ExplicitResponse{header, kServiceErrorResponse, {error.general, error.additional}};
}

ExplicitResponse AllocateResponse(ExplicitHeader header, BodyFormat format) {
  return ExplicitResponse{header, kServiceAllocate, {static_cast<uint8_t>(format)}};
}

ExplicitResponse ReleaseResponse(ExplicitHeader header) {
  return ExplicitResponse{header, kServiceRelease, {}};
}

absl::StatusOr<AllocateParams> DecodeAllocate(const ExplicitRequest& r) {
  if (r.service != kServiceAllocate) {
    return Invalid("allocate.service", absl::StrCat(Hex2(r.service), " is not 0x4B"));
  }
  if (r.class_id != kClassDeviceNet || r.instance_id != 1) {
    return Invalid("allocate", absl::StrCat("class ", r.class_id, " instance ", r.instance_id,
                                            ", needs the DeviceNet object (class 3, instance 1)"));
  }
  if (r.data.size() != 2) {
    return Invalid("allocate",
                   absl::StrCat(r.data.size(), " data bytes, needs 2 (choice, allocator MAC)"));
  }
  DGW_RETURN_IF_ERROR(CheckMac("allocate.allocator_mac", r.data[1]));
  return AllocateParams{r.data[0], r.data[1]};
}

absl::StatusOr<uint8_t> DecodeRelease(const ExplicitRequest& r) {
  if (r.service != kServiceRelease) {
    return Invalid("release.service", absl::StrCat(Hex2(r.service), " is not 0x4C"));
  }
  if (r.class_id != kClassDeviceNet || r.instance_id != 1) {
    return Invalid("release", absl::StrCat("class ", r.class_id, " instance ", r.instance_id,
                                           ", needs the DeviceNet object (class 3, instance 1)"));
  }
  if (r.data.size() != 1) {
    return Invalid("release", absl::StrCat(r.data.size(), " data bytes, needs 1 (choice)"));
  }
  return r.data[0];
}

absl::StatusOr<BodyFormat> DecodeAllocateResponse(const ExplicitResponse& r) {
  if (r.service != kServiceAllocate) {
    return Invalid("allocate_response.service",
                   absl::StrCat(Hex2(kResponseBit | r.service), " is not 0xCB"));
  }
  if (r.data.size() != 1) {
    return Invalid("allocate_response",
                   absl::StrCat(r.data.size(), " data bytes, needs 1 (body format)"));
  }
  const uint8_t format = r.data[0] & 0x0F;
  if (format > 3) {
    return Invalid("allocate_response.body_format", absl::StrCat(format, " exceeds 3"));
  }
  return static_cast<BodyFormat>(format);
}

absl::StatusOr<ErrorResponse> DecodeErrorResponse(const ExplicitResponse& r) {
  if (!r.is_error() || r.data.size() != 2) {
    return Invalid("error_response",
                   absl::StrCat("service ", Hex2(kResponseBit | r.service), " with ", r.data.size(),
                                " data bytes is not 0x94 + 2 bytes"));
  }
  return ErrorResponse{r.data[0], r.data[1]};
}

std::string ErrorResponseText(ErrorResponse e) {
  return absl::StrCat(GeneralErrorName(e.general), " (", Hex2(e.general), "), additional ",
                      AdditionalErrorName(e.additional), " (", Hex2(e.additional), ")");
}

absl::Status ErrorResponseStatus(uint8_t request_service, ErrorResponse error) {
  absl::Status s = absl::FailedPreconditionError(absl::StrCat(
      "devicenet ", ServiceName(request_service), ": error response ", ErrorResponseText(error)));
  s.SetPayload(kErrorResponsePayloadUrl,
               absl::Cord(absl::StrFormat("%02X%02X", error.general, error.additional)));
  return s;
}

std::optional<ErrorResponse> GetErrorResponse(const absl::Status& status) {
  auto payload = status.GetPayload(kErrorResponsePayloadUrl);
  if (!payload) return std::nullopt;
  const std::string s(*payload);
  if (s.size() != 4) return std::nullopt;
  int d[4];
  for (int i = 0; i < 4; ++i) {
    d[i] = HexDigit(s[static_cast<size_t>(i)]);
    if (d[i] < 0) return std::nullopt;
  }
  return ErrorResponse{static_cast<uint8_t>(d[0] * 16 + d[1]),
                       static_cast<uint8_t>(d[2] * 16 + d[3])};
}

std::vector<uint8_t> UintValue(uint16_t v) {
  return {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8)};
}

absl::StatusOr<uint16_t> DecodeUintValue(std::span<const uint8_t> data) {
  if (data.size() != 2) {
    return Invalid("attribute", absl::StrCat(data.size(), " bytes, UINT needs 2"));
  }
  return static_cast<uint16_t>(data[0] | (data[1] << 8));
}

// ---------------------------------------------------------------------------------------------
// UCMM (§5.9).

absl::StatusOr<std::vector<uint8_t>> EncodeUcmmOpenRequest(const UcmmOpenRequest& r) {
  DGW_RETURN_IF_ERROR(CheckMac("ucmm_open_request.header.mac_id", r.header.mac_id));
  if (r.header.fragmented) return Invalid("ucmm_open_request.header", "fragmented is set");
  if (r.group_select != 0 && r.group_select != 1 && r.group_select != 3) {
    return Invalid("ucmm_open_request.group_select",
                   absl::StrCat(r.group_select, " is not 0, 1 or 3"));
  }
  if (r.source_message_id > 0xF) {
    return Invalid("ucmm_open_request.source_message_id",
                   absl::StrCat(r.source_message_id, " exceeds 15"));
  }
  return std::vector<uint8_t>{EncodeExplicitHeader(r.header), kServiceAllocate,
                              static_cast<uint8_t>(r.requested_format),
                              static_cast<uint8_t>((r.group_select << 4) | r.source_message_id)};
}

absl::StatusOr<UcmmOpenRequest> DecodeUcmmOpenRequest(std::span<const uint8_t> b) {
  if (b.size() != 4) {
    return Invalid("ucmm_open_request", absl::StrCat(b.size(), " bytes, needs 4"));
  }
  UcmmOpenRequest r;
  r.header = DecodeExplicitHeader(b[0]);
  if (r.header.fragmented) return Invalid("ucmm_open_request.header", "fragmented is set");
  if (b[1] != kServiceAllocate) {
    return Invalid("ucmm_open_request.service", absl::StrCat(Hex2(b[1]), " is not 0x4B"));
  }
  if ((b[2] & 0x0F) > 3) {
    return Invalid("ucmm_open_request.body_format", absl::StrCat(b[2] & 0x0F, " exceeds 3"));
  }
  r.requested_format = static_cast<BodyFormat>(b[2] & 0x0F);
  r.group_select = static_cast<uint8_t>(b[3] >> 4);
  r.source_message_id = static_cast<uint8_t>(b[3] & 0x0F);
  if (r.group_select != 0 && r.group_select != 1 && r.group_select != 3) {
    return Invalid("ucmm_open_request.group_select",
                   absl::StrCat(r.group_select, " is not 0, 1 or 3"));
  }
  return r;
}

absl::StatusOr<std::vector<uint8_t>> EncodeUcmmOpenResponse(const UcmmOpenResponse& r) {
  DGW_RETURN_IF_ERROR(CheckMac("ucmm_open_response.header.mac_id", r.header.mac_id));
  if (r.header.fragmented) return Invalid("ucmm_open_response.header", "fragmented is set");
  if (r.destination_message_id > 0xF || r.source_message_id > 0xF) {
    return Invalid("ucmm_open_response.message_ids",
                   absl::StrCat(r.destination_message_id, "/", r.source_message_id, " exceed 15"));
  }
  return std::vector<uint8_t>{
      EncodeExplicitHeader(r.header),
      static_cast<uint8_t>(kResponseBit | kServiceAllocate),
      static_cast<uint8_t>(r.actual_format),
      static_cast<uint8_t>((r.destination_message_id << 4) | r.source_message_id),
      static_cast<uint8_t>(r.connection_instance),
      static_cast<uint8_t>(r.connection_instance >> 8)};
}

absl::StatusOr<UcmmOpenResponse> DecodeUcmmOpenResponse(std::span<const uint8_t> b) {
  if (b.size() != 6) {
    return Invalid("ucmm_open_response", absl::StrCat(b.size(), " bytes, needs 6"));
  }
  UcmmOpenResponse r;
  r.header = DecodeExplicitHeader(b[0]);
  if (r.header.fragmented) return Invalid("ucmm_open_response.header", "fragmented is set");
  if (b[1] != (kResponseBit | kServiceAllocate)) {
    return Invalid("ucmm_open_response.service", absl::StrCat(Hex2(b[1]), " is not 0xCB"));
  }
  if ((b[2] & 0x0F) > 3) {
    return Invalid("ucmm_open_response.body_format", absl::StrCat(b[2] & 0x0F, " exceeds 3"));
  }
  r.actual_format = static_cast<BodyFormat>(b[2] & 0x0F);
  r.destination_message_id = static_cast<uint8_t>(b[3] >> 4);
  r.source_message_id = static_cast<uint8_t>(b[3] & 0x0F);
  r.connection_instance = static_cast<uint16_t>(b[4] | (b[5] << 8));
  return r;
}

// ---------------------------------------------------------------------------------------------
// Fragmentation (§5.8).

const char* FragmentTypeName(FragmentType type) {
  switch (type) {
    case FragmentType::kFirst:
      return "first";
    case FragmentType::kMiddle:
      return "middle";
    case FragmentType::kLast:
      return "last";
    case FragmentType::kAck:
      return "ack";
  }
  return "?";
}

absl::StatusOr<std::vector<uint8_t>> EncodeFragmentAck(const FragmentAck& ack) {
  DGW_RETURN_IF_ERROR(CheckMac("fragment_ack.header.mac_id", ack.header.mac_id));
  if (ack.count > 0x3F) {
    return Invalid("fragment_ack.count", absl::StrCat(ack.count, " exceeds 63"));
  }
  ExplicitHeader h = ack.header;
  h.fragmented = true;
  return std::vector<uint8_t>{EncodeExplicitHeader(h), FragmentByte(FragmentType::kAck, ack.count),
                              ack.status};
}

absl::StatusOr<FragmentAck> DecodeFragmentAck(std::span<const uint8_t> b) {
  if (b.size() != 3) return Invalid("fragment_ack", absl::StrCat(b.size(), " bytes, needs 3"));
  const ExplicitHeader h = DecodeExplicitHeader(b[0]);
  if (!h.fragmented) return Invalid("fragment_ack.header", "Frag bit clear");
  if (FragmentTypeOf(b[1]) != FragmentType::kAck) {
    return Invalid(
        "fragment_ack",
        absl::StrCat("fragment type ", FragmentTypeName(FragmentTypeOf(b[1])), " is not ack"));
  }
  return FragmentAck{h, FragmentCountOf(b[1]), b[2]};
}

bool IsFragmentAck(std::span<const uint8_t> b) {
  return b.size() >= 2 && (b[0] & 0x80) != 0 && FragmentTypeOf(b[1]) == FragmentType::kAck;
}

namespace {

absl::StatusOr<std::vector<std::vector<uint8_t>>> Split(std::span<const uint8_t> body, size_t chunk,
                                                        std::optional<uint8_t> header,
                                                        const char* where) {
  const size_t n = (body.size() + chunk - 1) / chunk;
  if (n < 2) {
    return Invalid(where, absl::StrCat(body.size(), " bytes fit one fragment; send unfragmented"));
  }
  if (n > 64) {
    return Invalid(where, absl::StrCat(body.size(), " bytes need ", n,
                                       " fragments, more than 64 (decision 904)"));
  }
  std::vector<std::vector<uint8_t>> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const FragmentType t = i == 0       ? FragmentType::kFirst
                           : i == n - 1 ? FragmentType::kLast
                                        : FragmentType::kMiddle;
    std::vector<uint8_t> p;
    if (header) p.push_back(*header);
    p.push_back(FragmentByte(t, static_cast<uint8_t>(i & 0x3F)));
    const size_t begin = i * chunk;
    const size_t end = std::min(body.size(), begin + chunk);
    p.insert(p.end(), body.begin() + static_cast<std::ptrdiff_t>(begin),
             body.begin() + static_cast<std::ptrdiff_t>(end));
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace

absl::StatusOr<Fragmenter> Fragmenter::ForIo(std::span<const uint8_t> message) {
  if (message.size() <= kMaxFrameData) {
    return Invalid("io fragmenter",
                   absl::StrCat(message.size(), " bytes fit one frame; send unfragmented"));
  }
  DGW_ASSIGN_OR_RETURN(auto fragments,
                       Split(message, kIoFragmentData, std::nullopt, "io fragmenter"));
  return Fragmenter(false, std::move(fragments));
}

absl::StatusOr<Fragmenter> Fragmenter::ForExplicit(std::span<const uint8_t> message) {
  if (message.size() <= kMaxFrameData) {
    return Invalid("explicit fragmenter",
                   absl::StrCat(message.size(), " bytes fit one frame; send unfragmented"));
  }
  if (message[0] & 0x80) {
    return Invalid("explicit fragmenter", "header has the Frag bit set; pass the whole message");
  }
  const uint8_t header = static_cast<uint8_t>(message[0] | 0x80);
  DGW_ASSIGN_OR_RETURN(auto fragments, Split(message.subspan(1), kExplicitFragmentData, header,
                                             "explicit fragmenter"));
  return Fragmenter(true, std::move(fragments));
}

absl::StatusOr<std::vector<uint8_t>> Fragmenter::Next() {
  if (done()) {
    return absl::FailedPreconditionError(
        absl::StrCat("devicenet fragmenter: all ", fragments_.size(), " fragments sent"));
  }
  if (explicit_ && awaiting_ack_) {
    return absl::FailedPreconditionError(absl::StrCat("devicenet fragmenter: fragment count ",
                                                      (next_ - 1) & 0x3F, " not acknowledged yet"));
  }
  awaiting_ack_ = explicit_;
  return fragments_[next_++];
}

absl::Status Fragmenter::AcceptAck(std::span<const uint8_t> ack_payload) {
  if (!explicit_) {
    return absl::FailedPreconditionError(
        "devicenet fragmenter: I/O fragments are not acknowledged");
  }
  DGW_ASSIGN_OR_RETURN(FragmentAck ack, DecodeFragmentAck(ack_payload));
  if (!awaiting_ack_) {
    return absl::FailedPreconditionError(
        absl::StrCat("devicenet fragmenter: ack count ", ack.count, " while none is awaited"));
  }
  const unsigned expected = (next_ - 1) & 0x3F;
  if (ack.count != expected) {
    return absl::FailedPreconditionError(
        absl::StrCat("devicenet fragmenter: ack count ", ack.count, ", expected ", expected));
  }
  if (ack.status != kAckSuccess) {
    return absl::FailedPreconditionError(absl::StrCat(
        "devicenet fragmenter: fragment count ", ack.count, " acknowledged with status ",
        Hex2(ack.status), ack.status == kAckTooMuchData ? " (too much data)" : ""));
  }
  awaiting_ack_ = false;
  return absl::OkStatus();
}

void Reassembler::Reset() {
  active_ = false;
  next_count_ = 0;
  explicit_header_.reset();
  buffer_.clear();
}

absl::StatusOr<std::optional<std::vector<uint8_t>>> Reassembler::Feed(uint8_t protocol,
                                                                      std::span<const uint8_t> data,
                                                                      const char* where) {
  const FragmentType type = FragmentTypeOf(protocol);
  const unsigned count = FragmentCountOf(protocol);
  const std::string frag = absl::StrCat(FragmentTypeName(type), " fragment count ", count);
  if (type == FragmentType::kAck) {
    Reset();
    return Invalid(where, absl::StrCat(frag, " in the data stream; message dropped"));
  }
  if (type == FragmentType::kFirst) {
    if (count != 0) {
      Reset();
      return Invalid(where, absl::StrCat(frag, ", a first fragment has count 0"));
    }
    const bool interrupted = active_;
    const unsigned lost_at = next_count_;
    buffer_.assign(data.begin(), data.end());
    active_ = true;
    next_count_ = 1;
    if (buffer_.size() > max_size_) {
      Reset();
      return Invalid(where, absl::StrCat("oversize: ", data.size(), " bytes exceed ", max_size_,
                                         " at fragment count 0"));
    }
    if (interrupted) {
      return Invalid(where, absl::StrCat("missing fragments: message interrupted before count ",
                                         lost_at, " by a new first fragment (restarted)"));
    }
    return std::optional<std::vector<uint8_t>>();
  }
  if (!active_) {
    return Invalid(where, absl::StrCat(frag, " without a first fragment"));
  }
  if (count != next_count_) {
    const unsigned expected = next_count_;
    Reset();
    if (count == ((expected + 63) & 0x3F)) {
      return Invalid(where, absl::StrCat("duplicate ", frag, "; message dropped"));
    }
    return Invalid(where, absl::StrCat(frag, " out of order, expected count ", expected,
                                       " (missing or reordered); message dropped"));
  }
  if (buffer_.size() + data.size() > max_size_) {
    const size_t total = buffer_.size() + data.size();
    Reset();
    return Invalid(where, absl::StrCat("oversize: ", total, " bytes exceed ", max_size_,
                                       " at fragment count ", count, "; message dropped"));
  }
  buffer_.insert(buffer_.end(), data.begin(), data.end());
  next_count_ = static_cast<uint8_t>((count + 1) & 0x3F);
  if (type == FragmentType::kLast) {
    std::vector<uint8_t> message = std::move(buffer_);
    Reset();
    return std::optional<std::vector<uint8_t>>(std::move(message));
  }
  return std::optional<std::vector<uint8_t>>();
}

absl::StatusOr<std::optional<std::vector<uint8_t>>> Reassembler::FeedIo(
    std::span<const uint8_t> payload) {
  if (payload.empty()) {
    Reset();
    return Invalid("io fragment", "empty frame, no fragment byte; message dropped");
  }
  return Feed(payload[0], payload.subspan(1), "io fragment");
}

absl::StatusOr<std::optional<std::vector<uint8_t>>> Reassembler::FeedExplicit(
    std::span<const uint8_t> payload) {
  if (payload.size() < 2) {
    Reset();
    return Invalid("explicit fragment",
                   absl::StrCat(payload.size(), " bytes, header and fragment byte need 2"));
  }
  if ((payload[0] & 0x80) == 0) {
    Reset();
    return Invalid("explicit fragment", "Frag bit clear; not a fragment");
  }
  const uint8_t header = static_cast<uint8_t>(payload[0] & 0x7F);
  const bool first = FragmentTypeOf(payload[1]) == FragmentType::kFirst;
  if (!first && explicit_header_ && *explicit_header_ != header) {
    const uint8_t had = *explicit_header_;
    Reset();
    return Invalid("explicit fragment",
                   absl::StrCat("header ", Hex2(header), " differs from the first fragment's ",
                                Hex2(had), " at count ", FragmentCountOf(payload[1])));
  }
  auto r = Feed(payload[1], payload.subspan(2), "explicit fragment");
  if (first && active_) explicit_header_ = header;
  if (!r.ok() || !r->has_value()) return r;
  std::vector<uint8_t> message;
  message.reserve((*r)->size() + 1);
  message.push_back(header);
  message.insert(message.end(), (*r)->begin(), (*r)->end());
  return std::optional<std::vector<uint8_t>>(std::move(message));
}

// ---------------------------------------------------------------------------------------------
// Duplicate MAC ID check (§5.7).

absl::StatusOr<std::vector<uint8_t>> EncodeDuplicateMacCheck(const DuplicateMacCheck& m) {
  if (m.port > 0x7F) {
    return Invalid("duplicate_mac_check.port", absl::StrCat(m.port, " exceeds 127"));
  }
  return std::vector<uint8_t>{static_cast<uint8_t>((m.response ? 0x80 : 0) | m.port),
                              static_cast<uint8_t>(m.vendor_id),
                              static_cast<uint8_t>(m.vendor_id >> 8),
                              static_cast<uint8_t>(m.serial_number),
                              static_cast<uint8_t>(m.serial_number >> 8),
                              static_cast<uint8_t>(m.serial_number >> 16),
                              static_cast<uint8_t>(m.serial_number >> 24)};
}

absl::StatusOr<DuplicateMacCheck> DecodeDuplicateMacCheck(std::span<const uint8_t> b) {
  if (b.size() != kDuplicateMacCheckSize) {
    return Invalid("duplicate_mac_check",
                   absl::StrCat(b.size(), " bytes, needs ", kDuplicateMacCheckSize));
  }
  return DuplicateMacCheck{
      (b[0] & 0x80) != 0, static_cast<uint8_t>(b[0] & 0x7F),
      static_cast<uint16_t>(b[1] | (b[2] << 8)),
      uint32_t{b[3]} | (uint32_t{b[4]} << 8) | (uint32_t{b[5]} << 16) | (uint32_t{b[6]} << 24)};
}

absl::StatusOr<Frame> DuplicateMacCheckFrame(uint8_t mac, const DuplicateMacCheck& message) {
  DGW_ASSIGN_OR_RETURN(
      uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup2, mac, kG2DuplicateMacCheck}));
  DGW_ASSIGN_OR_RETURN(auto bytes, EncodeDuplicateMacCheck(message));
  return MakeFrame(id, bytes);
}

// ---------------------------------------------------------------------------------------------
// I/O frames.

absl::StatusOr<std::vector<Frame>> EncodeIoMessage(uint16_t id, std::span<const uint8_t> message,
                                                   size_t connection_size) {
  if (message.size() != connection_size) {
    return Invalid("io message",
                   absl::StrCat(message.size(), " bytes, connection size ", connection_size));
  }
  if (connection_size <= kMaxFrameData) {
    DGW_ASSIGN_OR_RETURN(Frame f, MakeFrame(id, message));
    return std::vector<Frame>{f};
  }
  DGW_ASSIGN_OR_RETURN(Fragmenter fr, Fragmenter::ForIo(message));
  return FramesOf(id, fr.fragments());
}

absl::StatusOr<std::vector<Frame>> EncodePollCommand(uint8_t slave_mac,
                                                     std::span<const uint8_t> image,
                                                     size_t connection_size) {
  DGW_ASSIGN_OR_RETURN(
      uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup2, slave_mac, kG2PollCommand}));
  return EncodeIoMessage(id, image, connection_size);
}

absl::StatusOr<std::vector<Frame>> EncodePollResponse(uint8_t slave_mac,
                                                      std::span<const uint8_t> image,
                                                      size_t connection_size) {
  DGW_ASSIGN_OR_RETURN(
      uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup1, slave_mac, kG1PollResponse}));
  return EncodeIoMessage(id, image, connection_size);
}

absl::StatusOr<std::vector<Frame>> EncodeChangeOfState(uint8_t slave_mac,
                                                       std::span<const uint8_t> image,
                                                       size_t connection_size) {
  DGW_ASSIGN_OR_RETURN(uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup1, slave_mac,
                                                                kG1ChangeOfState}));
  return EncodeIoMessage(id, image, connection_size);
}

absl::StatusOr<Frame> CosAcknowledgeFrame(uint8_t slave_mac) {
  DGW_ASSIGN_OR_RETURN(uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup2, slave_mac,
                                                                kG2CosAcknowledge}));
  return MakeFrame(id, {});
}

absl::StatusOr<Frame> SlaveCosAcknowledgeFrame(uint8_t slave_mac) {
  DGW_ASSIGN_OR_RETURN(
      uint16_t id, EncodeIdentifier(Identifier{MessageGroup::kGroup1, slave_mac, kG1PollResponse}));
  return MakeFrame(id, {});
}

absl::StatusOr<std::optional<std::vector<uint8_t>>> IoReceiver::Feed(
    std::span<const uint8_t> payload) {
  if (!fragmented()) {
    if (payload.size() != connection_size_) {
      return Invalid("io message",
                     absl::StrCat(payload.size(), " bytes, connection size ", connection_size_));
    }
    return std::optional<std::vector<uint8_t>>(
        std::vector<uint8_t>(payload.begin(), payload.end()));
  }
  DGW_ASSIGN_OR_RETURN(auto message, reassembler_.FeedIo(payload));
  if (message && message->size() != connection_size_) {
    return Invalid(
        "io message",
        absl::StrCat(message->size(), " bytes reassembled, connection size ", connection_size_));
  }
  return message;
}

}  // namespace drivegw::linmot::devicenet
