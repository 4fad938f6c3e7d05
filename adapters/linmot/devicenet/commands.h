// LinMot DeviceNet general-purpose commands: the table of all 102 commands (seed chapter 5.2),
// the command word, table-driven encode/decode of commands and responses, the per-motor toggle
// bit and the coded errors. Pure (no I/O).
// Source of truth: shared/protocols/linmot-devicenet.md §8 (seed lines 542-3274).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/linmot/devicenet/codec_io.h"

namespace drivegw::linmot::devicenet {

// ---------------------------------------------------------------------------------------------
// Command word (§7.2, §8.1): bits 15..12 motor select (Addressed; reserved in Direct slots),
// 11..8 reserved, 7 T (Start Command / Toggle), 6..0 command ID.
struct CommandWord {
  uint8_t id = 0;          // 0..0x7F
  bool toggle = false;     // bit 7
  uint8_t motor_mask = 0;  // bits 15..12 as bit 0 = A .. bit 3 = D
  uint8_t reserved = 0;    // bits 11..8, kept so that decode/encode round-trips

  constexpr uint16_t raw() const {
    return static_cast<uint16_t>(((motor_mask & 0x0F) << 12) | ((reserved & 0x0F) << 8) |
                                 (toggle ? 0x80 : 0) | (id & 0x7F));
  }
  static constexpr CommandWord FromRaw(uint16_t raw) {
    return CommandWord{static_cast<uint8_t>(raw & 0x7F), (raw & 0x80) != 0,
                       static_cast<uint8_t>(raw >> 12), static_cast<uint8_t>((raw >> 8) & 0x0F)};
  }
  friend constexpr bool operator==(CommandWord, CommandWord) = default;
};

// ---------------------------------------------------------------------------------------------
// The command table (§8.4).

// Command IDs of §8.4 (seed overview lines 548-658); names per the errata of §15.
enum class CommandId : uint8_t {
  kNoCommand = 0x00,
  kGetStatusLowWord = 0x02,
  kGetStatusHighWord = 0x03,
  kGetControlWord = 0x04,
  kSetControlWord = 0x05,
  kGetWarnState = 0x06,
  kResetWarnState = 0x07,
  kGetErrorState = 0x08,
  kResetErrorState = 0x09,
  kGetCodedError = 0x0A,
  kResetCodedError = 0x0B,
  kGetControllerIo = 0x0C,
  kSetControllerIo = 0x0D,
  kResetController = 0x0F,
  kGetPositionSetpoint = 0x10,
  kSetPositionSetpoint = 0x11,
  kSetPositionSetpointWaitingForTrigger = 0x12,
  kIncrementPositionSetpoint = 0x13,
  kIncrementPositionSetpointWaitingForTrigger = 0x14,
  kMoveHomePosition = 0x15,
  kGetActualPosition = 0x18,
  kSetActualPosition = 0x19,
  kStartCurve = 0x20,
  kStartCurveWaitingForTrigger = 0x21,
  kStartCurveIncremental = 0x22,
  kStartCurveIncrementalWaitingForTrigger = 0x23,
  kGetRiseCurveNumber = 0x24,
  kSetRiseCurveNumber = 0x25,
  kGetFallCurveNumber = 0x26,
  kSetFallCurveNumber = 0x27,
  kGetCurveOffset = 0x28,
  kSetCurveOffset = 0x29,
  kGetCurveAmplitude = 0x2A,
  kSetCurveAmplitude = 0x2B,
  kGetCurveSpeed = 0x2C,
  kSetCurveSpeed = 0x2D,
  kGetControllerMaximalCurrent = 0x30,
  kSetControllerMaximalCurrent = 0x31,
  kGetControllerCurrentOffset = 0x32,
  kSetControllerCurrentOffset = 0x33,
  kGetControllerP = 0x34,
  kSetControllerP = 0x35,
  kGetControllerD = 0x36,
  kSetControllerD = 0x37,
  kGetControllerI = 0x38,
  kSetControllerI = 0x39,
  kGetControllerFfFriction = 0x3A,
  kSetControllerFfFriction = 0x3B,
  kGetControllerFfAcceleration = 0x3C,
  kSetControllerFfAcceleration = 0x3D,
  kGetControllerFfDeceleration = 0x3E,
  kSetControllerFfDeceleration = 0x3F,
  kGetMinimalPosition = 0x40,
  kSetMinimalPosition = 0x41,
  kGetMaximalPosition = 0x42,
  kSetMaximalPosition = 0x43,
  kGetPosRangeMin = 0x44,
  kSetPosRangeMin = 0x45,
  kGetPosRangeMax = 0x46,
  kSetPosRangeMax = 0x47,
  kGetInPositionMinus = 0x48,
  kSetInPositionMinus = 0x49,
  kGetInPositionPlus = 0x4A,
  kSetInPositionPlus = 0x4B,
  kGetFollowingErrorMinus = 0x4C,
  kSetFollowingErrorMinus = 0x4D,
  kGetFollowingErrorPlus = 0x4E,
  kSetFollowingErrorPlus = 0x4F,
  kGetFilterMaxSpeed = 0x50,
  kSetFilterMaxSpeed = 0x51,
  kGetFilterMaxAcceleration = 0x52,
  kSetFilterMaxAcceleration = 0x53,
  kGet0VPosition = 0x56,
  kSet0VPosition = 0x57,
  kGet10VPosition = 0x58,
  kSet10VPosition = 0x59,
  kGetZeroPosition = 0x5A,
  kSetZeroPosition = 0x5B,
  kGetOnePosition = 0x5C,
  kSetOnePosition = 0x5D,
  kGetEncoder1Position = 0x60,
  kSetEncoder1Position = 0x61,
  kGetCamLength = 0x62,
  kSetCamLength = 0x63,
  kGetExtendedIo = 0x64,
  kSetExtendedIo = 0x65,
  kGetEncoder1Offset = 0x66,
  kSetEncoder1Offset = 0x67,
  kStartCamAtCounts = 0x68,
  kGetCamDelay = 0x6A,
  kSetCamDelay = 0x6B,
  kSetContinuousCurveMode = 0x6D,
  kSetSerialRunMode = 0x6E,
  kSetMasterEncoderRunMode = 0x6F,
  kGetDirectOut1Variable = 0x70,
  kSetDirectOut1Variable = 0x71,
  kGetDirectOut2Variable = 0x72,
  kSetDirectOut2Variable = 0x73,
  kGetDirectOut1Address = 0x74,
  kSetDirectOut1Address = 0x75,
  kGetDirectOut2Address = 0x76,
  kSetDirectOut2Address = 0x77,
};
inline constexpr size_t kCommandCount = 102;
constexpr uint8_t Raw(CommandId id) { return static_cast<uint8_t>(id); }

enum class CommandKind : uint8_t {
  kNoCommand,  // 0x00
  kGet,        // reads a value; Addressed only
  kSet,        // writes a value; the response echoes it
  kAction,     // resets, motion, curve starts, run modes
};

// Bits 15..12 of an Addressed command (§8.4 "Motor select").
enum class MotorSelect : uint8_t {
  kSystem,     // "-": no motor; bits reserved (any set bit is D-6's 0x8110 on the drive)
  kOptional,   // "none or one": 0x06, 0x08, 0x09 (system word without, motor word with)
  kRequired,   // "A-D": exactly one motor
  kUndefined,  // "?": overview-only commands 0x68, 0x6D, 0x74-0x77 (D-19): none or one
};

// Type of a word 2 (request or response).
enum class ValueType : uint8_t {
  kDontCare,  // "X": encoded as 0, ignored on decode
  kInt16,     // signed word (positions, offsets)
  kUInt16,    // unsigned word (gains, speeds, counts, codes)
  kBits,      // bit field (WordKind below)
};

struct ValueSpec {
  ValueType type = ValueType::kDontCare;
  int32_t min = 0;  // inclusive range of the seed (§8.4 "Range")
  int32_t max = 0;
  const char* unit = "";               // "pos", "23.438 mA", "counts", ...
  const char* name = "";               // snake_case field name: "position_setpoint"
  WordKind bits = WordKind::kControl;  // for kBits: which word (motor variants resolved at use)
};

enum class ResponseKind : uint8_t {
  kEcho,        // word 2 echoes the request value ("simply echoes the command")
  kValue,       // word 2 = the `response` ValueSpec
  kNoResponse,  // 0x0F Reset Controller: no response at all (seed line 984)
  kDontCare,    // 0x00 No Command: word 2 has no meaning
  kActualIo,    // 0x0D / 0x65: the actual I/O word, not a plain echo (lines 963, 2997)
};

enum class Requirement : uint8_t {
  kNone,
  kMasterEncoder,       // master encoder module (lines 2868 ff.)
  kEncoderOrDigitalIo,  // master encoder or digital IO module (line 2966)
};

struct CommandSpec {
  uint8_t id;
  const char* name;  // seed name, errata corrected: "Set Position Setpoint"
  CommandKind kind;
  bool addressed;  // overview "Addressed" column
  bool direct;     // overview "Direct" column
  MotorSelect motor_select;
  bool toggle;  // T-command: executes only if T != Command Toggle of the motor (D-4)
  ValueSpec request;
  ResponseKind response_kind;
  ValueSpec response;
  bool serial_mode;  // run mode must be serial (0x8112)
  Requirement requirement;
  bool trigger_armed;  // 0x12, 0x14, 0x21, 0x23: armed on a new word/value (D-4)
  bool one_shot;       // §11.4 one_shot_set: replaced by No Command once answered
  bool documented;     // false for the overview-only 0x68, 0x6D, 0x74-0x77 (D-19)
  const char* seed_lines;

  // snake_case key: "Set Position Setpoint" -> "set_position_setpoint".
  std::string key() const;
  // Coded errors a drive may raise for this command (§8.6, triggers [SEED-INF]).
  std::vector<uint16_t> ErrorCodes() const;
};

// Every command of §8.4, ascending ID (102 entries).
std::span<const CommandSpec> AllCommands();
// nullptr for an ID §8.4 does not list (§8.7: the drive answers with coded error 0x8108).
const CommandSpec* FindCommand(uint8_t id);
inline const CommandSpec* FindCommand(CommandId id) { return FindCommand(Raw(id)); }

// ---------------------------------------------------------------------------------------------
// Commands as values.

enum class Module : uint8_t { kAddressed, kDirect };
const char* ModuleName(Module m);  // "addressed", "direct"

struct Command {
  uint8_t id = 0;
  std::optional<Motor> motor;  // Addressed: the select bit; Direct: nullopt (the slot's motor)
  bool toggle = false;         // bit 7 (T); see NextToggle
  int32_t value = 0;           // word 2 per the spec: Int16 as signed, UInt16/bits 0..65535
  friend constexpr bool operator==(const Command&, const Command&) = default;
};

// Gateway side, driven by the table. Errors (STYLE §6 "where: what"):
//  NotFound "devicenet command 0x01: not in the command table";
//  OutOfRange when the value does not fit word 2 ("... 40000 exceeds Int16 max 32767").
// With `strict` (the gateway's default) also:
//  InvalidArgument "devicenet set_position_setpoint: needs exactly one motor (A-D)", "...: not
//  allowed in a Direct slot", "...: system command, motor B given", "...: undocumented (D-19)";
//  OutOfRange "devicenet set_in_position_plus.in_position_plus: 1 below minimum 2".
// Non-strict encoding writes whatever the Command says (tests provoke coded errors with it);
// a motor in a Direct slot is still rejected (bits 15..8 are reserved there, §7.3).
// Don't-care words are sent as 0.
absl::StatusOr<CommandSlot> EncodeCommand(const Command& command, Module module,
                                          bool strict = true);

// What a drive makes of a received slot.
struct DecodedCommand {
  const CommandSpec* spec = nullptr;  // never null in a successful decode
  CommandWord word;                   // as received
  std::optional<Motor> motor;         // the selected motor (Addressed, exactly one bit)
  uint16_t raw_value = 0;             // word 2 as received
  int32_t value = 0;                  // word 2 typed per spec.request (Int16 sign-extended)
};
// Drive side. Errors carry the coded error (GetCodedError) the drive raises (§8.6, D-6, D-18):
//  NotFound + 0x8108 for an unknown ID; InvalidArgument + 0x8110 for a missing motor or more
//  than one select bit where one is required/allowed. Range and drive-state checks are the
//  simulator's (CheckRange). Reserved bits are kept in `word`, not rejected.
absl::StatusOr<DecodedCommand> DecodeCommand(CommandSlot slot, Module module);

// OutOfRange + 0x8118 when `value` lies outside the spec's request range (no-op for
// don't-care and bit fields): "devicenet set_in_position_plus.in_position_plus: 1 below
// minimum 2".
absl::Status CheckRange(const CommandSpec& spec, int32_t value);

// Drive side: the Addressed Out slot answering `command`. Echo = the full received command word
// (D-4 rule 3); word 2 per response kind: echo -> the received value; value/actual-I/O -> the
// given `response_value`; don't care -> `response_value`. FailedPrecondition for 0x0F (no
// response). OutOfRange when a value does not fit the response type.
absl::StatusOr<CommandSlot> EncodeResponse(const DecodedCommand& command,
                                           int32_t response_value = 0);

struct DecodedResponse {
  const CommandSpec* spec = nullptr;
  CommandWord echo;
  uint16_t raw_value = 0;
  int32_t value = 0;  // typed per the response kind/spec (Int16 sign-extended)
};
// Gateway side: decodes an Addressed Out slot. NotFound for an echoed ID outside the table.
absl::StatusOr<DecodedResponse> DecodeResponse(CommandSlot received);
// True when `received` answers `sent`: the echo equals the sent command word (§11.4).
constexpr bool ResponseMatches(CommandSlot sent, CommandSlot received) {
  return sent.word == received.word;
}

// ---------------------------------------------------------------------------------------------
// Toggle bit (§7.4 status high bit 4k+3, §8.2, D-4).

// T bit for the next T-command to `motor`: the inverse of its Command Toggle bit, so that the
// drive sees a new command. Non-T commands are sent with T = 0.
constexpr bool NextToggle(StatusHighWord status_high, Motor motor) {
  return !status_high.command_toggle(motor);
}
// Drive side: a T-command executes iff T differs from the motor's Command Toggle bit; the drive
// then sets the bit to T. Repeating the frame does nothing.
constexpr bool IsNewToggleCommand(bool t, StatusHighWord status_high, Motor motor) {
  return t != status_high.command_toggle(motor);
}
// Gateway side: the drive accepted a T-command once its Command Toggle bit equals T.
constexpr bool ToggleAccepted(bool t, StatusHighWord status_high, Motor motor) {
  return t == status_high.command_toggle(motor);
}
// The T bit to send for `spec`: NextToggle for T-commands, false otherwise.
bool ToggleFor(const CommandSpec& spec, StatusHighWord status_high, Motor motor);

// ---------------------------------------------------------------------------------------------
// Coded errors (§8.6; D-2: hexadecimal).

inline constexpr uint16_t kCodedNoError = 0x0000;  // 0x0A answer without a coded error (D-23)
inline constexpr uint16_t kCodedNeedsDnController = 0x8100;
inline constexpr uint16_t kCodedMacIdInUse = 0x8101;
inline constexpr uint16_t kCodedProcessorSpeed = 0x8104;
inline constexpr uint16_t kCodedUnknownCommand = 0x8108;
inline constexpr uint16_t kCodedDriveNotSpecified = 0x8110;
inline constexpr uint16_t kCodedDriveNotMaster = 0x8111;
inline constexpr uint16_t kCodedDriveNotSerial = 0x8112;
inline constexpr uint16_t kCodedRangeError = 0x8118;
inline constexpr uint16_t kCodedEncoderNotExists = 0x8120;
inline constexpr uint16_t kCodedEncoderSsiMode = 0x8121;
inline constexpr uint16_t kCodedCurveMissing = 0x8130;
inline constexpr uint16_t kCodedCurveTypeMismatch = 0x8131;
inline constexpr uint16_t kCodedCurveProcessing = 0x8132;
inline constexpr uint16_t kCodedCanNoError = 0x8140;
inline constexpr uint16_t kCodedCanStuffError = 0x8141;
inline constexpr uint16_t kCodedCanFormError = 0x8142;
inline constexpr uint16_t kCodedCanAckError = 0x8143;
inline constexpr uint16_t kCodedCanBit1Error = 0x8144;
inline constexpr uint16_t kCodedCanCrcError = 0x8145;
inline constexpr uint16_t kCodedCanBusOff = 0x8148;

struct CodedError {
  uint16_t code;
  const char* text;     // the seed's text, "Unknown command"
  const char* trigger;  // likely trigger (§8.6, [SEED-INF]); "" if none given
};
// The 20 application errors of §8.6, ascending.
std::span<const CodedError> AllCodedErrors();
const CodedError* FindCodedError(uint16_t code);
// "Unknown command (0x8108)"; "no coded error (0x0000)"; "LinMot coded error 0x1234" otherwise.
std::string CodedErrorText(uint16_t code);

// A coded error riding on an absl::Status (STYLE §6): payload under this URL, value = 4
// upper-case hex digits ("8108").
inline constexpr char kCodedErrorPayloadUrl[] = "type.drivegw.dev/linmot.devicenet.CodedError";
void AttachCodedError(absl::Status& status, uint16_t code);
std::optional<uint16_t> GetCodedError(const absl::Status& status);

}  // namespace drivegw::linmot::devicenet
