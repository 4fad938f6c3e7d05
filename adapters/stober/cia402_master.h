// Pure CiA 402 / motion-core logic of the STOBER drive (no I/O): the power state decoded from the
// status word 6041h, the control words of the power state machine (CiA 402 §6.2, as the
// simulated axis implements it, sim/stober/cia402.h), the unified DriveState from TPDO1
// (status word + I89 + I90 + packed flags, decision 1174) and the texts of I89 and I90
// (stober-motion.md §2.6, §2.8; cause numbers decision 1145). Choices: decisions 1191-1195.
#pragma once

#include <cstdint>
#include <string>

#include "adapters/core/drive.h"
#include "adapters/stober/object_map.h"

namespace drivegw::stober {

// CiA 402 power states (6041h bits 0-3, 5, 6).
enum class PowerState : uint8_t {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};
PowerState DecodePowerState(uint16_t status_word);
const char* ToString(PowerState s);  // "operation enabled"
bool IsFaultState(PowerState s);

// Control words (6040h, CiA 402 Table 35). Bit 4 is Execute (A515.4 → I402, §2.1), bit 7 the
// fault reset (also the reset of I89 = 7, decision 1147).
namespace control {
inline constexpr uint16_t kDisableVoltage = 0x0000;
inline constexpr uint16_t kShutdown = 0x0006;
inline constexpr uint16_t kSwitchOn = 0x0007;
inline constexpr uint16_t kEnableOperation = 0x000F;
inline constexpr uint16_t kExecute = 1u << 4;
inline constexpr uint16_t kFaultReset = 1u << 7;
inline constexpr uint16_t kPowerMask = 0x008F;  // bits 0-3 and 7
}  // namespace control

// The next control word that moves `from` one step towards Operation enabled (shutdown →
// switch on → enable operation); kEnableOperation when already there.
uint16_t NextEnableStep(PowerState from);

// I89 PLCopen states (§2.6; 0 = axis disabled, decision 1146).
inline constexpr int kPlcDisabled = 0;
inline constexpr int kPlcStandstill = 2;
inline constexpr int kPlcDiscrete = 3;
inline constexpr int kPlcContinuous = 4;
inline constexpr int kPlcStopping = 6;
inline constexpr int kPlcErrorStop = 7;
inline constexpr int kPlcHoming = 8;
inline constexpr int kPlcCyclic = 11;
std::string PlcStateText(int plc_state);  // "2: Standstill", "7: Error stop", "5: unknown"
// I90 cause (decision 1145) naming the rule: "position outside software limits I50..I51".
std::string CauseText(int cause);
bool IsMotionPlcState(int plc_state);  // 3, 4, 6, 11

// Unified state from a TPDO1 sample (decision 1192): CiA 402 fault → FAULT; not Operation
// enabled → DISABLED (quick stop active → MOVING while I199 = 0); Operation enabled by I89:
// 7 → FAULT, 8 → HOMING, 3/4/6/11 → MOVING, else ENABLED.
DriveState MapState(const MotionStatus& status);

// Motion-core command numbers I401 (§1.1).
namespace mc {
inline constexpr uint8_t kDoNothing = 0;
inline constexpr uint8_t kMoveAbsolute = 1;
inline constexpr uint8_t kMoveRelative = 2;
inline constexpr uint8_t kMoveAdditive = 3;
inline constexpr uint8_t kMoveVelocity = 4;
inline constexpr uint8_t kStop = 5;
inline constexpr uint8_t kHome = 6;
inline constexpr uint8_t kCyclicSpeed = 7;
inline constexpr uint8_t kMoveSpeed = 8;
inline constexpr uint8_t kTorqueControl = 9;
inline constexpr uint8_t kCyclicPosition = 10;
inline constexpr uint8_t kHalt = 11;
}  // namespace mc
const char* CommandName(uint8_t command);  // "MC_MoveAbsolute"; "MC_?" beyond 11
// Commands that never finish by themselves: Done only acknowledges the takeover (§2.7 L1415).
bool IsCyclicCommand(uint8_t command);

// How one command handle moves on a TPDO1 sample taken after its edge (§2.15, decision 1193).
struct CommandProgress {
  uint8_t command = 0;
  bool reset_seen = false;  // I91 = I92 = 0 seen after the edge (the forced-0 cycle, §2.7)
  bool active_seen = false;
};
// BUSY / ACTIVE / DONE / ERROR of the latest command for `status`; updates `progress`.
CommandState Evaluate(CommandProgress& progress, const MotionStatus& status);

}  // namespace drivegw::stober
