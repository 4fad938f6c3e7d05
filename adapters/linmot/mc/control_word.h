// LinMot MC SW control word (master -> drive): bit masks and the recommended words (linmot-mc.md
// §3.1, §2.7).
#pragma once

#include <cstdint>

namespace drivegw::linmot::mc {

// Bits of the 16-bit control word, linmot-mc.md §3.1 (MC22 L634-672). Names ending in N are
// active low: the stop function acts while the bit is 0.
inline constexpr uint16_t kSwitchOn = 1u << 0;              // level; 0 = OFF1 (A-stop)
inline constexpr uint16_t kVoltageEnable = 1u << 1;         // level; 0 = OFF2
inline constexpr uint16_t kQuickStopN = 1u << 2;            // level; 0 = OFF3 (quick stop)
inline constexpr uint16_t kEnableOperation = 1u << 3;       // level; 0 -> state 6
inline constexpr uint16_t kAbortN = 1u << 4;                // level; 0 -> state 12, command cleared
inline constexpr uint16_t kFreezeN = 1u << 5;               // level; rising edge resumes (§2.4)
inline constexpr uint16_t kGoToPosition = 1u << 6;          // level
inline constexpr uint16_t kErrorAcknowledge = 1u << 7;      // rising edge only (§2.4)
inline constexpr uint16_t kJogPlus = 1u << 8;               // level
inline constexpr uint16_t kJogMinus = 1u << 9;              // level
inline constexpr uint16_t kSpecialMode = 1u << 10;          // B1100 only; never set (D-07)
inline constexpr uint16_t kHome = 1u << 11;                 // level
inline constexpr uint16_t kClearanceCheck = 1u << 12;       // level
inline constexpr uint16_t kGoToInitialPosition = 1u << 13;  // rising edge starts it
inline constexpr uint16_t kReservedBit14 = 1u << 14;
inline constexpr uint16_t kPhaseSearch = 1u << 15;  // level; never set by the gateway (D-07)

// Bits that must be 1 for normal operation (§2.7): Voltage Enable, /Quick Stop, /Abort, /Freeze.
inline constexpr uint16_t kOperationalBits = kVoltageEnable | kQuickStopN | kAbortN | kFreezeN;

// Recommended words of linmot-mc.md §2.7.
inline constexpr uint16_t kAllOff = 0x0000;       // step 1a: release anti-restart (state 0 -> 1)
inline constexpr uint16_t kSwitchedOff = 0x003E;  // step 1b / 7: kOperational without Switch On
inline constexpr uint16_t kOperational = 0x003F;  // step 2 / 4: switch on and run commands
inline constexpr uint16_t kHoming = 0x083F;       // step 3: kOperational | kHome
inline constexpr uint16_t kAcknowledge = 0x00BF;  // step 5: kOperational | kErrorAcknowledge
inline constexpr uint16_t kOperationDisabled = 0x0037;  // step 6: clear Enable Operation (-> 6)

static_assert(kSwitchedOff == (kOperational & ~kSwitchOn));
static_assert(kOperational == (kOperationalBits | kSwitchOn | kEnableOperation));
static_assert(kHoming == (kOperational | kHome));
static_assert(kAcknowledge == (kOperational | kErrorAcknowledge));
static_assert(kOperationDisabled == (kOperational & ~kEnableOperation));

}  // namespace drivegw::linmot::mc
