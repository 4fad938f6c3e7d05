// The simulated drive's UPID table: RAM and ROM values, type, limits, read-only variables (§9).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "sim/linmot/options.h"

namespace drivegw::sim::linmot {

// LinMot parameter types (linmot-mc.md §0.4); Bool uses bit 0 only (MC22 L1152).
enum class ParamType : uint8_t { kBool, kSInt16, kUInt16, kSInt32, kUInt32 };
const char* ParamTypeName(ParamType type);

struct ParamDef {
  uint16_t upid = 0;
  std::string name;
  ParamType type = ParamType::kSInt32;
  int64_t default_value = 0;
  int64_t min = 0;
  int64_t max = 0;
  // Variables (1Bxxh ...) are runtime values: RAM only, written by the drive itself.
  bool variable = false;
  // Refuses writes through RTC and 002x (A-14: 0xC3). All variables are read-only except those
  // motion commands write (CT Var 1E72h/1E73h are parameters here).
  bool read_only = false;
};

// UPIDs the simulator knows (linmot-mc.md §9.2; D-32 project UPIDs >= F000h).
namespace upid {
inline constexpr uint16_t kOperatingSubHours = 0x0082;  // ms within the hour (linudp §4.2)
inline constexpr uint16_t kActivePositionControllerSet = 0x1393;
inline constexpr uint16_t kMaximalCurrentSetA = 0x13A6;
inline constexpr uint16_t kMaximalCurrentSetB = 0x13BA;
inline constexpr uint16_t kHomePosition = 0x13C7;
inline constexpr uint16_t kSliderHomePosition = 0x13CA;
inline constexpr uint16_t kScalePosition16 = 0x1455;  // D-14: internal = value x scale
inline constexpr uint16_t kScaleVelocity16 = 0x1456;
inline constexpr uint16_t kScaleAcceleration16 = 0x1457;
inline constexpr uint16_t kScaleJerk16 = 0x1458;
inline constexpr uint16_t kMinimalPosition = 0x146E;         // below => 0007h
inline constexpr uint16_t kMaximalPosition = 0x146F;         // above => 0008h
inline constexpr uint16_t kPositionLagMovingMax = 0x1473;    // => 000Bh
inline constexpr uint16_t kPositionLagStandingMax = 0x1475;  // => 000Ch
inline constexpr uint16_t kPredefVelocity = 0x14BE;
inline constexpr uint16_t kPredefAcceleration = 0x14BF;
inline constexpr uint16_t kPredefDeceleration = 0x14C0;
inline constexpr uint16_t kPredefJerk = 0x14C1;
// 040h defaults, in the order §7 L1003 lists them (linmot-mc.md §5.5 L524; decision 606).
inline constexpr uint16_t kCurveOffset = 0x14C9;          // SInt32, 0.1 um
inline constexpr uint16_t kCurveAmplitudeScale = 0x14CA;  // SInt16, 0.1 %, -2000 ... 2000 %
inline constexpr uint16_t kCurveTimeScale = 0x14CB;       // UInt16, 0.01 %, 0 ... 200 %
inline constexpr uint16_t kTriggerMode = 0x170C;
inline constexpr uint16_t kQuickStopDeceleration = 0x1721;
inline constexpr uint16_t kDemandPosition = 0x1B8A;
inline constexpr uint16_t kDemandVelocity = 0x1B8B;
inline constexpr uint16_t kActualPosition = 0x1B8D;
inline constexpr uint16_t kActualVelocity = 0x1B8E;
inline constexpr uint16_t kDifferencePosition = 0x1B90;
inline constexpr uint16_t kDemandCurrent = 0x1B93;
inline constexpr uint16_t kControlWord = 0x1D4C;  // linudp 6.8: read by LinMot's own library
inline constexpr uint16_t kCapturePosition = 0x1E62;
inline constexpr uint16_t kCmdTabVar1 = 0x1E72;
inline constexpr uint16_t kCmdTabVar2 = 0x1E73;
inline constexpr uint16_t kMonitoringChannel1 = 0x20A8;  // ... 0x20AB (linudp §4.2, A-12)
// D-32 project UPIDs for values the manual names without a UPID.
inline constexpr uint16_t kInTargetWindow = 0xF000;        // 0.1 um (D-10)
inline constexpr uint16_t kHomingVelocity = 0xF001;        // 1E-6 m/s (D-39)
inline constexpr uint16_t kHomingAcceleration = 0xF002;    // 1E-5 m/s^2 (D-39)
inline constexpr uint16_t kMotorRequiresHoming = 0xF003;   // Bool (D-41)
inline constexpr uint16_t kPositionLagWarnLimit = 0xF004;  // 0.1 um, warn bit 4
inline constexpr uint16_t kHomingTargetPosition = 0xF005;  // 0.1 um, physical frame (D-39)
inline constexpr uint16_t kGoToPositionTarget = 0xF006;    // 0.1 um, state 15 (CW bit 6)
inline constexpr uint16_t kInitialPosition = 0xF007;       // 0.1 um, state 11 (CW bit 13)
inline constexpr uint16_t kJogVelocity = 0xF008;           // 1E-6 m/s, states 16/17
}  // namespace upid

// RAM/ROM store (D-31): RAM := ROM at boot and Reset; ROM lives as long as the object (the
// simulator process). Values are held as int64 in the parameter's own range.
class Parameters {
 public:
  explicit Parameters(std::vector<ParamDef> defs);
  // The table of this simulator with defaults derived from the options (stroke, homing, ...).
  static Parameters ForOptions(const SimOptions& options);

  const ParamDef* Find(uint16_t upid) const;
  // NotFound (unknown UPID); ReadRom of a variable is FailedPrecondition.
  absl::StatusOr<int64_t> ReadRam(uint16_t upid) const;
  absl::StatusOr<int64_t> ReadRom(uint16_t upid) const;
  // NotFound, FailedPrecondition (read-only), OutOfRange (outside min/max, naming both).
  absl::Status WriteRam(uint16_t upid, int64_t value);
  absl::Status WriteRom(uint16_t upid, int64_t value);

  // A 32-bit wire value (RTC words 3-4) read as the parameter's type: OutOfRange when it does
  // not fit the type (e.g. 70000 for a UInt16); min/max are checked by Write*.
  absl::StatusOr<int64_t> FromWire(uint16_t upid, uint32_t raw) const;
  // 002x Write Live Parameter: "the drive keeps only the relevant bits" (MC22 L1152).
  absl::StatusOr<int64_t> FromLiveWrite(uint16_t upid, uint32_t raw) const;
  // Value as the 32-bit wire word (sign-extended for signed types, A-12).
  static uint32_t ToWire(int64_t value);

  // RAM value for the drive's own use; 0 for an unknown UPID.
  int64_t Get(uint16_t upid) const;
  // The drive updates a variable (or any RAM value) bypassing read-only; clamped to the type.
  void Set(uint16_t upid, int64_t value);

  // D-31: every RAM value := its ROM value; variables keep their values.
  void Boot();
  // RTC 0x31-0x34: ROM := default for every parameter.
  void RestoreRomDefaults();

  // UPID list (RTC 0x20-0x23): the first known UPID >= from; with modified_only, the first whose
  // ROM value differs from its default.
  std::optional<uint16_t> NextUpid(uint32_t from, bool modified_only) const;

  size_t size() const { return slots_.size(); }

 private:
  struct Slot {
    ParamDef def;
    int64_t ram = 0;
    int64_t rom = 0;
  };
  Slot* FindSlot(uint16_t upid);
  const Slot* FindSlot(uint16_t upid) const;

  std::vector<Slot> slots_;  // sorted by UPID
};

}  // namespace drivegw::sim::linmot
