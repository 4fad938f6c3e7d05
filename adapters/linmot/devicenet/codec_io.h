// LinMot DeviceNet I/O data modules: the bit-field words (control, status low/high, warn/error
// states, controller IO) and the consumed/produced image codec; pure (no I/O).
// Source of truth: shared/protocols/linmot-devicenet.md §7 (seed chapter 5.1), §8.5.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace drivegw::linmot::devicenet {

// Motors A..D = drive 1..4 (§0.2, seed line 342).
enum class Motor : uint8_t { kA = 0, kB = 1, kC = 2, kD = 3 };
inline constexpr size_t kMotorCount = 4;
const char* MotorName(Motor m);  // "A", "B", "C", "D"
constexpr uint8_t MotorBit(Motor m) { return static_cast<uint8_t>(1u << static_cast<uint8_t>(m)); }

// ---------------------------------------------------------------------------------------------
// Words. These are the 2002 DeviceNet/AT-controller words, not the MC SW words of
// adapters/linmot/mc (a different protocol generation: linmot-mc.md line 8; decision 902).

// Control In / Set Control Word (§7.1, seed lines 334-351).
struct ControlWord {
  uint16_t raw = 0;
  static constexpr uint16_t kRunRequest = 1u << 1;
  static constexpr uint16_t kStopRequest = 1u << 2;
  static constexpr uint16_t kInitRequest = 1u << 3;
  static constexpr uint16_t kFreezeRequest = 1u << 4;
  static constexpr uint16_t kTriggerA = 1u << 8;       // + motor index
  static constexpr uint16_t kFreezeMotorA = 1u << 12;  // + motor index, firmware >= 1R3R10
  static constexpr uint16_t kReservedMask = 0x00E1;

  constexpr bool run_request() const { return (raw & kRunRequest) != 0; }
  constexpr bool stop_request() const { return (raw & kStopRequest) != 0; }
  constexpr bool init_request() const { return (raw & kInitRequest) != 0; }
  constexpr bool freeze_request() const { return (raw & kFreezeRequest) != 0; }
  constexpr bool trigger(Motor m) const { return (raw >> (8 + static_cast<int>(m))) & 1u; }
  constexpr bool freeze_motor(Motor m) const { return (raw >> (12 + static_cast<int>(m))) & 1u; }
  constexpr ControlWord With(uint16_t mask, bool on) const {
    return ControlWord{static_cast<uint16_t>(on ? (raw | mask) : (raw & ~mask))};
  }
  friend constexpr bool operator==(ControlWord, ControlWord) = default;
};

// Status Out word 1, Get Status Low Word (§7.4, seed lines 384-445).
struct StatusLowWord {
  uint16_t raw = 0;
  static constexpr uint16_t kInitDone = 1u << 0;
  static constexpr uint16_t kRunState = 1u << 1;
  static constexpr uint16_t kErrorState = 1u << 2;
  static constexpr uint16_t kInitState = 1u << 3;
  static constexpr uint16_t kDisableState = 1u << 4;
  static constexpr uint16_t kEmergencyStop = 1u << 5;
  static constexpr uint16_t kErrorPending = 1u << 6;
  static constexpr uint16_t kWarningPending = 1u << 7;
  static constexpr uint16_t kCurveDoneA = 1u << 8;    // toggles at each curve end; + motor
  static constexpr uint16_t kInPositionA = 1u << 12;  // + motor

  constexpr bool init_done() const { return (raw & kInitDone) != 0; }
  constexpr bool run_state() const { return (raw & kRunState) != 0; }
  constexpr bool error_state() const { return (raw & kErrorState) != 0; }
  constexpr bool init_state() const { return (raw & kInitState) != 0; }
  constexpr bool disable_state() const { return (raw & kDisableState) != 0; }
  constexpr bool emergency_stop() const { return (raw & kEmergencyStop) != 0; }
  constexpr bool error_pending() const { return (raw & kErrorPending) != 0; }
  constexpr bool warning_pending() const { return (raw & kWarningPending) != 0; }
  constexpr bool curve_done(Motor m) const { return (raw >> (8 + static_cast<int>(m))) & 1u; }
  constexpr bool in_position(Motor m) const { return (raw >> (12 + static_cast<int>(m))) & 1u; }
  constexpr StatusLowWord With(uint16_t mask, bool on) const {
    return StatusLowWord{static_cast<uint16_t>(on ? (raw | mask) : (raw & ~mask))};
  }
  friend constexpr bool operator==(StatusLowWord, StatusLowWord) = default;
};

// Status Out word 2, Get Status High Word: 4 bits per motor k at 4k (§7.4, seed 401-417, 724).
struct StatusHighWord {
  uint16_t raw = 0;
  static constexpr uint16_t kFollowingError = 1u << 0;  // shifted by 4 * motor
  static constexpr uint16_t kPositionRange = 1u << 1;
  static constexpr uint16_t kOverTemperature = 1u << 2;
  static constexpr uint16_t kCommandToggle = 1u << 3;
  static constexpr uint16_t Bit(Motor m, uint16_t flag) {
    return static_cast<uint16_t>(flag << (4 * static_cast<int>(m)));
  }

  constexpr bool following_error(Motor m) const { return (raw & Bit(m, kFollowingError)) != 0; }
  constexpr bool position_range(Motor m) const { return (raw & Bit(m, kPositionRange)) != 0; }
  constexpr bool over_temperature(Motor m) const { return (raw & Bit(m, kOverTemperature)) != 0; }
  constexpr bool command_toggle(Motor m) const { return (raw & Bit(m, kCommandToggle)) != 0; }
  constexpr StatusHighWord With(uint16_t mask, bool on) const {
    return StatusHighWord{static_cast<uint16_t>(on ? (raw | mask) : (raw & ~mask))};
  }
  friend constexpr bool operator==(StatusHighWord, StatusHighWord) = default;
};

// Bit names of the bit-field words of §7.1, §7.4 and §8.5, lowest bit first; reserved bits are
// named "Reserved". Word kinds:
enum class WordKind : uint8_t {
  kControl,           // §7.1
  kStatusLow,         // §7.4
  kStatusHigh,        // §7.4
  kSystemWarnState,   // 0x06 without motor select
  kMotorWarnState,    // 0x06 with a motor selected
  kSystemErrorState,  // 0x08 without motor select
  kMotorErrorState,   // 0x08 with a motor selected
  kControllerIo,      // 0x0C / 0x0D
  kExtendedIo,        // 0x64 / 0x65 (bits 15..8 outputs, 7..0 inputs)
};
// Name of `bit` (0..15) of a word kind ("RUN Request", "Motor B Command Toggle").
const char* WordBitName(WordKind kind, int bit);
// Names of the set (non-reserved and reserved) bits, lowest first.
std::vector<std::string> SetBitNames(WordKind kind, uint16_t raw);

// System Error State bit 7: a coded error is present, read it with 0x0A (seed line 847).
inline constexpr uint16_t kSystemErrorCodedError = 1u << 7;
// Motor Error / Warn State bits used by the simulator (§8.5).
inline constexpr uint16_t kMotorTooHotCalc = 1u << 0;
inline constexpr uint16_t kMotorTooHotSensor = 1u << 1;
inline constexpr uint16_t kMotorFollowingError = 1u << 2;
inline constexpr uint16_t kMotorSliderMissing = 1u << 3;
// Controller IO word bits 15..10 are the outputs settable by 0x0D (seed line 959).
inline constexpr uint16_t kControllerIoOutputMask = 0xFC00;

// Direct Out variable selection codes (§6.2).
enum class DirectOutVariable : uint8_t {
  kActualPos = 0,
  kDemandPos = 1,
  kPositionError = 2,
  kDemPosUnfiltered = 3,
  kActualSpeed = 4,
  kDemandSpeed = 5,
  kDemandAcc = 6,
  kCurrent = 7,
};
const char* DirectOutVariableName(uint8_t code);  // "Actual Pos"; "unknown" above 7

// ---------------------------------------------------------------------------------------------
// Module selection and image layout (§7.7).

// D-1: byte order of the 16-bit words inside the I/O data, switchable per drive.
enum class ByteOrder : uint8_t { kLittleEndian, kBigEndian };

struct ModuleSet {
  bool control_in = false;     // 1 word  (master -> drive)
  bool addressed_in = false;   // 2 words
  bool direct_in = false;      // 2 words per master drive
  bool status_out = false;     // 2 words (drive -> master)
  bool addressed_out = false;  // 2 words
  bool direct_out_1 = false;   // 1 word per master drive
  bool direct_out_2 = false;   // 1 word per master drive
  friend constexpr bool operator==(ModuleSet, ModuleSet) = default;
};

struct IoLayout {
  ModuleSet modules;
  uint8_t master_drives = 0x1;  // bit 0 = A ... bit 3 = D (D-32: slots ascending, gaps close)
  ByteOrder byte_order = ByteOrder::kLittleEndian;
  friend constexpr bool operator==(IoLayout, IoLayout) = default;
};
// Number of master drives (Direct slots) of a layout.
size_t MasterDriveCount(const IoLayout& layout);
// The masters in slot order (§7.7, D-32).
std::vector<Motor> MasterDrives(const IoLayout& layout);
// consumed_bytes = 2c + 4a + 4dN; produced_bytes = 4s + 4o + 2(d1 + d2)N (§7.7).
size_t ConsumedSize(const IoLayout& layout);
size_t ProducedSize(const IoLayout& layout);
// "control_in+addressed_in" style text of the selected consumed / produced modules.
std::string ConsumedModulesText(const IoLayout& layout);
std::string ProducedModulesText(const IoLayout& layout);
// InvalidArgument for master_drives above 0xF: "devicenet io_layout.master_drives: 0x10 exceeds
// 0xF".
absl::Status ValidateLayout(const IoLayout& layout);

// Layouts of the seed and the reference fixtures (§7.7, §7.8, §13.1).
IoLayout DefaultLayoutP();  // D-3 candidate P: Control+Addressed In / Status+Addressed Out, A
IoLayout Example1Layout();  // seed example 1: 4 masters, all modules (22 / 24 bytes)
IoLayout Example2Layout();  // seed example 2: masters A, C; CtrlIn, DirectIn, StatusOut, DO1

// One command slot: Addressed In / Direct In (command word, value) or Addressed Out (echo,
// response value).
struct CommandSlot {
  uint16_t word = 0;
  uint16_t value = 0;
  friend constexpr bool operator==(CommandSlot, CommandSlot) = default;
};

// Master -> drive image. Present fields must match the layout's modules; `direct` has one slot
// per master drive in slot order.
struct ConsumedImage {
  std::optional<ControlWord> control;
  std::optional<CommandSlot> addressed;
  std::vector<CommandSlot> direct;
  friend bool operator==(const ConsumedImage&, const ConsumedImage&) = default;
};

struct DirectOut {
  std::optional<uint16_t> out_1;  // present iff Direct Out 1 is selected
  std::optional<uint16_t> out_2;
  friend constexpr bool operator==(DirectOut, DirectOut) = default;
};

// Drive -> master image.
struct ProducedImage {
  std::optional<StatusLowWord> status_low;  // Status Out (both or neither)
  std::optional<StatusHighWord> status_high;
  std::optional<CommandSlot> addressed;  // Addressed Out: echo, response value
  std::vector<DirectOut> direct;         // per master drive (if DO1 or DO2 selected)
  friend bool operator==(const ProducedImage&, const ProducedImage&) = default;
};

// Errors name the module: "devicenet consumed.addressed_in: selected but absent",
// "devicenet consumed.direct_in: 1 slots, layout has 2 master drives".
absl::StatusOr<std::vector<uint8_t>> EncodeConsumed(const IoLayout& layout,
                                                    const ConsumedImage& image);
// InvalidArgument unless the size equals ConsumedSize ("devicenet consumed: 4 bytes, layout
// control_in+addressed_in needs 6").
absl::StatusOr<ConsumedImage> DecodeConsumed(const IoLayout& layout,
                                             std::span<const uint8_t> bytes);
absl::StatusOr<std::vector<uint8_t>> EncodeProduced(const IoLayout& layout,
                                                    const ProducedImage& image);
absl::StatusOr<ProducedImage> DecodeProduced(const IoLayout& layout,
                                             std::span<const uint8_t> bytes);

// A zero image with every selected module present (control 0, No Command): the image the
// gateway sends first (§11.2 step 8) and the simulator's initial produced image.
ConsumedImage EmptyConsumed(const IoLayout& layout);
ProducedImage EmptyProduced(const IoLayout& layout);

}  // namespace drivegw::linmot::devicenet
