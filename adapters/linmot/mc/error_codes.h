// LinMot MC SW error codes: the §10 table, lookup, text, and the payload carrying a drive fault.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace drivegw::linmot::mc {

// Error class prefix as LinMot prints it (linmot-mc.md §10).
enum class ErrorClass : uint8_t {
  kNone,
  kErr,
  kFatalErr,
  kSetupErr,
  kCfgErr,
  kUserErr,
  kRuntimeErr
};
const char* ErrorClassName(ErrorClass c);  // "Err", "Fatal Err", ...

struct ErrorCode {
  uint16_t code;
  const char* text;  // LinMot's name, e.g. "Unknown Motion Cmd"
  bool fatal;        // cannot be acknowledged (status word bit 12)
  ErrorClass error_class;
};

// Named codes (linmot-mc.md §10) that simulators raise and gateways react to.
inline constexpr uint16_t kNoError = 0x0000;
inline constexpr uint16_t kLogicSupplyTooLow = 0x0001;
inline constexpr uint16_t kLogicSupplyTooHigh = 0x0002;
inline constexpr uint16_t kPwrVoltageTooLow = 0x0003;
inline constexpr uint16_t kPwrVoltageTooHigh = 0x0004;
inline constexpr uint16_t kPtc1SensorTooHot = 0x0006;
inline constexpr uint16_t kMinPosUndershot = 0x0007;
inline constexpr uint16_t kMaxPosOvershot = 0x0008;
inline constexpr uint16_t kPosLagAlwaysTooBig = 0x000B;
inline constexpr uint16_t kPosLagStandingTooBig = 0x000C;
inline constexpr uint16_t kPwrOverCurrent = 0x000D;  // fatal (LMC-09)
inline constexpr uint16_t kControllerRrHotCalc = 0x0015;
inline constexpr uint16_t kMotorHotSensor = 0x0020;
inline constexpr uint16_t kMotorShortTimeOverload = 0x0023;
inline constexpr uint16_t kRrHotCalculated = 0x0024;
inline constexpr uint16_t kParRangeError = 0x005E;
inline constexpr uint16_t kCurveNotDefined = 0x0062;
inline constexpr uint16_t kLinNotHomed = 0x0080;
inline constexpr uint16_t kUnknownMotionCommand = 0x0081;
inline constexpr uint16_t kPvtBufferOverflow = 0x0082;
inline constexpr uint16_t kPvtBufferUnderflow = 0x0083;
inline constexpr uint16_t kPvtMasterTooFast = 0x0084;
inline constexpr uint16_t kPvtMasterTooSlow = 0x0085;
inline constexpr uint16_t kMotionCommandInWrongState = 0x0086;
inline constexpr uint16_t kLimitSwitchInHigh = 0x0087;
inline constexpr uint16_t kLimitSwitchOutHigh = 0x0088;
inline constexpr uint16_t kCurveAmpScaleError = 0x0089;
inline constexpr uint16_t kCmdTabEntryNotDefined = 0x008A;
inline constexpr uint16_t kTooFewCalculationTimeCycle0 = 0x0090;

// Every code of linmot-mc.md §10, ascending (ranges such as 0030h/0031h are listed per code).
std::span<const ErrorCode> AllErrorCodes();
// nullptr if the code is not in the table.
const ErrorCode* FindErrorCode(uint16_t code);
// "Unknown Motion Cmd (0x0081)" for known codes, "LinMot error 0xNNNN" otherwise (D-33).
std::string ErrorText(uint16_t code);
// Fatal per the table; unknown codes are not fatal (the status word bit 12 is authoritative).
bool IsFatal(uint16_t code);

// A LinMot error code riding on an absl::Status (STYLE.md §6 "Errors"): payload under this type
// URL, value = the code as 4 upper-case hex digits ("0081").
inline constexpr char kErrorCodePayloadUrl[] = "type.drivegw.dev/linmot.mc.ErrorCode";
void AttachErrorCode(absl::Status& status, uint16_t code);
std::optional<uint16_t> GetErrorCode(const absl::Status& status);

}  // namespace drivegw::linmot::mc
