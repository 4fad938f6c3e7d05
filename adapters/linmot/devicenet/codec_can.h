// Conversion between the codec's DeviceNet Frame and adapters/transport's CanFrame; header-only
// so that the codec library stays free of transport code (decision 901).
#pragma once

#include <algorithm>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::linmot::devicenet {

// A DeviceNet frame as a classic CAN base-format data frame.
inline transport::CanFrame ToCanFrame(const Frame& frame) {
  transport::CanFrame out;
  out.id = frame.id;
  out.dlc = static_cast<uint8_t>(frame.payload().size());
  std::copy(frame.payload().begin(), frame.payload().end(), out.data.begin());
  return out;
}

// DeviceNet uses 11-bit data frames only (linmot-devicenet.md §5.1): extended, remote and error
// frames, identifiers above 0x7FF and DLC above 8 are InvalidArgument naming the field.
inline absl::StatusOr<Frame> FromCanFrame(const transport::CanFrame& frame) {
  if (frame.error) return absl::InvalidArgumentError("devicenet frame: error frame, not data");
  if (frame.extended) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "devicenet frame.id: extended identifier 0x%08X, DeviceNet uses 11 bits", frame.id));
  }
  if (frame.rtr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("devicenet frame: remote frame on 0x%03X, DeviceNet has none", frame.id));
  }
  if (frame.dlc > kMaxFrameData) {
    return absl::InvalidArgumentError(
        absl::StrCat("devicenet frame.dlc: ", frame.dlc, " exceeds ", kMaxFrameData));
  }
  if (frame.id > kMaxIdentifier) {
    return absl::InvalidArgumentError(
        absl::StrFormat("devicenet frame.id: 0x%X exceeds 11 bits (0x7FF)", frame.id));
  }
  return MakeFrame(static_cast<uint16_t>(frame.id), frame.payload());
}

}  // namespace drivegw::linmot::devicenet
