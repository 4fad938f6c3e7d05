// RTC status -> absl::Status (linmot-linudp.md §5.2, A-14).
#include "adapters/linmot/linudp/rtc_error.h"

#include "absl/strings/cord.h"
#include "absl/strings/str_format.h"
#include "adapters/linmot/linudp/codec.h"

namespace drivegw::linmot::linudp {

absl::Status RtcStatusError(const std::string& drive, const std::string& what, uint8_t status) {
  const std::string message = absl::StrFormat("drive '%s': %s: %s (RTC status 0x%02X)", drive, what,
                                              RtcStatusText(status), status);
  absl::Status s;
  switch (status) {
    case kRtcStatusUpidError:
    case kRtcStatusParameterTypeError:
    case kRtcStatusRangeError:
    case kRtcStatusOddAddress:
    case kRtcStatusSizeError:
      s = absl::InvalidArgumentError(message);
      break;
    default:
      s = absl::FailedPreconditionError(message);
  }
  s.SetPayload(kRtcStatusPayloadUrl, absl::Cord(absl::StrFormat("%02X", status)));
  return s;
}

}  // namespace drivegw::linmot::linudp
