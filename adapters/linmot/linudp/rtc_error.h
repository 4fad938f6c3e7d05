// The absl::Status of an RTC command the drive refused (linmot-linudp.md §5.2, A-14): the
// manual's text, the raw status in the message and as payload (STYLE.md §6 "Errors").
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"

namespace drivegw::linmot::linudp {

// Payload type URL carrying the raw RTC status (2 hex digits).
inline constexpr char kRtcStatusPayloadUrl[] = "type.drivegw.dev/linmot.linudp.RtcStatus";

// "drive 'x1': <what>: Range Error (RTC status 0xC2)". Codes that reject the request itself
// (0xC0-0xC2, 0xD0, 0xD1) -> InvalidArgument; codes about the drive's state or the parameter's
// use -> FailedPrecondition.
absl::Status RtcStatusError(const std::string& drive, const std::string& what, uint8_t status);

}  // namespace drivegw::linmot::linudp
