// LinUDP V2 telegram codec: little-endian block packing per linmot-linudp.md §2-§5.
#include "adapters/linmot/linudp/codec.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::linmot::linudp {
namespace {

// linmot-linudp.md 2.1: every multi-byte field is little-endian.
void PutU16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v));
  out.push_back(static_cast<uint8_t>(v >> 8));
}
void PutU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
uint16_t GetU16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t GetU32(const uint8_t* p) {
  return uint32_t{p[0]} | (uint32_t{p[1]} << 8) | (uint32_t{p[2]} << 16) | (uint32_t{p[3]} << 24);
}

struct Block {
  uint32_t bit;
  size_t size;
  const char* name;
};

// linmot-linudp.md §3.1, ascending bit order (2.3).
constexpr Block kRequestBlocks[] = {
    {kReqControlWord, kControlWordSize, "control_word"},
    {kReqMotionCommand, kMotionCommandSize, "motion_command"},
    {kReqRtc, kRtcRequestSize, "rtc"},
};

// linmot-linudp.md §4.2, ascending bit order (2.3).
constexpr Block kResponseBlocks[] = {
    {kRespStatusWord, kStatusWordSize, "status_word"},
    {kRespStateVar, kStateVarSize, "state_var"},
    {kRespActualPosition, kActualPositionSize, "actual_position"},
    {kRespDemandPosition, kDemandPositionSize, "demand_position"},
    {kRespCurrent, kCurrentSize, "current"},
    {kRespWarnWord, kWarnWordSize, "warn_word"},
    {kRespErrorCode, kErrorCodeSize, "error_code"},
    {kRespMonitoring, kMonitoringSize, "monitoring"},
    {kRespRtc, kRtcReplySize, "rtc"},
};

template <size_t N>
size_t LayoutSize(const Block (&blocks)[N], uint32_t definition) {
  size_t size = kHeaderSize;
  for (const Block& b : blocks) {
    if (definition & b.bit) size += b.size;
  }
  return size;
}

std::string Hex32(uint32_t v) { return absl::StrFormat("0x%08X", v); }

// Bit of every block present in `reply`.
uint32_t PresentReplyBits(const Reply& r) {
  uint32_t bits = 0;
  if (r.status_word) bits |= kRespStatusWord;
  if (r.state_var) bits |= kRespStateVar;
  if (r.actual_position) bits |= kRespActualPosition;
  if (r.demand_position) bits |= kRespDemandPosition;
  if (r.current) bits |= kRespCurrent;
  if (r.warn_word) bits |= kRespWarnWord;
  if (r.error_code) bits |= kRespErrorCode;
  if (r.monitoring) bits |= kRespMonitoring;
  if (r.rtc) bits |= kRespRtc;
  return bits;
}

}  // namespace

size_t RequestLayoutSize(uint32_t request_definition) {
  return LayoutSize(kRequestBlocks, request_definition);
}

size_t ResponseLayoutSize(uint32_t response_definition) {
  return LayoutSize(kResponseBlocks, response_definition);
}

std::optional<RtcCommand> RtcCommandFromId(uint8_t id) {
  const auto command = static_cast<RtcCommand>(id);
  // RtcCommandName knows exactly the IDs of §5.3.
  if (std::strcmp(RtcCommandName(command), "unknown") == 0) return std::nullopt;
  return command;
}

const char* RtcCommandName(RtcCommand command) {
  // Names as in the manual's command list (LinUDP V2 manual pages 12-13).
  switch (command) {
    case RtcCommand::kNoOperation:
      return "No Operation";
    case RtcCommand::kReadRomValueByUpid:
      return "Read ROM Value of Parameter by UPID";
    case RtcCommand::kReadRamValueByUpid:
      return "Read RAM Value of Parameter by UPID";
    case RtcCommand::kWriteRomValueByUpid:
      return "Write ROM Value of Parameter by UPID";
    case RtcCommand::kWriteRamValueByUpid:
      return "Write RAM Value of Parameter by UPID";
    case RtcCommand::kWriteRamAndRomValueByUpid:
      return "Write RAM and ROM Value of Parameter by UPID";
    case RtcCommand::kGetMinimalValueByUpid:
      return "Get minimal Value of Parameter by UPID";
    case RtcCommand::kGetMaximalValueByUpid:
      return "Get maximal Value of Parameter by UPID";
    case RtcCommand::kGetDefaultValueByUpid:
      return "Get default Value of Parameter by UPID";
    case RtcCommand::kStartGettingUpidList:
      return "Start Getting UPID List";
    case RtcCommand::kGetNextUpidListItem:
      return "Get next UPID List item";
    case RtcCommand::kStartGettingModifiedUpidList:
      return "Start Getting Modified UPID List";
    case RtcCommand::kGetNextModifiedUpidListItem:
      return "Get next Modified UPID List item";
    case RtcCommand::kRestartDrive:
      return "Restart Drive";
    case RtcCommand::kSetRomDefaultsOsSw:
      return "Set parameter ROM values to default (OS SW)";
    case RtcCommand::kSetRomDefaultsMcSw:
      return "Set parameter ROM values to default (MC SW)";
    case RtcCommand::kSetRomDefaultsInterfaceSw:
      return "Set parameter ROM values to default (Interface SW)";
    case RtcCommand::kSetRomDefaultsApplicationSw:
      return "Set parameter ROM values to default (Application SW)";
    case RtcCommand::kStopMcAndApplicationSw:
      return "Stop MC and Application Software (for Flash access)";
    case RtcCommand::kStartMcAndApplicationSw:
      return "Start MC and Application Software";
    case RtcCommand::kSaveAllCurvesToFlash:
      return "Save all Curves from RAM to Flash";
    case RtcCommand::kDeleteAllCurves:
      return "Delete all Curves (RAM)";
    case RtcCommand::kStartAddingCurve:
      return "Start Adding Curve (RAM)";
    case RtcCommand::kAddCurveInfoBlock:
      return "Add Curve Info Block (RAM)";
    case RtcCommand::kAddCurveData:
      return "Add Curve Data (RAM)";
    case RtcCommand::kStartModifyingCurve:
      return "Start Modifying Curve (RAM)";
    case RtcCommand::kModifyCurveInfoBlock:
      return "Modify Curve Info Block (RAM)";
    case RtcCommand::kModifyCurveData:
      return "Modify Curve Data (RAM)";
    case RtcCommand::kStartGettingCurve:
      return "Start Getting Curve (RAM)";
    case RtcCommand::kGetCurveInfoBlock:
      return "Get Curve Info Block (RAM)";
    case RtcCommand::kGetCurveData:
      return "Get Curve Data (RAM)";
    case RtcCommand::kGetErrorLogEntryCounter:
      return "Get Error Log Entry Counter";
    case RtcCommand::kGetErrorLogEntryErrorCode:
      return "Get Error Log Entry Error Code";
    case RtcCommand::kGetErrorLogEntryTimeLow:
      return "Get Error Log Entry Time low";
    case RtcCommand::kGetErrorLogEntryTimeHigh:
      return "Get Error Log Entry Time high";
    case RtcCommand::kGetErrorCodeTextStringlet:
      return "Get Error Code Text Stringlet";
    case RtcCommand::kCommandTableSaveToFlash:
      return "Command Table: Save to Flash";
    case RtcCommand::kCommandTableDeleteAllEntries:
      return "Command Table: Delete All Entries (RAM)";
    case RtcCommand::kCommandTableDeleteEntry:
      return "Command Table: Delete Entry";
    case RtcCommand::kCommandTableWriteEntry:
      return "Command Table: Write Entry";
    case RtcCommand::kCommandTableWriteEntryData:
      return "Command Table: Write Entry Data";
    case RtcCommand::kCommandTableGetEntry:
      return "Command Table: Get Entry";
    case RtcCommand::kCommandTableGetEntryData:
      return "Command Table: Get Entry Data";
    case RtcCommand::kGetPresenceListEntries0To31:
      return "Get Presence List of Entries 0..31 from RAM";
    case RtcCommand::kGetPresenceListEntries32To63:
      return "Get Presence List of Entries 32..63 from RAM";
    case RtcCommand::kGetPresenceListEntries64To95:
      return "Get Presence List of Entries 64..95 from RAM";
    case RtcCommand::kGetPresenceListEntries96To127:
      return "Get Presence List of Entries 96..127 from RAM";
    case RtcCommand::kGetPresenceListEntries128To159:
      return "Get Presence List of Entries 128..159 from RAM";
    case RtcCommand::kGetPresenceListEntries160To191:
      return "Get Presence List of Entries 160..191 from RAM";
    case RtcCommand::kGetPresenceListEntries192To223:
      return "Get Presence List of Entries 192..223 from RAM";
    case RtcCommand::kGetPresenceListEntries224To255:
      return "Get Presence List of Entries 224..255 from RAM";
  }
  return "unknown";
}

const char* RtcStatusText(uint8_t status) {
  // linmot-linudp.md §5.2 (manual "Parameter Status" table).
  switch (status) {
    case kRtcStatusDone:
      return "OK, done";
    case kRtcStatusCommandRunning:
      return "Command Running / Busy";
    case kRtcStatusBlockAccepted:
      return "Block not finished";
    case kRtcStatusBusy:
      return "Busy";
    case kRtcStatusUpidError:
      return "UPID Error";
    case kRtcStatusParameterTypeError:
      return "Parameter Type Error";
    case kRtcStatusRangeError:
      return "Range Error";
    case kRtcStatusAddressUsageError:
      return "Address Usage Error";
    case kRtcStatusNoUpidListStarted:
      return "Get next UPID List item without prior Start Getting UPID List";
    case kRtcStatusEndOfUpidList:
      return "End of UPID List reached";
    case kRtcStatusOddAddress:
      return "Odd Address";
    case kRtcStatusSizeError:
      return "Size Error (Curve Service)";
    case kRtcStatusCurveDefinedOrMissing:
      return "Curve already defined / Curve not present";
    default:
      return "unknown status";
  }
}

uint32_t RequestDefinitionOf(const Request& request) {
  uint32_t def = 0;
  if (request.control_word) def |= kReqControlWord;
  if (request.motion_command) def |= kReqMotionCommand;
  if (request.rtc) def |= kReqRtc;
  return def;
}

size_t EncodeRequestInto(const Request& request, std::span<uint8_t, kMaxRequestSize> out) {
  uint8_t* p = out.data();
  auto u16 = [&p](uint16_t v) {
    *p++ = static_cast<uint8_t>(v);
    *p++ = static_cast<uint8_t>(v >> 8);
  };
  auto u32 = [&u16](uint32_t v) {
    u16(static_cast<uint16_t>(v));
    u16(static_cast<uint16_t>(v >> 16));
  };
  u32(RequestDefinitionOf(request));
  // linmot-linudp.md A-03: the gateway never sets response bits 9-31.
  u32(request.response_definition & kRespDefinedMask);
  if (request.control_word) u16(*request.control_word);
  // always the complete 32-byte MC block.
  if (request.motion_command) {
    std::copy(request.motion_command->begin(), request.motion_command->end(), p);
    p += kMotionCommandSize;
  }
  if (request.rtc) {
    // §3.5: byte 0 bits 7-4 reserved (0), byte 1 command ID, then words 2-4.
    *p++ = request.rtc->count & 0x0F;
    *p++ = request.rtc->command_id;
    u16(request.rtc->word2);
    u16(request.rtc->word3);
    u16(request.rtc->word4);
  }
  return static_cast<size_t>(p - out.data());
}

std::vector<uint8_t> EncodeRequest(const Request& request) {
  std::array<uint8_t, kMaxRequestSize> buffer;
  const size_t n = EncodeRequestInto(request, buffer);
  return std::vector<uint8_t>(buffer.begin(), buffer.begin() + n);
}

absl::StatusOr<Request> DecodeRequest(std::span<const uint8_t> bytes) {
  // shorter than the header -> dropped (the caller counts it as malformed).
  if (bytes.size() < kHeaderSize) {
    return absl::InvalidArgumentError(absl::StrCat("linudp request: ", bytes.size(),
                                                   " bytes, shorter than the ", kHeaderSize,
                                                   "-byte header"));
  }
  const uint8_t* p = bytes.data();
  // reserved bits are ignored.
  const uint32_t req_def = GetU32(p) & kReqDefinedMask;
  const uint32_t resp_def = GetU32(p + 4) & kRespDefinedMask;
  const size_t required = RequestLayoutSize(req_def);
  if (bytes.size() < required) {
    return absl::InvalidArgumentError(absl::StrCat("linudp request: request definition ",
                                                   Hex32(req_def), " needs ", required,
                                                   " bytes, datagram has ", bytes.size()));
  }
  Request request;
  request.response_definition = resp_def;
  p += kHeaderSize;
  if (req_def & kReqControlWord) {
    request.control_word = GetU16(p);
    p += kControlWordSize;
  }
  if (req_def & kReqMotionCommand) {
    std::array<uint8_t, kMotionCommandSize> mc;
    std::memcpy(mc.data(), p, mc.size());
    request.motion_command = mc;
    p += kMotionCommandSize;
  }
  if (req_def & kReqRtc) {
    RtcRequest rtc;
    rtc.count = p[0] & 0x0F;  // §3.5: bits 7-4 reserved
    rtc.command_id = p[1];
    rtc.word2 = GetU16(p + 2);
    rtc.word3 = GetU16(p + 4);
    rtc.word4 = GetU16(p + 6);
    request.rtc = rtc;
  }
  // bytes beyond the layout are ignored.
  return request;
}

std::vector<uint8_t> EncodeReply(const Reply& reply, size_t min_payload) {
  const uint32_t resp_def = reply.response_definition | PresentReplyBits(reply);
  std::vector<uint8_t> out;
  out.reserve(std::max(ResponseLayoutSize(resp_def), min_payload));
  PutU32(out, reply.request_definition);
  PutU32(out, resp_def);
  // §2.3: blocks in ascending bit order; a flagged block without a value reads as zeros.
  if (resp_def & kRespStatusWord) PutU16(out, reply.status_word.value_or(0));
  if (resp_def & kRespStateVar) PutU16(out, reply.state_var.value_or(0));
  if (resp_def & kRespActualPosition) {
    PutU32(out, static_cast<uint32_t>(reply.actual_position.value_or(0)));
  }
  if (resp_def & kRespDemandPosition) {
    PutU32(out, static_cast<uint32_t>(reply.demand_position.value_or(0)));
  }
  if (resp_def & kRespCurrent) PutU16(out, static_cast<uint16_t>(reply.current.value_or(0)));
  if (resp_def & kRespWarnWord) PutU16(out, reply.warn_word.value_or(0));
  if (resp_def & kRespErrorCode) PutU16(out, reply.error_code.value_or(0));
  if (resp_def & kRespMonitoring) {
    const std::array<int32_t, 4> channels = reply.monitoring.value_or(std::array<int32_t, 4>{});
    for (int32_t c : channels) PutU32(out, static_cast<uint32_t>(c));
  }
  if (resp_def & kRespRtc) {
    const RtcReply rtc = reply.rtc.value_or(RtcReply{});
    out.push_back(rtc.count & 0x0F);  // §4.4: bits 7-4 reserved
    out.push_back(rtc.status);
    PutU16(out, rtc.word2);
    PutU16(out, rtc.word3);
    PutU16(out, rtc.word4);
  }
  // zero fill to the minimum payload.
  if (out.size() < min_payload) out.resize(min_payload, 0);
  return out;
}

absl::StatusOr<Reply> DecodeReply(std::span<const uint8_t> bytes) {
  if (bytes.size() < kHeaderSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "linudp reply: ", bytes.size(), " bytes, shorter than the ", kHeaderSize, "-byte header"));
  }
  Reply reply;
  reply.request_definition = GetU32(bytes.data());
  reply.response_definition = GetU32(bytes.data() + 4);
  // the layout comes from bytes 4-7 only; A-06: shorter replies are rejected whole, so
  // name the first block that does not fit.
  const uint32_t layout = reply.response_definition & kRespDefinedMask;
  const size_t required = ResponseLayoutSize(layout);
  if (bytes.size() < required) {
    size_t offset = kHeaderSize;
    const Block* cut = nullptr;
    for (const Block& b : kResponseBlocks) {
      if (!(layout & b.bit)) continue;
      if (offset + b.size > bytes.size()) {
        cut = &b;
        break;
      }
      offset += b.size;
    }
    return absl::InvalidArgumentError(
        absl::StrCat("linudp reply.", cut != nullptr ? cut->name : "?", ": block at offset ",
                     offset, " needs ", cut != nullptr ? cut->size : 0,
                     " bytes; response definition ", Hex32(reply.response_definition), " needs ",
                     required, " bytes, datagram has ", bytes.size()));
  }
  const uint8_t* p = bytes.data() + kHeaderSize;
  if (layout & kRespStatusWord) {
    reply.status_word = GetU16(p);
    p += kStatusWordSize;
  }
  if (layout & kRespStateVar) {
    reply.state_var = GetU16(p);
    p += kStateVarSize;
  }
  if (layout & kRespActualPosition) {
    reply.actual_position = static_cast<int32_t>(GetU32(p));
    p += kActualPositionSize;
  }
  if (layout & kRespDemandPosition) {
    reply.demand_position = static_cast<int32_t>(GetU32(p));
    p += kDemandPositionSize;
  }
  if (layout & kRespCurrent) {
    reply.current = static_cast<int16_t>(GetU16(p));
    p += kCurrentSize;
  }
  if (layout & kRespWarnWord) {
    reply.warn_word = GetU16(p);
    p += kWarnWordSize;
  }
  if (layout & kRespErrorCode) {
    reply.error_code = GetU16(p);
    p += kErrorCodeSize;
  }
  if (layout & kRespMonitoring) {
    std::array<int32_t, 4> channels;
    for (size_t i = 0; i < channels.size(); ++i) {
      channels[i] = static_cast<int32_t>(GetU32(p + 4 * i));
    }
    reply.monitoring = channels;
    p += kMonitoringSize;
  }
  if (layout & kRespRtc) {
    RtcReply rtc;
    rtc.count = p[0] & 0x0F;  // §4.4: bits 7-4 reserved
    rtc.status = p[1];
    rtc.word2 = GetU16(p + 2);
    rtc.word3 = GetU16(p + 4);
    rtc.word4 = GetU16(p + 6);
    reply.rtc = rtc;
  }
  return reply;
}

}  // namespace drivegw::linmot::linudp
