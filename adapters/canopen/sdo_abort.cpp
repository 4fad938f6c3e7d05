// SDO abort codes (CiA 301 v4.2.0 §7.2.4.3.17, Table 22) and their mapping to absl statuses
// (decision 1104).
#include <array>
#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {
namespace {

struct AbortSpec {
  SdoAbortCode code;
  const char* description;
};

// Table 22, in table order, with its texts (lower case; "value range of parameter exceeded" is
// the older wording of 0609 0030h that most device manuals print).
constexpr std::array<AbortSpec, 31> kAborts = {{
    {SdoAbortCode::kToggleBit, "toggle bit not alternated"},
    {SdoAbortCode::kTimeout, "SDO protocol timed out"},
    {SdoAbortCode::kInvalidCommand, "client/server command specifier not valid or unknown"},
    {SdoAbortCode::kInvalidBlockSize, "invalid block size (block mode only)"},
    {SdoAbortCode::kInvalidSequence, "invalid sequence number (block mode only)"},
    {SdoAbortCode::kCrcError, "CRC error (block mode only)"},
    {SdoAbortCode::kOutOfMemory, "out of memory"},
    {SdoAbortCode::kUnsupportedAccess, "unsupported access to an object"},
    {SdoAbortCode::kWriteOnly, "attempt to read a write only object"},
    {SdoAbortCode::kReadOnly, "attempt to write a read only object"},
    {SdoAbortCode::kNoObject, "object does not exist in the object dictionary"},
    {SdoAbortCode::kNotMappable, "object cannot be mapped to the PDO"},
    {SdoAbortCode::kPdoLength,
     "the number and length of the objects to be mapped would exceed PDO length"},
    {SdoAbortCode::kParameterIncompatible, "general parameter incompatibility reason"},
    {SdoAbortCode::kInternalIncompatible, "general internal incompatibility in the device"},
    {SdoAbortCode::kHardwareError, "access failed due to a hardware error"},
    {SdoAbortCode::kLengthMismatch,
     "data type does not match, length of service parameter does not match"},
    {SdoAbortCode::kLengthTooHigh,
     "data type does not match, length of service parameter too high"},
    {SdoAbortCode::kLengthTooLow, "data type does not match, length of service parameter too low"},
    {SdoAbortCode::kNoSubIndex, "sub-index does not exist"},
    {SdoAbortCode::kValueRange, "value range of parameter exceeded"},
    {SdoAbortCode::kValueTooHigh, "value of parameter written too high"},
    {SdoAbortCode::kValueTooLow, "value of parameter written too low"},
    {SdoAbortCode::kMaxLessThanMin, "maximum value is less than minimum value"},
    {SdoAbortCode::kResourceUnavailable, "resource not available: SDO connection"},
    {SdoAbortCode::kGeneral, "general error"},
    {SdoAbortCode::kDataTransfer, "data cannot be transferred or stored to the application"},
    {SdoAbortCode::kLocalControl,
     "data cannot be transferred or stored to the application because of local control"},
    {SdoAbortCode::kDeviceState,
     "data cannot be transferred or stored to the application because of the present device "
     "state"},
    {SdoAbortCode::kNoDictionary,
     "object dictionary dynamic generation fails or no object dictionary is present"},
    {SdoAbortCode::kNoData, "no data available"},
}};

constexpr std::array<SdoAbortCode, kAborts.size()> MakeCodes() {
  std::array<SdoAbortCode, kAborts.size()> out{};
  for (size_t i = 0; i < kAborts.size(); ++i) out[i] = kAborts[i].code;
  return out;
}
constexpr std::array<SdoAbortCode, kAborts.size()> kCodes = MakeCodes();

// Status payload type URL carrying the 4 code bytes (big-endian).
constexpr char kPayloadUrl[] = "type.drivegw/canopen.SdoAbortCode";

absl::StatusCode StatusCodeFor(SdoAbortCode code) {
  const uint32_t v = static_cast<uint32_t>(code);
  switch (code) {
    case SdoAbortCode::kTimeout:
      return absl::StatusCode::kDeadlineExceeded;
    case SdoAbortCode::kNoObject:
    case SdoAbortCode::kNoSubIndex:
      return absl::StatusCode::kNotFound;
    case SdoAbortCode::kOutOfMemory:
    case SdoAbortCode::kResourceUnavailable:
      return absl::StatusCode::kResourceExhausted;
    default:
      break;
  }
  if ((v & 0xFFFF0000) == 0x06010000) return absl::StatusCode::kPermissionDenied;
  if ((v & 0xFFFFFFF0) == 0x06090030) return absl::StatusCode::kOutOfRange;
  if ((v & 0xFFFF0000) == 0x06070000 || (v & 0xFFFFFFF0) == 0x06040040) {
    return absl::StatusCode::kInvalidArgument;
  }
  if ((v & 0xFFFFFFF0) == 0x08000020) return absl::StatusCode::kFailedPrecondition;
  return absl::StatusCode::kAborted;
}

}  // namespace

std::span<const SdoAbortCode> AllAbortCodes() { return kCodes; }

bool IsKnownAbortCode(uint32_t code) {
  for (const AbortSpec& a : kAborts) {
    if (static_cast<uint32_t>(a.code) == code) return true;
  }
  return false;
}

std::string_view AbortCodeDescription(SdoAbortCode code) {
  for (const AbortSpec& a : kAborts) {
    if (a.code == code) return a.description;
  }
  return "unknown abort code";
}

std::string AbortCodeName(SdoAbortCode code) {
  return absl::StrFormat("SDO abort 0x%08X %s", static_cast<uint32_t>(code),
                         std::string(AbortCodeDescription(code)));
}

absl::Status SdoAbortStatus(SdoAbortCode code, std::string_view context) {
  absl::Status status(StatusCodeFor(code),
                      context.empty()
                          ? AbortCodeName(code)
                          : absl::StrCat(std::string(context), ": ", AbortCodeName(code)));
  const uint32_t v = static_cast<uint32_t>(code);
  const char bytes[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                         static_cast<char>(v >> 8), static_cast<char>(v)};
  status.SetPayload(kPayloadUrl, absl::Cord(std::string(bytes, 4)));
  return status;
}

std::optional<SdoAbortCode> AbortCodeOf(const absl::Status& status) {
  const auto payload = status.GetPayload(kPayloadUrl);
  if (!payload || payload->size() != 4) return std::nullopt;
  const std::string s(*payload);
  uint32_t v = 0;
  for (const char c : s) v = v << 8 | static_cast<uint8_t>(c);
  return static_cast<SdoAbortCode>(v);
}

SdoAbortCode AbortCodeForStatus(const absl::Status& status) {
  if (auto code = AbortCodeOf(status)) return *code;
  switch (status.code()) {
    case absl::StatusCode::kNotFound:
      return SdoAbortCode::kNoObject;
    case absl::StatusCode::kPermissionDenied:
      return SdoAbortCode::kUnsupportedAccess;
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kInvalidArgument:
      return SdoAbortCode::kValueRange;
    case absl::StatusCode::kFailedPrecondition:
      return SdoAbortCode::kDeviceState;
    case absl::StatusCode::kResourceExhausted:
      return SdoAbortCode::kOutOfMemory;
    case absl::StatusCode::kUnavailable:
      return SdoAbortCode::kDataTransfer;
    default:
      return SdoAbortCode::kGeneral;
  }
}

}  // namespace drivegw::canopen
