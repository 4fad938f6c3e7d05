// LinMot MC command interface: header, the table of every command of linmot-mc.md §5, and the
// table-driven 32-byte block codec (bytes <-> raw wire values), plus typed builders. No I/O.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::linmot::mc {

// ---------------------------------------------------------------------------------------------
// Header (linmot-mc.md §4.2, MC22 L770-791): bits 15-8 master ID, 7-4 sub ID, 3-0 count.
// On the wire little-endian (D-01): byte 0 = (sub_id << 4) | count, byte 1 = master_id.
struct Header {
  uint8_t master_id = 0;
  uint8_t sub_id = 0;  // 0..15
  uint8_t count = 0;   // 0..15

  constexpr uint16_t raw() const {
    return static_cast<uint16_t>((master_id << 8) | ((sub_id & 0x0F) << 4) | (count & 0x0F));
  }
  static constexpr Header FromRaw(uint16_t raw) {
    return Header{static_cast<uint8_t>(raw >> 8), static_cast<uint8_t>((raw >> 4) & 0x0F),
                  static_cast<uint8_t>(raw & 0x0F)};
  }
  friend constexpr bool operator==(Header, Header) = default;
};

// Size of the MC interface block: header + 15 parameter words (D-02, linmot-linudp.md §3.4).
inline constexpr size_t kMcBlockSize = 32;
using McBlock = std::array<uint8_t, kMcBlockSize>;

// D-09: the gateway's count ring 1, 2, ..., 15, 1, ... seeded from the echo; never 0 (0 is only
// sent with Reset 00F0h, §4.3 rule 4). NextCount(0) = 1, NextCount(15) = 1; the echo's high
// nibble is ignored.
constexpr uint8_t NextCount(uint8_t echo) {
  const uint8_t e = echo & 0x0F;
  return e >= 15 ? 1 : static_cast<uint8_t>(e + 1);
}

// ---------------------------------------------------------------------------------------------
// Command catalogue (linmot-mc.md §5).

// Wire type of a parameter. Positions are SInt32 even where MC22 prints UInt32 (D-13).
enum class ParamType : uint8_t { kSInt16, kUInt16, kSInt32, kUInt32 };
const char* ParamTypeName(ParamType t);  // "SInt16", "UInt16", "SInt32", "UInt32"
constexpr uint8_t ParamTypeSize(ParamType t) {
  return (t == ParamType::kSInt16 || t == ParamType::kUInt16) ? 2 : 4;
}
constexpr int64_t ParamTypeMin(ParamType t) {
  switch (t) {
    case ParamType::kSInt16:
      return -32768;
    case ParamType::kSInt32:
      return -2147483648LL;
    default:
      return 0;
  }
}
constexpr int64_t ParamTypeMax(ParamType t) {
  switch (t) {
    case ParamType::kSInt16:
      return 32767;
    case ParamType::kUInt16:
      return 65535;
    case ParamType::kSInt32:
      return 2147483647LL;
    case ParamType::kUInt32:
      return 4294967295LL;
  }
  return 0;
}

struct ParamSpec {
  const char* name;  // snake_case of the manual's name: "target_position", "maximal_velocity"
  uint8_t offset;    // byte offset in the block, header = 0 (§4.1)
  ParamType type;
  const char* unit;  // "0.1 um", "1E-6 m/s", "1E-5 m/s^2", "1E-4 m/s^3", "1 mA", "" if none
};

// Products of the availability columns (MC22 L793-1126), in that order.
enum class Product : uint8_t { kC1100 = 0, kC1250 = 1, kE1200 = 2, kE1400 = 3 };
inline constexpr size_t kProductCount = 4;
const char* ProductName(Product p);  // "C1100", ...
enum class Availability : uint8_t {
  kNo,               // "." in §5
  kYes,              // "1"
  kForceControlKey,  // "F": only with the Force Control software key (MC22 L1126)
};

struct CommandSpec {
  uint8_t master_id;
  uint8_t sub_id;
  const char* name;                                      // the manual's name, e.g. "VAI Go To Pos"
  std::span<const ParamSpec> params;                     // in offset order; empty = header only
  std::array<Availability, kProductCount> availability;  // C1100, C1250, E1200, E1400
  // False for the four overview-only commands 064, 072, 218, 219 whose parameters the manual
  // never documents; they are coded header-only (docs/decisions/101-mc-codec-gaps.md).
  bool layout_documented = true;

  // Bytes used: 2 + the end of the last parameter.
  size_t size() const;
  // snake_case key for messages and APIs: "VAI Dec=Acc Go To Pos" -> "vai_dec_acc_go_to_pos".
  std::string key() const;
  bool AvailableOn(Product p, bool force_control_key = false) const;
  // Index of the parameter named `name`, or nullopt.
  std::optional<size_t> ParamIndex(std::string_view name) const;
};

// nullptr if the ID is not in §5 (-> error 0081h on a drive, D-20).
const CommandSpec* FindCommand(uint8_t master_id, uint8_t sub_id);
// Every command of §5, ordered by (master_id, sub_id).
std::span<const CommandSpec> AllCommands();

// A command ID (master, sub) without count.
struct CommandId {
  uint8_t master;
  uint8_t sub;
  constexpr Header WithCount(uint8_t count) const { return Header{master, sub, count}; }
  friend constexpr bool operator==(CommandId, CommandId) = default;
};

// Named IDs (§5). The spec of each is FindCommand(id.master, id.sub).
// §5.1 system
inline constexpr CommandId kNoOperation{0x00, 0x0};
inline constexpr CommandId kWriteInterfaceControlWord{0x00, 0x1};
inline constexpr CommandId kWriteLiveParameter{0x00, 0x2};
inline constexpr CommandId kWriteX4IntfOutputsWithMask{0x00, 0x3};
inline constexpr CommandId kSelectPositionControllerSet{0x00, 0x5};
inline constexpr CommandId kClearEventEvaluation{0x00, 0x8};
inline constexpr CommandId kMasterHoming{0x00, 0x9};
inline constexpr CommandId kResetIPositionController{0x00, 0xA};
inline constexpr CommandId kReset{0x00, 0xF};  // send with count 0 (§4.3 rule 4)
// §5.2 VAI
inline constexpr CommandId kVaiGoToPos{0x01, 0x0};
inline constexpr CommandId kVaiIncrementDemPos{0x01, 0x1};
inline constexpr CommandId kVaiIncrementTargetPos{0x01, 0x2};
inline constexpr CommandId kVaiGoToPosFromActPosAndActVel{0x01, 0x3};
inline constexpr CommandId kVaiGoToPosFromActPosDemVel0{0x01, 0x4};
inline constexpr CommandId kVaiIncrementActPos{0x01, 0x5};
inline constexpr CommandId kVaiIncrementActPosDemVel0{0x01, 0x6};
inline constexpr CommandId kVaiStop{0x01, 0x7};
inline constexpr CommandId kVaiGoToPosAfterActualCommand{0x01, 0x8};
inline constexpr CommandId kVaiGoToAnalogPos{0x01, 0x9};
inline constexpr CommandId kVaiGoToPosOnRisingTrigger{0x01, 0xA};
inline constexpr CommandId kVaiIncrementTargetPosOnRisingTrigger{0x01, 0xB};
inline constexpr CommandId kVaiGoToPosOnFallingTrigger{0x01, 0xC};
inline constexpr CommandId kVaiIncrementTargetPosOnFallingTrigger{0x01, 0xD};
inline constexpr CommandId kVaiChangeMotionParamsOnPositiveTransition{0x01, 0xE};
inline constexpr CommandId kVaiChangeMotionParamsOnNegativeTransition{0x01, 0xF};
// §5.3 Predef VAI (limits from 14BEh/14BFh/14C0h)
inline constexpr CommandId kPredefVaiGoToPos{0x02, 0x0};
inline constexpr CommandId kPredefVaiIncrementDemPos{0x02, 0x1};
inline constexpr CommandId kPredefVaiIncrementTargetPos{0x02, 0x2};
inline constexpr CommandId kPredefVaiStop{0x02, 0x7};  // deceleration from 1721h
inline constexpr CommandId kPredefVaiGoToPosAfterActualCommand{0x02, 0x8};
inline constexpr CommandId kPredefVaiInfinitePositive{0x02, 0xE};
inline constexpr CommandId kPredefVaiInfiniteNegative{0x02, 0xF};
// §5.4 streaming
inline constexpr CommandId kPStream{0x03, 0x0};
inline constexpr CommandId kPvStream{0x03, 0x1};
inline constexpr CommandId kPvaStream{0x03, 0x4};
inline constexpr CommandId kStopStreaming{0x03, 0xF};
// §5.5 time curves
inline constexpr CommandId kTimeCurveWithDefaultParameters{0x04, 0x0};
inline constexpr CommandId kTimeCurveWithDefaultParametersFromActPos{0x04, 0x1};
inline constexpr CommandId kTimeCurveToPosWithDefaultSpeed{0x04, 0x2};
inline constexpr CommandId kTimeCurveToPosWithAdjustableTime{0x04, 0x3};
inline constexpr CommandId kTimeCurveWithAdjustableOffsetTimeScaleAmplitudeScale{0x04, 0x4};
inline constexpr CommandId kTimeCurveWithAdjustableOffsetTimeAmplitudeScale{0x04, 0x5};
// §5.8 16-bit VAI (values scaled by 1455h-1458h, D-14)
inline constexpr CommandId kVai16BitGoToPos{0x09, 0x0};
inline constexpr CommandId kVai16BitIncrementDemPos{0x09, 0x1};
inline constexpr CommandId kVai16BitIncrementTargetPos{0x09, 0x2};
inline constexpr CommandId kVai16BitStop{0x09, 0x7};
inline constexpr CommandId kPredefVai16BitGoToPos{0x0A, 0x0};
inline constexpr CommandId kPredefVai16BitStop{0x0A, 0x7};
// §5.10 Dec=Acc
inline constexpr CommandId kVaiDecAccGoToPos{0x0C, 0x0};
inline constexpr CommandId kVaiDecAccInfinitePositive{0x0C, 0xE};
inline constexpr CommandId kVaiDecAccInfiniteNegative{0x0C, 0xF};
// §5.12, §5.13, §5.17
inline constexpr CommandId kSinVaGoToPos{0x0E, 0x0};
inline constexpr CommandId kSinVaGoToPosAfterActualCommand{0x0E, 0x8};
inline constexpr CommandId kBestehornVajGoToPos{0x0F, 0x0};
inline constexpr CommandId kBestehornVajGoToPosAfterActualCommand{0x0F, 0x8};
inline constexpr CommandId kVajiGoToPos{0x3A, 0x0};
inline constexpr CommandId kPredefVajiGoToPos{0x3B, 0x0};
// §5.14 command table
inline constexpr CommandId kStartCommandTableCommand{0x20, 0x0};

// ---------------------------------------------------------------------------------------------
// Codec.

// A command as raw wire values, one per parameter of its spec, in spec order (positions in
// 0.1 um, velocities in 1E-6 m/s, ...: units.h converts). No count: that is a session concern.
struct McCommand {
  uint8_t master_id = 0;
  uint8_t sub_id = 0;
  std::vector<int64_t> values;

  constexpr CommandId id() const { return CommandId{master_id, sub_id}; }
  friend bool operator==(const McCommand&, const McCommand&) = default;
};

struct DecodedMotionCommand {
  Header header;                      // as received, including the count
  const CommandSpec* spec = nullptr;  // never null in a successful decode
  McCommand command;                  // values decoded per spec
};

// Encodes into a zero-filled 32-byte block, little-endian byte by byte (D-01, D-02).
// Errors: count > 15 -> InvalidArgument; unknown ID -> NotFound naming "0xMMS"; wrong number of
// values -> InvalidArgument; a value outside its type -> OutOfRange
// ("vai_go_to_pos.maximal_velocity: 4294967296 exceeds UInt32 max 4294967295").
absl::StatusOr<McBlock> EncodeMotionCommand(const McCommand& cmd, uint8_t count);

// Reads the header of a block (>= 2 bytes, else InvalidArgument).
absl::StatusOr<Header> DecodeHeader(std::span<const uint8_t> block);

// Decodes a block (>= 2 bytes). A block shorter than 32 bytes is fine as long as it holds every
// parameter of the command; otherwise InvalidArgument naming the missing bytes. Bytes after the
// last parameter are ignored (D-02). Unknown ID -> NotFound naming the ID, with the received
// header attached (UnknownCommandHeader) so that a simulator can raise 0081h.
absl::StatusOr<DecodedMotionCommand> DecodeMotionCommand(std::span<const uint8_t> block);

// Payload type URL carrying the raw header (4 hex digits) on DecodeMotionCommand's NotFound.
inline constexpr char kHeaderPayloadUrl[] = "type.drivegw.dev/linmot.mc.Header";
// The header attached to a NotFound from DecodeMotionCommand, if any.
std::optional<Header> UnknownCommandHeader(const absl::Status& status);

// Converts between the codec's raw values and the LinMotMcRequest parameter bytes of
// adapters/core/command.h (offset 2 onwards): ParameterBytes returns block[2 .. spec size).
absl::StatusOr<std::vector<uint8_t>> ParameterBytes(const McCommand& cmd);

// Field name for messages: "<command key>.<param name>", e.g. "vai_go_to_pos.target_position".
std::string FieldName(const CommandSpec& spec, size_t param_index);

// ---------------------------------------------------------------------------------------------
// Typed builders for the commands the gateway and the simulators use (raw wire units).

McCommand NoOperation();
McCommand Reset();
McCommand ClearEventEvaluation();
McCommand WriteInterfaceControlWord(uint16_t control_word);
// Every parameter travels as a 32-bit integer; the drive keeps the relevant bits (MC22 L1152).
// UInt32 parameters above 7FFF'FFFFh are passed as their two's-complement int32 (decision 101).
McCommand WriteLiveParameter(uint16_t upid, int32_t value);
McCommand MasterHoming(int32_t home_position);
// VA layout: position 0.1 um, velocity 1E-6 m/s, acceleration/deceleration 1E-5 m/s^2.
McCommand VaiGoToPos(int32_t target_position, uint32_t maximal_velocity, uint32_t acceleration,
                     uint32_t deceleration);
McCommand VaiIncrementDemPos(int32_t position_increment, uint32_t maximal_velocity,
                             uint32_t acceleration, uint32_t deceleration);
McCommand VaiIncrementTargetPos(int32_t position_increment, uint32_t maximal_velocity,
                                uint32_t acceleration, uint32_t deceleration);
McCommand VaiIncrementActPos(int32_t position_increment, uint32_t maximal_velocity,
                             uint32_t acceleration, uint32_t deceleration);
McCommand VaiGoToPosAfterActualCommand(int32_t target_position, uint32_t maximal_velocity,
                                       uint32_t acceleration, uint32_t deceleration);
McCommand VaiStop(uint32_t deceleration);
McCommand PredefVaiGoToPos(int32_t target_position);
McCommand PredefVaiIncrementDemPos(int32_t position_increment);
McCommand PredefVaiStop();
McCommand PredefVaiInfinitePositive();
McCommand PredefVaiInfiniteNegative();
McCommand VaiDecAccInfinitePositive(uint32_t maximal_velocity, uint32_t acceleration);
McCommand VaiDecAccInfiniteNegative(uint32_t maximal_velocity, uint32_t acceleration);
// §5.5 time curves (linmot-mc.md L515-L535): curve ID 1..100; offset 0.1 um; time scale
// 0.01 %; amplitude scale 0.1 %; curve time 10 us.
McCommand TimeCurveWithDefaultParameters(uint16_t curve_id);
McCommand TimeCurveWithAdjustableOffsetTimeScaleAmplitudeScale(uint16_t curve_id,
                                                               int32_t curve_offset,
                                                               uint16_t time_scale,
                                                               int16_t amplitude_scale);

// Typed view of a decoded VA-layout command (010-016, 018, 01A-01D, 070, 07E, 0D0, 0D9, 381,
// 386, 387, 3C0-3C2: position, velocity, acceleration, deceleration at offsets 2/6/10/14).
struct VaParams {
  int32_t position = 0;  // target or increment, 0.1 um
  uint32_t maximal_velocity = 0;
  uint32_t acceleration = 0;
  uint32_t deceleration = 0;
};
// InvalidArgument unless the command's spec has the VA layout.
absl::StatusOr<VaParams> AsVa(const McCommand& cmd);

}  // namespace drivegw::linmot::mc
