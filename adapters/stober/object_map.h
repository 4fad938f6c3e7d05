// The STOBER axis on CANopen: the wire binding the gateway's STOBER drive and the simulated axis
// (sim/stober/axis_device.h) both use (issue 5; stober-motion.md §7, G-01, G-23). For every
// parameter either side exchanges: its CANopen index/sub, CiA 301 data type and fixed-point
// scaling; value <-> bytes conversion with range errors; the packed motion status object; and the
// default PDO layout the gateway configures. Pure: no I/O. Decisions 1171-1179.
//
// Scaling (decision 1172): user-unit quantities travel as fixed-point integers, value = raw ×
// scale, so positions (INTEGER32, 0.001 u) cover ±2 147 483.647 u exactly; CiA 402 objects keep
// their standard CiA 402 data types (6040h u16, 6060h i8, 607Ah i32, 6081h u32, 6071h i16 ...).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/pdo.h"
#include "adapters/stober/param_id.h"

namespace drivegw::stober {

// CiA 301 §7.1.6 basic types used on the wire (a subset; no REAL32, decision 1172).
enum class WireType : uint8_t { kU8, kI8, kU16, kI16, kU32, kI32 };
std::string_view WireTypeName(WireType type);  // "u8", "i8", ...
uint8_t WireTypeBits(WireType type);           // 8, 16, 32
bool WireTypeSigned(WireType type);
int64_t WireTypeMin(WireType type);
int64_t WireTypeMax(WireType type);
drivegw::canopen::PdoType ToPdoType(WireType type);

// Quantity classes and their increments (decision 1172). Times in ms use 1 µs, percent 0.1 %
// (the CiA 402 per-thousand of 6071h/6087h), user units 0.001 u.
inline constexpr double kUserUnitScale = 0.001;     // u, u/s, u/s², u/s³ per increment
inline constexpr double kMillisecondScale = 0.001;  // ms per increment (1 µs)
inline constexpr double kPercentScale = 0.1;        // % per increment (‰)

// One CANopen object of the STOBER axis and the parameter whose value it carries.
struct ObjectBinding {
  ParamId param;           // the STOBER parameter (A-lines > 511 reach it via CiA 402)
  CanOpenAddress address;  // ToCanOpen(param), or a CiA 402 alias (606Ch → I88)
  WireType type = WireType::kI32;
  double scale = 1;        // user value = raw × scale; 1 for integers and booleans
  bool boolean = false;    // raw must be 0 or 1
  bool read_only = false;  // status values: the drive refuses writes (0601 0002h)
  std::string_view name;   // "position actual value"
};

// Every bound object in address order; each parameter appears once with its ToCanOpen address,
// plus the CiA 402 aliases that carry an I-parameter (606Ch velocity actual value ↔ I88,
// decision 1173). The packed status object (kStatusFlagsIndex) is not in this list.
const std::vector<ObjectBinding>& ObjectMap();
// The binding of a parameter at its own address; NotFound naming the parameter.
absl::StatusOr<ObjectBinding> FindBinding(ParamId id);
// The binding at a CANopen address (aliases included); NotFound naming the address.
absl::StatusOr<ObjectBinding> FindBinding(CanOpenAddress address);

// User value → wire integer: rounds to the nearest increment; OutOfRange naming the parameter
// and the limit in user units ("I403 (position): 3000000 above the wire maximum 2147483.647"),
// InvalidArgument for NaN/inf or a non-integer where the parameter is integer/boolean.
absl::StatusOr<int64_t> ToRaw(const ObjectBinding& binding, double value);
double FromRaw(const ObjectBinding& binding, int64_t raw);
// Little-endian bytes of the wire type for `value` (Encode) and back (Decode; exactly the wire
// type's size, else InvalidArgument naming the parameter and the sizes).
absl::StatusOr<std::vector<uint8_t>> Encode(ParamId id, double value);
absl::StatusOr<double> Decode(ParamId id, std::span<const uint8_t> bytes);
absl::StatusOr<std::vector<uint8_t>> Encode(const ObjectBinding& binding, double value);
absl::StatusOr<double> Decode(const ObjectBinding& binding, std::span<const uint8_t> bytes);

// ---- packed motion status (decision 1174) ----
// A manufacturer object outside the 2000h..39FFh parameter range, UNSIGNED32, read-only,
// mappable: the status flags of the motion core in one TPDO entry.
// CiA 402 6007h abort connection option code (INTEGER16): the drive's reaction to a lost
// connection such as a heartbeat consumer time-out (decision 1483).
inline constexpr uint16_t kAbortConnectionOption = 0x6007;
enum AbortConnectionOption : uint16_t {
  kAbortNoAction = 0,
  kAbortFault = 1,
  kAbortDisableVoltage = 2,
  kAbortQuickStop = 3,
};

inline constexpr uint16_t kStatusFlagsIndex = 0x4000;
inline constexpr uint8_t kStatusFlagsSub = 0;
namespace status_bit {
inline constexpr uint32_t kError = 1u << 0;        // I91
inline constexpr uint32_t kDone = 1u << 1;         // I92
inline constexpr uint32_t kCommandStateShift = 2;  // I83 (0..2) in bits 2-3
inline constexpr uint32_t kCommandStateMask = 3u << 2;
inline constexpr uint32_t kProfileDone = 1u << 4;               // I85
inline constexpr uint32_t kInReference = 1u << 5;               // I86
inline constexpr uint32_t kInWindow = 1u << 6;                  // I180
inline constexpr uint32_t kSpeedReached = 1u << 7;              // I183
inline constexpr uint32_t kStandstill = 1u << 8;                // I199
inline constexpr uint32_t kVelocityLimit = 1u << 9;             // I190
inline constexpr uint32_t kDynamicsLimit = 1u << 10;            // I191
inline constexpr uint32_t kCyclicPositionLimit = 1u << 11;      // I192
inline constexpr uint32_t kCyclicVelocityLimit = 1u << 12;      // I193
inline constexpr uint32_t kCyclicTorqueLimit = 1u << 13;        // I194
inline constexpr uint32_t kCyclicAccelerationLimit = 1u << 14;  // I195
inline constexpr uint32_t kPositiveLimitSwitch = 1u << 15;      // I441
inline constexpr uint32_t kNegativeLimitSwitch = 1u << 16;      // I442
}  // namespace status_bit

// The parameters packed into kStatusFlagsIndex, with their bit (I83: the shift of its 2 bits).
struct StatusFlagBit {
  ParamId param;
  uint32_t bit;  // mask of a boolean; for I83 the mask of both bits
  bool two_bit;  // I83
};
const std::vector<StatusFlagBit>& StatusFlagBits();

// Motion status decoded from TPDO1 (or assembled by the simulator to encode it).
struct MotionStatus {
  uint16_t status_word = 0;  // 6041h (A516)
  int plc_state = 0;         // I89
  int cause = 0;             // I90
  uint32_t flags = 0;        // kStatusFlagsIndex
  bool error() const { return (flags & status_bit::kError) != 0; }
  bool done() const { return (flags & status_bit::kDone) != 0; }
  int command_state() const {
    return static_cast<int>((flags & status_bit::kCommandStateMask) >>
                            status_bit::kCommandStateShift);
  }
  friend bool operator==(const MotionStatus&, const MotionStatus&) = default;
};

// ---- default PDO layout (decision 1175) ----
// One mapped field: the object (address + wire type) and, unless it is the packed status, its
// parameter.
struct PdoField {
  std::optional<ParamId> param;  // nullopt: the packed status object
  drivegw::canopen::PdoMappingEntry entry;
  WireType type = WireType::kU8;
};
struct PdoLayout {
  drivegw::canopen::PdoKind kind = drivegw::canopen::PdoKind::kRpdo;
  uint16_t number = 1;  // 1..4, predefined-set COB-IDs
  drivegw::canopen::PdoCommParams comm;
  std::vector<PdoField> fields;  // payload order
  drivegw::canopen::PdoMapping Mapping() const;
};
// RPDO1 = 6040h control word, I401 command, I403 position, I402 execute (the edge last);
// RPDO2 = I404 velocity, I405 acceleration; RPDO3 = I406 deceleration, I407 jerk;
// RPDO4 = I230 override, I411 direction, I410 brake at end, I400 motion ID;
// TPDO1 = 6041h status word, I89, I90, packed status flags (event-driven, no inhibit);
// TPDO2 = 6064h position actual (A545), 606Ch velocity actual (I88) (event-driven, inhibit
// 10 ms, event timer 100 ms). All RPDOs event-driven (type 255): applied on reception.
const std::vector<PdoLayout>& DefaultPdoLayout();
// The layout entry of one PDO; nullptr when the default layout leaves it unused.
const PdoLayout* FindDefaultPdo(drivegw::canopen::PdoKind kind, uint16_t number);

// Typed PDO values (adapters/canopen PackPdo/UnpackPdo) for a layout: user values in field order
// (the packed status as its raw u32) → payload, and back.
absl::StatusOr<std::vector<uint8_t>> PackLayout(const PdoLayout& layout,
                                                std::span<const double> values);
absl::StatusOr<std::vector<double>> UnpackLayout(const PdoLayout& layout,
                                                 std::span<const uint8_t> payload);
// TPDO1 payload → MotionStatus; TPDO2 payload → {position, velocity} in user units.
absl::StatusOr<MotionStatus> DecodeStatusTpdo(std::span<const uint8_t> payload);
struct ActualValues {
  double position = 0;  // 6064h, u
  double velocity = 0;  // 606Ch, u/s
};
absl::StatusOr<ActualValues> DecodeActualTpdo(std::span<const uint8_t> payload);

}  // namespace drivegw::stober
