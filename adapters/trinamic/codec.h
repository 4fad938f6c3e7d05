// Trinamic SIXpack/QUADpack codec: 9-byte command datagrams, 8/9-byte serial replies and 8-byte
// CAN frames, table-driven over all 39 opcodes. Pure (no I/O). No checksums: the protocol has none.
// Source of truth: shared/protocols/trinamic-sixpack.md §2.3-2.4, §3.1, §4 (seed L275-317,
// L473-1024).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::trinamic {

// Opcodes of the instruction table (§4.1, seed chapter 9 L984-1024).
enum class Opcode : uint8_t {
  kPeakCurrent = 0x10,
  kCurrentControl = 0x11,
  kVelocitySetting = 0x12,
  kStartingVelocity = 0x13,
  kSetRamp = 0x14,
  kMotorParameters = 0x15,
  kReferenceParameters = 0x16,
  kWriteTable = 0x17,
  kNullOffset = 0x18,
  kPiParameters = 0x19,
  kQueryPosition = 0x20,
  kQueryVelocity = 0x21,
  kStartReferenceSearch = 0x22,
  kStartRamp = 0x23,
  kActivatePi = 0x24,
  kStartRotation = 0x25,
  kSetTarget = 0x26,
  kSetPosition = 0x27,
  kQueryActivities = 0x28,
  kStartRampParallel = 0x29,
  kStopMotors = 0x2A,
  kReadInputs = 0x30,
  kAnalogStopLimits = 0x31,
  kSetOutputs = 0x32,
  kReadyOutput = 0x33,
  kSetBaudRate = 0x40,
  kSetPacketTimeout = 0x41,
  kChangeAddress = 0x42,
  kUnitInformation = 0x43,
  kRs232Tunnel = 0x44,
  kPowerDown = 0x45,
  kHardwareReset = 0xCC,
  kInterpolate = 0x50,
  kFlashEnable = 0xF2,
  kFlashProgram = 0xF3,
  kFlashChecksum = 0xF4,
  kFlashRead = 0xF5,
  kEepromWrite = 0xF6,
  kEepromRead = 0xF7,
};

inline constexpr size_t kCommandSize = 9;    // A CMD P0..P6 (§2.3, L275, L375)
inline constexpr size_t kReplyBodySize = 8;  // CMD P0..P6 (§2.4, L657-663)
inline constexpr size_t kParamCount = 7;     // P0..P6
inline constexpr size_t kOpcodeCount = 39;   // §4.1
inline constexpr uint8_t kMotorCount = 6;    // SIXpack motnr 0..5 (L475); QUADpack policy G-17
inline constexpr uint8_t kMotorMask = 0x3F;  // bit n = motor n (L746, L763, L770)

// Wire type of one field; multi-byte fields are little-endian (§0, L475, L503).
enum class FieldType : uint8_t { kU8, kI8, kU16, kI16, kU32, kI32 };
size_t FieldWidth(FieldType type);

// One named field of a request or reply: position `param` (0 = P0) and inclusive range.
// `multiple_of` > 1 restricts the value further (`$17` pointer 0, 4, 8, 12: L618-625).
struct FieldSpec {
  const char* name;
  FieldType type;
  uint8_t param;
  int64_t min;
  int64_t max;
  uint8_t multiple_of = 1;
};

// One row of the instruction table (§4.1, §4.2). `has_reply` = the command carries a response
// address and the PACK answers with a reply body; silent commands have no reply fields.
struct OpcodeSpec {
  Opcode opcode;
  const char* name;  // snake_case, used in error messages ("set_ramp.amax: ...")
  std::array<FieldSpec, kParamCount> fields;
  uint8_t field_count;
  bool has_reply;
  std::array<FieldSpec, kParamCount> reply_fields;
  uint8_t reply_field_count;
  int8_t response_address_field;  // index into fields of RA, -1 if none

  std::span<const FieldSpec> Fields() const { return {fields.data(), field_count}; }
  std::span<const FieldSpec> ReplyFields() const {
    return {reply_fields.data(), reply_field_count};
  }
};

// The whole table, in the order of §4.1.
std::span<const OpcodeSpec> OpcodeTable();
// The row for a byte value; NotFound for bytes that are no opcode (the PACK ignores them, G-06).
absl::StatusOr<const OpcodeSpec*> FindOpcode(uint8_t byte);
const OpcodeSpec& SpecOf(Opcode opcode);

// A request (host → PACK). `values[i]` belongs to `SpecOf(opcode).fields[i]`; unused entries are 0.
struct Command {
  uint8_t address = 1;  // unit address A (1..255, decision 1013)
  Opcode opcode = Opcode::kQueryPosition;
  std::array<int64_t, kParamCount> values{};

  friend bool operator==(const Command&, const Command&) = default;
};

// Builds a command from field values in table order; checks count and ranges.
absl::StatusOr<Command> MakeCommand(uint8_t address, Opcode opcode,
                                    std::initializer_list<int64_t> values);
// Field access by the table's name; NotFound names the opcode and field.
absl::StatusOr<int64_t> GetField(const Command& command, std::string_view field);
absl::Status SetField(Command& command, std::string_view field, int64_t value);

// A reply body (PACK → host). `response_address` is the RA the reply was sent to: on the wire in
// framing R9 and as the CAN identifier; unknown (0) after decoding an R8 reply.
struct Reply {
  uint8_t response_address = 0;
  Opcode opcode = Opcode::kQueryPosition;
  std::array<int64_t, kParamCount> values{};

  friend bool operator==(const Reply&, const Reply&) = default;
};
absl::StatusOr<int64_t> GetField(const Reply& reply, std::string_view field);

// Range check of every field; messages read "<opcode>.<field>: <value> exceeds <max>".
absl::Status ValidateCommand(const Command& command);
absl::Status ValidateReply(const Reply& reply);

// Serial request: exactly 9 bytes, unused parameter bytes 00 (L375). Unused bytes received
// non-zero are ignored by DecodeCommand (decision 1012).
absl::StatusOr<std::vector<uint8_t>> EncodeCommand(const Command& command);
absl::StatusOr<Command> DecodeCommand(std::span<const uint8_t> bytes);

// Serial reply framing (G-01, decision 1011): R8 = `CMD P0..P6`, R9 = `RA CMD P0..P6`.
enum class ReplyFraming : uint8_t { kR8, kR9 };
// RA must differ from 00 and from every reply opcode so that the first reply byte tells the
// framing apart (§2.4); InvalidArgument otherwise.
absl::Status ValidateResponseAddress(uint8_t response_address);
// Framing from the first byte of a reply to a query sent with `response_address`:
// byte == RA → R9; byte == a reply opcode → R8; anything else (e.g. a stray 00, L228) is an error.
absl::StatusOr<ReplyFraming> DetectReplyFraming(uint8_t first_byte, uint8_t response_address);
size_t ReplySize(ReplyFraming framing);

absl::StatusOr<std::vector<uint8_t>> EncodeReply(const Reply& reply, ReplyFraming framing);
// Decodes exactly ReplySize(framing) bytes. Undefined reply bytes (G-02) are ignored.
absl::StatusOr<Reply> DecodeReply(std::span<const uint8_t> bytes, ReplyFraming framing);

// CAN 2.0A (§3.1, L289-291): 11-bit identifier, 8 data bytes `CMD P0..P6`.
struct CanFrame {
  uint16_t id = 0;
  uint8_t dlc = 8;
  std::array<uint8_t, 8> data{};

  friend bool operator==(const CanFrame&, const CanFrame&) = default;
};
// Command ID = A << 3 (A 1..255, L289); reply ID = RA << 3 (L291); RS-232 tunnel ids (L315-317).
absl::StatusOr<uint16_t> CommandCanId(uint8_t address);
absl::StatusOr<uint16_t> ReplyCanId(uint8_t response_address);
absl::StatusOr<uint16_t> TunnelTransmitCanId(uint8_t address);        // (A << 3) + 1
absl::StatusOr<uint16_t> TunnelReceiveCanId(uint8_t tunnel_address);  // $44 P1 << 3 (G-30)

// `$40` baud-rate divisor (§2.1 table, L832): baud = 1 250 000 / divisor. The gateway only runs
// standard termios rates its own port can take; BaudOfDivisor returns the rate of 1200..115200
// whose rounded divisor `divisor` is (1042, 521, 260, 130, 65, 33, 22, 11; 1800 = 694), else
// InvalidArgument naming `$40.divisor` and the accepted values. DivisorOfBaud(19200) = 65.
absl::StatusOr<int> BaudOfDivisor(int64_t divisor);
int DivisorOfBaud(int baud);
// The PACK's line rate after every reset (L273, L899).
inline constexpr int kResetBaud = 19200;

absl::StatusOr<CanFrame> EncodeCommandCan(const Command& command);
absl::StatusOr<Command> DecodeCommandCan(const CanFrame& frame);
absl::StatusOr<CanFrame> EncodeReplyCan(const Reply& reply);
absl::StatusOr<Reply> DecodeReplyCan(const CanFrame& frame);

// `$15` motor-type word bits (§4.2 `$15`, L573-603; StopNoRef = P6 bit 5 per G-10).
namespace motor_type {
inline constexpr uint16_t kPiMode = 0x0001;
inline constexpr uint16_t kRotaryAxis = 0x0002;
inline constexpr uint16_t kAutoNullCmd = 0x0004;
inline constexpr uint16_t kTestNull = 0x0008;
inline constexpr uint16_t kNullLeft = 0x0010;
inline constexpr uint16_t kNullCenter = 0x0020;
inline constexpr uint16_t kStopNull = 0x0040;
inline constexpr uint16_t kFilterSwitch = 0x0080;
inline constexpr uint16_t kWayOptimization = 0x0100;
inline constexpr uint16_t kFastRef = 0x0200;
inline constexpr uint16_t kMechRef = 0x0400;
inline constexpr uint16_t kDelayTestNull = 0x0800;
inline constexpr uint16_t kStopSoft = 0x1000;
inline constexpr uint16_t kStopNoRef = 0x2000;
inline constexpr uint16_t kNullPositive = 0x4000;
inline constexpr uint16_t kStopAtFullsteps = 0x8000;
}  // namespace motor_type

}  // namespace drivegw::trinamic
