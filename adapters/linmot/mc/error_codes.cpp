// The LinMot MC SW error code table of linmot-mc.md §10 (MC15 list, MC22 codes named in the
// text), lookup and texts (D-33), and the absl::Status payload carrying a drive's error code.
#include "adapters/linmot/mc/error_codes.h"

#include <algorithm>
#include <iterator>

#include "absl/strings/cord.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"

namespace drivegw::linmot::mc {
namespace {

constexpr auto E = ErrorClass::kErr;
constexpr auto FE = ErrorClass::kFatalErr;
constexpr auto SE = ErrorClass::kSetupErr;
constexpr auto CE = ErrorClass::kCfgErr;
constexpr auto UE = ErrorClass::kUserErr;
constexpr auto RE = ErrorClass::kRuntimeErr;

// linmot-mc.md §10. "(+/-)" marks the phase pairs whose sign the MC15 OCR lost. Fatal = "Fatal
// Err" or "Cfg Err (fatal)" in §10.
constexpr ErrorCode kErrorCodes[] = {
    {0x0000, "No Error", false, ErrorClass::kNone},
    {0x0001, "X4 Logic Supply Too Low", false, E},
    {0x0002, "X4 Logic Supply Too High", false, E},
    {0x0003, "X1 Pwr Voltage Too Low", false, E},
    {0x0004, "X1 Pwr Voltage Too High", false, E},
    {0x0005, "X1 RR Not Connected", false, E},
    {0x0006, "PTC 1 Sensor Too Hot", false, E},
    {0x0007, "Min Pos Undershot", false, E},
    {0x0008, "Max Pos Overshot", false, E},
    {0x0009, "Ext Int Sensor Diff Err", false, E},
    {0x000A, "X12 Signals Missing", true, FE},
    {0x000B, "Pos Lag Always Too Big", false, E},
    {0x000C, "Pos Lag Standing Too Big", false, E},
    {0x000D, "X1 Pwr Over Current", true, FE},
    {0x000E, "Supply Dig Out Missing", false, E},
    {0x000F, "PTC 2 Sensor Too Hot", false, E},
    {0x0010, "Controller Ph1(+/-) Too Hot", false, E},
    {0x0011, "Controller Ph1(+/-) Too Hot", false, E},
    {0x0012, "Controller Ph2(+/-) Too Hot", false, E},
    {0x0013, "Controller Ph2(+/-) Too Hot", false, E},
    {0x0014, "Controller Pwr Too Hot", false, E},
    {0x0015, "Controller RR Hot Calc", false, E},
    {0x0016, "Controller X3 Too Hot", false, E},
    {0x0017, "Controller Core Too Hot", false, E},
    {0x0018, "Power Bridge Ph1(+/-) Defective", false, E},
    {0x0019, "Power Bridge Ph1(+/-) Defective", false, E},
    {0x001A, "Power Bridge Ph2(+/-) Defective", false, E},
    {0x001B, "Power Bridge Ph2(+/-) Defective", false, E},
    {0x001C, "Supply DigOut X6 Fuse Blown", false, E},
    {0x001D, "Supply X3.3 5V Fuse Blown", false, E},
    {0x001E, "Supply X3.8 AGND Fuse Blown", false, E},
    {0x0020, "Motor Hot Sensor", false, E},
    {0x0021, "X3 Hall Sig Missing", true, FE},
    {0x0022, "Motor Slider Missing", true, FE},
    {0x0023, "Motor Short Time Overload", false, E},
    {0x0024, "RR Hot Calculated", false, E},
    {0x0025, "Sensor Alarm On X12", false, E},
    {0x0028, "Ph1(+/-) Short Circuit To GND", false, E},
    {0x0029, "Ph1(+/-) Short Circuit To GND", false, E},
    {0x002A, "Ph2(+/-) Short Circuit To GND", false, E},
    {0x002B, "Ph2(+/-) Short Circuit To GND", false, E},
    {0x002C, "Ph1 Short Circuit To Ph2", false, E},
    {0x0030, "Ph1 Wired To Ph2", false, E},
    {0x0031, "Ph1 Wired To Ph2", false, E},
    {0x0032, "Ph1 Not Wired To Ph1", false, E},
    {0x0033, "Ph2 Wired To Ph1", false, E},
    {0x0034, "Ph2 Wired To Ph1", false, E},
    {0x0035, "Ph2 Not Wired To Ph2", false, E},
    {0x0036, "Ph1 Short Circuit To Ph2", false, E},
    {0x0037, "Ph1 Short Circuit To Ph2", false, E},
    {0x0038, "Ph2 Short Circuit To Ph1", false, E},
    {0x0039, "Ph2 Short Circuit To Ph1", false, E},
    {0x003A, "Phase U Broken", false, E},
    {0x003B, "Phase V Broken", false, E},
    {0x003C, "Phase W Broken", false, E},
    {0x0040, "X4.3 Brake Driver Error", false, E},
    {0x0041, "Dig Out X4.4..X4.11 Status", false, E},
    {0x0042, "Dig Out X6 Status", false, E},
    {0x0044, "X4 Dig Out GND Fuse Blown", false, E},
    {0x0045, "Motor Comm Lost", true, FE},
    {0x0046, "PTC 1 Broken", false, E},
    {0x0047, "PTC 1 Short To 24V", false, E},
    {0x0050, "HW Not Supported", false, SE},
    {0x0051, "SW Key Missing", false, SE},
    {0x0058, "ROM Write Error", false, RE},
    {0x005E, "Par Range Error", false, CE},
    {0x0060, "RR Voltage Set Too Low", false, CE},
    {0x0061, "RR Hysteresis < 0.5V", false, CE},
    {0x0062, "Curve Not Defined", false, CE},
    {0x0063, "Pos Ctrl Max Curr High", false, CE},
    {0x0064, "No Motor Defined", true, CE},
    {0x0065, "No Trigger Mode Defined", true, CE},
    {0x0067, "Wrong Stator Type", true, CE},
    {0x0068, "No Motor Communication", true, CE},
    {0x0069, "Wrong Slider", false, CE},
    {0x006B, "Commutation not Supp", false, CE},
    {0x0080, "Lin Not Homed", false, UE},
    {0x0081, "Unknown Motion Cmd", false, UE},
    {0x0082, "PVT Buffer Overflow", false, UE},
    {0x0083, "PVT Buffer Underflow", false, UE},
    {0x0084, "PVT Master Too Fast", false, UE},
    {0x0085, "PVT Master Too Slow", false, UE},
    {0x0086, "Motion Cmd In Wrong State", false, UE},
    {0x0087, "Limit Switch In High", false, UE},
    {0x0088, "Limit Switch Out High", false, UE},
    {0x0089, "Curve Amp Scale Error", false, UE},
    {0x008A, "Cmd Tab Entry Not Defined", false, UE},
    {0x0090, "Too Few Calculation Time For Cycle 0", false, RE},
    {0x0091, "Too Few Calculation Time For Cycle 1", false, RE},
    {0x0092, "Too Few Calculation Time For Cycle 2", false, RE},
    {0x0093, "Too Few Calculation Time For Cycle 3", false, RE},
};

constexpr bool Sorted() {
  for (size_t i = 1; i < std::size(kErrorCodes); ++i) {
    if (kErrorCodes[i - 1].code >= kErrorCodes[i].code) return false;
  }
  return true;
}
static_assert(Sorted(), "kErrorCodes must be strictly ascending");

}  // namespace

const char* ErrorClassName(ErrorClass c) {
  switch (c) {
    case ErrorClass::kNone:
      return "";
    case ErrorClass::kErr:
      return "Err";
    case ErrorClass::kFatalErr:
      return "Fatal Err";
    case ErrorClass::kSetupErr:
      return "Setup Err";
    case ErrorClass::kCfgErr:
      return "Cfg Err";
    case ErrorClass::kUserErr:
      return "User Err";
    case ErrorClass::kRuntimeErr:
      return "Runtime Err";
  }
  return "";
}

std::span<const ErrorCode> AllErrorCodes() { return kErrorCodes; }

const ErrorCode* FindErrorCode(uint16_t code) {
  const auto* end = std::end(kErrorCodes);
  const auto* it = std::lower_bound(std::begin(kErrorCodes), end, code,
                                    [](const ErrorCode& e, uint16_t c) { return e.code < c; });
  return (it != end && it->code == code) ? it : nullptr;
}

std::string ErrorText(uint16_t code) {
  const ErrorCode* e = FindErrorCode(code);
  if (e == nullptr) return absl::StrFormat("LinMot error 0x%04X", code);  // D-33
  return absl::StrFormat("%s (0x%04X)", e->text, code);
}

bool IsFatal(uint16_t code) {
  const ErrorCode* e = FindErrorCode(code);
  return e != nullptr && e->fatal;
}

void AttachErrorCode(absl::Status& status, uint16_t code) {
  if (status.ok()) return;  // an OK status carries no payload
  status.SetPayload(kErrorCodePayloadUrl, absl::Cord(absl::StrFormat("%04X", code)));
}

std::optional<uint16_t> GetErrorCode(const absl::Status& status) {
  auto payload = status.GetPayload(kErrorCodePayloadUrl);
  if (!payload.has_value()) return std::nullopt;
  uint32_t code = 0;
  if (!absl::SimpleHexAtoi(std::string(*payload), &code) || code > 0xFFFF) return std::nullopt;
  return static_cast<uint16_t>(code);
}

}  // namespace drivegw::linmot::mc
