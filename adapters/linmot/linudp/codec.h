// LinUDP V2 telegram codec: UDP payload bytes <-> Request/Reply structs, pure (no I/O, no clock).
// Source of truth: shared/protocols/linmot-linudp.md (§2-§5 framing, §8 A-nn, §9 telegrams).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"

namespace drivegw::linmot::linudp {

// linmot-linudp.md 1.2, 1.3: default UDP ports (both are configuration values, A-01).
inline constexpr uint16_t kDrivePort = 49360;   // 0xC0D0
inline constexpr uint16_t kMasterPort = 41136;  // 0xA0B0

// linmot-linudp.md 2.2: request definition (bytes 0-3) + response definition (bytes 4-7).
inline constexpr size_t kHeaderSize = 8;

// Request definition bits (linmot-linudp.md §3.1); blocks follow in this order.
inline constexpr uint32_t kReqControlWord = 0x00000001;    // 2 bytes
inline constexpr uint32_t kReqMotionCommand = 0x00000002;  // 32 bytes, MC interface
inline constexpr uint32_t kReqRtc = 0x00000004;            // 8 bytes, realtime configuration
inline constexpr uint32_t kReqDefinedMask = 0x00000007;    // bits 3-31 reserved

inline constexpr size_t kControlWordSize = 2;
inline constexpr size_t kMotionCommandSize = 32;
inline constexpr size_t kRtcRequestSize = 8;

// Response definition bits (linmot-linudp.md §4.2); blocks follow in this order.
inline constexpr uint32_t kRespStatusWord = 0x001;      // 2 bytes, UInt16
inline constexpr uint32_t kRespStateVar = 0x002;        // 2 bytes, UInt16 (main << 8 | sub)
inline constexpr uint32_t kRespActualPosition = 0x004;  // 4 bytes, SInt32, 0.1 µm
inline constexpr uint32_t kRespDemandPosition = 0x008;  // 4 bytes, SInt32, 0.1 µm
inline constexpr uint32_t kRespCurrent = 0x010;         // 2 bytes, SInt16, 1 mA (set current)
inline constexpr uint32_t kRespWarnWord = 0x020;        // 2 bytes, UInt16
inline constexpr uint32_t kRespErrorCode = 0x040;       // 2 bytes, UInt16
inline constexpr uint32_t kRespMonitoring = 0x080;      // 16 bytes, 4 x 32-bit, channel 1 first
inline constexpr uint32_t kRespRtc = 0x100;             // 8 bytes, RTC reply
inline constexpr uint32_t kRespStandard = 0x07F;        // §9 telegram 1: status poll blocks
inline constexpr uint32_t kRespDefinedMask = 0x1FF;     // bits 9-31 reserved

inline constexpr size_t kStatusWordSize = 2;
inline constexpr size_t kStateVarSize = 2;
inline constexpr size_t kActualPositionSize = 4;
inline constexpr size_t kDemandPositionSize = 4;
inline constexpr size_t kCurrentSize = 2;
inline constexpr size_t kWarnWordSize = 2;
inline constexpr size_t kErrorCodeSize = 2;
inline constexpr size_t kMonitoringSize = 16;
inline constexpr size_t kRtcReplySize = 8;

// linmot-linudp.md A-06: the simulated drive zero-fills replies to 14 bytes (observed hardware);
// a test switch fills to 64 (manual wording, 4.5.1).
inline constexpr size_t kMinReplyPayload = 14;
inline constexpr size_t kManualReplyPayload = 64;

// Header + blocks flagged in a request definition; reserved bits count nothing.
size_t RequestLayoutSize(uint32_t request_definition);
// Header + blocks flagged in a response definition; reserved bits count nothing.
size_t ResponseLayoutSize(uint32_t response_definition);

// RTC command IDs (linmot-linudp.md §5.3, manual pages 12-13). Request byte 1 of the RTC block.
enum class RtcCommand : uint8_t {
  kNoOperation = 0x00,
  // Parameter access
  kReadRomValueByUpid = 0x10,
  kReadRamValueByUpid = 0x11,
  kWriteRomValueByUpid = 0x12,
  kWriteRamValueByUpid = 0x13,
  kWriteRamAndRomValueByUpid = 0x14,
  kGetMinimalValueByUpid = 0x15,
  kGetMaximalValueByUpid = 0x16,
  kGetDefaultValueByUpid = 0x17,
  // Parameter (UPID) list
  kStartGettingUpidList = 0x20,
  kGetNextUpidListItem = 0x21,
  kStartGettingModifiedUpidList = 0x22,
  kGetNextModifiedUpidListItem = 0x23,
  // Stop / start / default
  kRestartDrive = 0x30,
  kSetRomDefaultsOsSw = 0x31,
  kSetRomDefaultsMcSw = 0x32,
  kSetRomDefaultsInterfaceSw = 0x33,
  kSetRomDefaultsApplicationSw = 0x34,
  kStopMcAndApplicationSw = 0x35,
  kStartMcAndApplicationSw = 0x36,
  // Curve service
  kSaveAllCurvesToFlash = 0x40,
  kDeleteAllCurves = 0x41,
  kStartAddingCurve = 0x50,
  kAddCurveInfoBlock = 0x51,
  kAddCurveData = 0x52,
  kStartModifyingCurve = 0x53,
  kModifyCurveInfoBlock = 0x54,
  kModifyCurveData = 0x55,
  kStartGettingCurve = 0x60,
  kGetCurveInfoBlock = 0x61,
  kGetCurveData = 0x62,
  // Error log
  kGetErrorLogEntryCounter = 0x70,
  kGetErrorLogEntryErrorCode = 0x71,
  kGetErrorLogEntryTimeLow = 0x72,
  kGetErrorLogEntryTimeHigh = 0x73,
  kGetErrorCodeTextStringlet = 0x74,
  // Command table (linmot-linudp.md §5.3: save to flash is 0x80, the manual's "75h" is a typo)
  kCommandTableSaveToFlash = 0x80,
  kCommandTableDeleteAllEntries = 0x81,
  kCommandTableDeleteEntry = 0x82,
  kCommandTableWriteEntry = 0x83,
  kCommandTableWriteEntryData = 0x84,
  kCommandTableGetEntry = 0x85,
  kCommandTableGetEntryData = 0x86,
  kGetPresenceListEntries0To31 = 0x87,
  kGetPresenceListEntries32To63 = 0x88,
  kGetPresenceListEntries64To95 = 0x89,
  kGetPresenceListEntries96To127 = 0x8A,
  kGetPresenceListEntries128To159 = 0x8B,
  kGetPresenceListEntries160To191 = 0x8C,
  kGetPresenceListEntries192To223 = 0x8D,
  kGetPresenceListEntries224To255 = 0x8E,
};

// The command for a wire ID, or nullopt for an ID §5.3 does not list (A-14: drive answers 0xC0).
std::optional<RtcCommand> RtcCommandFromId(uint8_t id);
// Manual name of a command ("Read RAM Value of Parameter by UPID"); "unknown" for other values.
const char* RtcCommandName(RtcCommand command);

// RTC parameter status, reply byte 1 (linmot-linudp.md §5.2).
inline constexpr uint8_t kRtcStatusDone = 0x00;            // OK, done
inline constexpr uint8_t kRtcStatusCommandRunning = 0x02;  // command running / busy
inline constexpr uint8_t kRtcStatusBlockAccepted = 0x04;   // block not finished: send the next
inline constexpr uint8_t kRtcStatusBusy = 0x05;            // busy
inline constexpr uint8_t kRtcStatusUpidError = 0xC0;
inline constexpr uint8_t kRtcStatusParameterTypeError = 0xC1;
inline constexpr uint8_t kRtcStatusRangeError = 0xC2;
inline constexpr uint8_t kRtcStatusAddressUsageError = 0xC3;
inline constexpr uint8_t kRtcStatusNoUpidListStarted = 0xC5;  // 0x21 without a prior 0x20
inline constexpr uint8_t kRtcStatusEndOfUpidList = 0xC6;
inline constexpr uint8_t kRtcStatusOddAddress = 0xD0;
inline constexpr uint8_t kRtcStatusSizeError = 0xD1;              // curve service
inline constexpr uint8_t kRtcStatusCurveDefinedOrMissing = 0xD4;  // curve service

// linmot-linudp.md 5.1.3, A-09: busy = resend the identical block; error = 0xC0 and above.
inline bool IsRtcBusy(uint8_t status) {
  return status == kRtcStatusCommandRunning || status == kRtcStatusBusy;
}
inline bool IsRtcError(uint8_t status) { return status >= 0xC0; }
// Manual text of a status ("Range Error"); "unknown status" for codes §5.2 does not list.
const char* RtcStatusText(uint8_t status);

// RTC block, master -> drive (linmot-linudp.md §3.5). count uses bits 3-0 only (bits 7-4 are
// reserved: encoded as 0, masked on decode). Words are little-endian on the wire.
struct RtcRequest {
  uint8_t count = 0;
  uint8_t command_id = 0;  // RtcCommand value; raw so that unknown IDs can be sent and tested
  uint16_t word2 = 0;
  uint16_t word3 = 0;
  uint16_t word4 = 0;
  friend bool operator==(const RtcRequest&, const RtcRequest&) = default;
};

// One request telegram. The request definition is derived from which blocks are present.
struct Request {
  uint32_t response_definition = 0;  // kResp* bits the master wants back
  std::optional<uint16_t> control_word;
  std::optional<std::array<uint8_t, 32>> motion_command;  // MC block: header + 30 param bytes
  std::optional<RtcRequest> rtc;
  friend bool operator==(const Request&, const Request&) = default;
};

// RTC block, drive -> master (linmot-linudp.md §4.4).
struct RtcReply {
  uint8_t count = 0;   // echo of the last evaluated count, bits 3-0
  uint8_t status = 0;  // kRtcStatus*
  uint16_t word2 = 0;
  uint16_t word3 = 0;
  uint16_t word4 = 0;
  friend bool operator==(const RtcReply&, const RtcReply&) = default;
};

// One reply telegram. Definition fields hold bytes 0-3 and 4-7 as they are on the wire.
struct Reply {
  uint32_t request_definition = 0;
  uint32_t response_definition = 0;
  std::optional<uint16_t> status_word;
  std::optional<uint16_t> state_var;
  std::optional<int32_t> actual_position;  // 0.1 µm
  std::optional<int32_t> demand_position;  // 0.1 µm
  std::optional<int16_t> current;          // mA
  std::optional<uint16_t> warn_word;
  std::optional<uint16_t> error_code;
  std::optional<std::array<int32_t, 4>> monitoring;  // channels 1-4
  std::optional<RtcReply> rtc;
  friend bool operator==(const Reply&, const Reply&) = default;
};

// Request definition implied by the blocks present in `request`.
uint32_t RequestDefinitionOf(const Request& request);

// Gateway side. Writes the request definition derived from the present blocks, the response
// definition masked to bits 0-8, then complete blocks in bit order (A-04: MC 32, RTC 8).
// Does not force response bit 8 when an RTC block is present: that pairing is the session's
// job (A-05, docs/decisions/201-linudp-codec-boundaries.md).
std::vector<uint8_t> EncodeRequest(const Request& request);

// The same bytes into a caller's buffer, for the session's allocation-free cycle (issue 10,
// P2); returns the telegram length.
inline constexpr size_t kMaxRequestSize =
    kHeaderSize + kControlWordSize + kMotionCommandSize + kRtcRequestSize;
size_t EncodeRequestInto(const Request& request, std::span<uint8_t, kMaxRequestSize> out);

// Simulated-drive side. Masks reserved bits of both definitions. InvalidArgument when
// the datagram is shorter than the header or than header + flagged blocks, naming the
// required and actual lengths; bytes beyond the layout are ignored.
absl::StatusOr<Request> DecodeRequest(std::span<const uint8_t> bytes);

// Simulated-drive side. Writes both definition fields as given, OR-ed with the bit of every
// present block; then the blocks of bits 0-8 in bit order (a flagged block without a value is
// zero-filled); then zeros up to `min_payload` (A-06: 14 observed, 64 per the manual).
// The A-02 header rules (mask, force bit 8) are the simulated drive's policy, not the codec's.
std::vector<uint8_t> EncodeReply(const Reply& reply, size_t min_payload = kMinReplyPayload);

// Gateway side. Layout from bytes 4-7 only; bytes 0-3 are reported, never checked.
// Reserved response bits are kept in `response_definition` but carry no block. InvalidArgument
// when the reply is shorter than the layout needs, naming the first incomplete block and the
// lengths; trailing bytes (padding, A-06) are ignored.
absl::StatusOr<Reply> DecodeReply(std::span<const uint8_t> bytes);

}  // namespace drivegw::linmot::linudp
