// CanFrame construction, wire validation and candump's compact text form.
#include "adapters/transport/can_frame.h"

#include <algorithm>
#include <cstdio>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {
namespace {

std::string Hex(uint32_t value) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "0x%X", value);
  return buf;
}

// linux/can.h: CAN_ERR_FLAG marks error frames in can_id; candump -l prints it with the class.
constexpr uint32_t kCanErrFlag = 0x20000000;

}  // namespace

CanFrame MakeCanFrame(uint32_t id, std::span<const uint8_t> bytes, bool extended) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<uint8_t>(std::min<size_t>(bytes.size(), kCanMaxDlc));
  std::copy_n(bytes.begin(), f.dlc, f.data.begin());
  return f;
}

CanFrame MakeCanRtrFrame(uint32_t id, uint8_t dlc, bool extended) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.rtr = true;
  f.dlc = dlc;
  return f;
}

absl::Status ValidateCanFrame(const CanFrame& frame) {
  if (frame.error) {
    return absl::InvalidArgumentError(
        "can frame.error: error frames are reported by the controller and cannot be sent");
  }
  if (frame.extended && frame.id > kCanExtendedIdMax) {
    return absl::InvalidArgumentError(absl::StrCat("can frame.id: ", Hex(frame.id), " exceeds ",
                                                   Hex(kCanExtendedIdMax),
                                                   " (29-bit extended format)"));
  }
  if (!frame.extended && frame.id > kCanStandardIdMax) {
    return absl::InvalidArgumentError(absl::StrCat("can frame.id: ", Hex(frame.id), " exceeds ",
                                                   Hex(kCanStandardIdMax),
                                                   " (11-bit base format)"));
  }
  if (frame.dlc > kCanMaxDlc) {
    return absl::InvalidArgumentError(
        absl::StrCat("can frame.dlc: ", frame.dlc, " exceeds ", kCanMaxDlc, " (classic CAN)"));
  }
  return absl::OkStatus();
}

std::string FormatCanFrame(const CanFrame& frame) {
  // can-utils lib.c sprint_canframe: "%03X" base ids, "%08X" extended and error ids,
  // upper-case data bytes without separators, "R" plus the length digit for RTR.
  char buf[64];
  int n = 0;
  if (frame.error) {
    n = std::snprintf(buf, sizeof(buf), "%08X#", (frame.id & kCanExtendedIdMax) | kCanErrFlag);
  } else if (frame.extended) {
    n = std::snprintf(buf, sizeof(buf), "%08X#", frame.id & kCanExtendedIdMax);
  } else {
    n = std::snprintf(buf, sizeof(buf), "%03X#", frame.id & kCanStandardIdMax);
  }
  std::string out(buf, static_cast<size_t>(n));
  if (frame.rtr) {
    out += 'R';
    if (frame.dlc > 0 && frame.dlc <= kCanMaxDlc) out += static_cast<char>('0' + frame.dlc);
    return out;
  }
  static constexpr char kDigits[] = "0123456789ABCDEF";
  for (const uint8_t b : frame.payload()) {
    out += kDigits[b >> 4];
    out += kDigits[b & 0xF];
  }
  return out;
}

}  // namespace drivegw::transport
