// EMCY frames and error code names (CiA 301 v4.2.0 §7.2.7.3.1, Table 21; CiA 402-2 error codes).
#include "adapters/canopen/emcy.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"

namespace drivegw::canopen {
namespace {

constexpr uint16_t kEmcyBase = 0x080;
constexpr size_t kEmcySize = 8;
constexpr size_t kEmcyMinSize = 3;  // error code + error register (decision 1106)

struct CodeName {
  uint16_t code;
  const char* name;
};

// Table 21 entries with their own text, plus the CiA 402 codes drives commonly send.
constexpr CodeName kCodeNames[] = {
    {0x0000, "error reset or no error"},
    {0x1000, "generic error"},
    {0x2000, "current, generic error"},
    {0x2100, "current, device input side"},
    {0x2200, "current inside the device"},
    {0x2300, "current, device output side"},
    {0x2310, "continuous over current"},        // CiA 402
    {0x2320, "short circuit / earth leakage"},  // CiA 402
    {0x3000, "voltage, generic error"},
    {0x3100, "mains voltage"},
    {0x3200, "voltage inside the device"},
    {0x3210, "DC link over-voltage"},   // CiA 402
    {0x3220, "DC link under-voltage"},  // CiA 402
    {0x3300, "output voltage"},
    {0x4000, "temperature, generic error"},
    {0x4100, "ambient temperature"},
    {0x4200, "device temperature"},
    {0x4310, "drive excess temperature"},  // CiA 402
    {0x5000, "device hardware"},
    {0x6000, "device software, generic error"},
    {0x6100, "internal software"},
    {0x6200, "user software"},
    {0x6300, "data set"},
    {0x7000, "additional modules"},
    {0x7300, "sensor"},  // CiA 402
    {0x8000, "monitoring, generic error"},
    {0x8100, "communication, generic error"},
    {0x8110, "CAN overrun (objects lost)"},
    {0x8120, "CAN in error passive mode"},
    {0x8130, "life guard error or heartbeat error"},
    {0x8140, "recovered from bus off"},
    {0x8150, "CAN-ID collision"},
    {0x8200, "protocol error, generic error"},
    {0x8210, "PDO not processed due to length error"},
    {0x8220, "PDO length exceeded"},
    {0x8230, "DAM MPDO not processed, destination object not available"},
    {0x8240, "unexpected SYNC data length"},
    {0x8250, "RPDO timeout"},
    {0x8400, "velocity speed controller"},  // CiA 402
    {0x8500, "position controller"},        // CiA 402
    {0x8600, "positioning controller"},     // CiA 402
    {0x8611, "following error"},            // CiA 402
    {0x8612, "reference limit"},            // CiA 402
    {0x9000, "external error, generic error"},
    {0xF000, "additional functions, generic error"},
    {0xFF00, "device specific, generic error"},
};

}  // namespace

EmcyClass ClassOfEmcyCode(uint16_t code) {
  const uint8_t high = static_cast<uint8_t>(code >> 8);
  if (high == 0x00) return EmcyClass::kNoError;
  if (high == 0x10) return EmcyClass::kGeneric;
  if (high == 0xF0) return EmcyClass::kAdditionalFunctions;
  if (high == 0xFF) return EmcyClass::kDeviceSpecific;
  switch (code >> 12) {
    case 0x2:
      return EmcyClass::kCurrent;
    case 0x3:
      return EmcyClass::kVoltage;
    case 0x4:
      return EmcyClass::kTemperature;
    case 0x5:
      return EmcyClass::kHardware;
    case 0x6:
      return EmcyClass::kSoftware;
    case 0x7:
      return EmcyClass::kAdditionalModules;
    case 0x8:
      return EmcyClass::kMonitoring;
    case 0x9:
      return EmcyClass::kExternal;
    default:
      return EmcyClass::kReserved;
  }
}

std::string_view EmcyClassName(EmcyClass emcy_class) {
  switch (emcy_class) {
    case EmcyClass::kNoError:
      return "no error";
    case EmcyClass::kGeneric:
      return "generic";
    case EmcyClass::kCurrent:
      return "current";
    case EmcyClass::kVoltage:
      return "voltage";
    case EmcyClass::kTemperature:
      return "temperature";
    case EmcyClass::kHardware:
      return "device hardware";
    case EmcyClass::kSoftware:
      return "device software";
    case EmcyClass::kAdditionalModules:
      return "additional modules";
    case EmcyClass::kMonitoring:
      return "monitoring";
    case EmcyClass::kExternal:
      return "external";
    case EmcyClass::kAdditionalFunctions:
      return "additional functions";
    case EmcyClass::kDeviceSpecific:
      return "device specific";
    case EmcyClass::kReserved:
      return "reserved";
  }
  return "reserved";
}

std::string EmcyCodeName(uint16_t code) {
  for (const CodeName& c : kCodeNames) {
    if (c.code == code) return absl::StrFormat("EMCY 0x%04X %s", code, c.name);
  }
  const EmcyClass cls = ClassOfEmcyCode(code);
  std::string pattern;
  switch (cls) {
    case EmcyClass::kNoError:
      pattern = "00xxh";
      break;
    case EmcyClass::kGeneric:
      pattern = "10xxh";
      break;
    case EmcyClass::kAdditionalFunctions:
      pattern = "F0xxh";
      break;
    case EmcyClass::kDeviceSpecific:
      pattern = "FFxxh";
      break;
    default:
      pattern = absl::StrFormat("%Xxxxh", code >> 12);
  }
  return absl::StrFormat("EMCY 0x%04X %s (class %s)", code, std::string(EmcyClassName(cls)),
                         pattern);
}

absl::StatusOr<transport::CanFrame> EncodeEmcy(const Emcy& emcy) {
  if (auto s = ValidateNodeId(emcy.node, "emcy.node_id"); !s.ok()) return s;
  std::array<uint8_t, kEmcySize> bytes{};
  bytes[0] = static_cast<uint8_t>(emcy.error_code);
  bytes[1] = static_cast<uint8_t>(emcy.error_code >> 8);
  bytes[2] = emcy.error_register;
  std::copy(emcy.manufacturer.begin(), emcy.manufacturer.end(), bytes.begin() + 3);
  return transport::MakeCanFrame(kEmcyBase + emcy.node, bytes);
}

absl::StatusOr<Emcy> DecodeEmcy(const transport::CanFrame& frame) {
  if (frame.extended || frame.rtr || frame.error) {
    return absl::InvalidArgumentError(
        "canopen emcy: needs a base-format data frame (no RTR, extended, error)");
  }
  if (frame.id <= kEmcyBase || frame.id > kEmcyBase + kMaxNodeId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen emcy: cob id 0x%03X outside 0x081..0x0FF", frame.id));
  }
  const auto payload = frame.payload();
  if (payload.size() < kEmcyMinSize) {
    return absl::InvalidArgumentError(absl::StrCat("canopen emcy.dlc: ", payload.size(),
                                                   " bytes, need ", kEmcySize, " (at least ",
                                                   kEmcyMinSize, ")"));
  }
  Emcy out;
  out.node = static_cast<uint8_t>(frame.id - kEmcyBase);
  out.error_code = static_cast<uint16_t>(payload[0] | payload[1] << 8);
  out.error_register = payload[2];
  std::copy(payload.begin() + 3, payload.end(), out.manufacturer.begin());
  return out;
}

}  // namespace drivegw::canopen
