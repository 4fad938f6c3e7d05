// CANopen emergency object (EMCY): COB-ID 080h + n, 8 bytes = error code (u16 LE), error register
// (1001h, u8) and 5 manufacturer-specific bytes; the CiA 301 error code classes with names.
// Pure (no I/O).
// Source: CiA 301 v4.2.0 §7.2.7.3.1 (EMCY write, Figure 40 frame layout), Table 21 (emergency
// error codes), §7.5.2.2 (1001h error register bits); CiA 402-2 Table "error codes" (8611h
// following error, 8612h reference limit).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::canopen {

// Error register 1001h bits (§7.5.2.2).
namespace error_register {
inline constexpr uint8_t kGeneric = 0x01;
inline constexpr uint8_t kCurrent = 0x02;
inline constexpr uint8_t kVoltage = 0x04;
inline constexpr uint8_t kTemperature = 0x08;
inline constexpr uint8_t kCommunication = 0x10;
inline constexpr uint8_t kDeviceProfile = 0x20;
inline constexpr uint8_t kManufacturer = 0x80;
}  // namespace error_register

// Well-known error codes (Table 21 and CiA 402).
namespace emcy_code {
inline constexpr uint16_t kNoError = 0x0000;  // "error reset or no error"
inline constexpr uint16_t kGeneric = 0x1000;
inline constexpr uint16_t kCanOverrun = 0x8110;
inline constexpr uint16_t kCanErrorPassive = 0x8120;
inline constexpr uint16_t kLifeGuardHeartbeat = 0x8130;
inline constexpr uint16_t kRecoveredFromBusOff = 0x8140;
inline constexpr uint16_t kCanIdCollision = 0x8150;
inline constexpr uint16_t kPdoLengthError = 0x8210;
inline constexpr uint16_t kPdoLengthExceeded = 0x8220;
inline constexpr uint16_t kUnexpectedSyncLength = 0x8240;
inline constexpr uint16_t kRpdoTimeout = 0x8250;
inline constexpr uint16_t kFollowingError = 0x8611;  // CiA 402
inline constexpr uint16_t kDeviceSpecific = 0xFF00;
}  // namespace emcy_code

// The class an error code belongs to: the high nibble, or the high byte for 10xxh, F0xxh, FFxxh.
enum class EmcyClass : uint8_t {
  kNoError,              // 0000h (00xxh)
  kGeneric,              // 10xxh
  kCurrent,              // 2xxxh
  kVoltage,              // 3xxxh
  kTemperature,          // 4xxxh
  kHardware,             // 5xxxh
  kSoftware,             // 6xxxh
  kAdditionalModules,    // 7xxxh
  kMonitoring,           // 8xxxh (communication 81xxh, protocol 82xxh, CiA 402 84xxh..86xxh)
  kExternal,             // 9xxxh
  kAdditionalFunctions,  // F0xxh
  kDeviceSpecific,       // FFxxh
  kReserved,             // everything Table 21 leaves unassigned (e.g. 11xxh, Axxxh..Exxxh)
};
EmcyClass ClassOfEmcyCode(uint16_t code);
// "no error", "generic", "current", "voltage", "temperature", "device hardware", "device
// software", "additional modules", "monitoring", "external", "additional functions",
// "device specific", "reserved".
std::string_view EmcyClassName(EmcyClass emcy_class);
// "EMCY 0x8130 life guard error or heartbeat error"; for codes without an own entry the class:
// "EMCY 0x2345 current (class 2xxxh)".
std::string EmcyCodeName(uint16_t code);

struct Emcy {
  uint8_t node = 1;  // from the COB-ID 080h + n
  uint16_t error_code = 0;
  uint8_t error_register = 0;             // 1001h
  std::array<uint8_t, 5> manufacturer{};  // bytes 3..7
  friend bool operator==(const Emcy&, const Emcy&) = default;
};

// COB-ID 080h + node (1..127), DLC 8.
absl::StatusOr<transport::CanFrame> EncodeEmcy(const Emcy& emcy);
// Identifier 081h..0FFh, DLC 8 (decision 1106: shorter frames from non-conforming devices are
// accepted down to 3 bytes, the missing manufacturer bytes read 00). InvalidArgument otherwise.
absl::StatusOr<Emcy> DecodeEmcy(const transport::CanFrame& frame);

}  // namespace drivegw::canopen
