// Classic CAN frame (11/29-bit identifier, up to 8 data bytes, RTR, error) and its limits.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "absl/status/status.h"

namespace drivegw::transport {

// ISO 11898-1: base format identifiers have 11 bits, extended format 29 bits.
inline constexpr uint32_t kCanStandardIdMax = 0x7FF;
inline constexpr uint32_t kCanExtendedIdMax = 0x1FFFFFFF;
// Classic CAN carries at most 8 data bytes (CAN FD is out of scope, docs/decisions/801).
inline constexpr uint8_t kCanMaxDlc = 8;

struct CanFrame {
  // Base (11-bit) or extended (29-bit) identifier, without any flag bits. For an error frame
  // (error=true) the error class bits, as SocketCAN reports them in can_id (linux/can/error.h).
  uint32_t id = 0;
  bool extended = false;  // 29-bit identifier
  bool rtr = false;       // remote transmission request: dlc is the requested length, no data
  bool error = false;     // error frame reported by the controller/driver, never sent
  uint8_t dlc = 0;        // 0..8
  std::array<uint8_t, 8> data{};

  // The first dlc bytes (none for RTR frames); dlc above 8 is cut to 8.
  std::span<const uint8_t> payload() const {
    return rtr ? std::span<const uint8_t>()
               : std::span<const uint8_t>(data.data(), dlc > 8 ? 8 : dlc);
  }

  friend bool operator==(const CanFrame&, const CanFrame&) = default;
};

// A data frame with `bytes` (at most 8; more is an InvalidArgument from ValidateCanFrame,
// here the extra bytes are dropped and dlc says 8).
CanFrame MakeCanFrame(uint32_t id, std::span<const uint8_t> bytes, bool extended = false);
// A remote frame asking for `dlc` bytes.
CanFrame MakeCanRtrFrame(uint32_t id, uint8_t dlc, bool extended = false);

// OK when the frame can go on the wire: id within 11 or 29 bits, dlc <= 8, not an error
// frame. InvalidArgument naming the field and the limit otherwise, e.g.
// "can frame.id: 0x800 exceeds 0x7FF (11-bit base format)".
absl::Status ValidateCanFrame(const CanFrame& frame);

// candump's compact body: "42E#004B030103", "1ABCDEF0#R", "123#R3" (RTR with length 3),
// "20000040#0000000000000000" (error frame: CAN_ERR_FLAG | class, as candump -l prints it).
// Extended and error ids are 8 hex digits, base ids 3 (can-utils lib.c sprint_canframe).
std::string FormatCanFrame(const CanFrame& frame);

}  // namespace drivegw::transport
