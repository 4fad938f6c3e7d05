// CANopen SYNC object: COB-ID 080h (1005h), DLC 0, or DLC 1 with a counter 1..240 when the
// synchronous counter overflow value (1019h) is 2..240. Pure (no I/O).
// Source: CiA 301 v4.2.0 §7.2.5 (SYNC protocol, counter), §7.5.2.5 (1005h), §7.5.2.22 (1019h).
#pragma once

#include <cstdint>
#include <optional>

#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::canopen {

inline constexpr uint16_t kSyncCobId = 0x080;
// 1019h: 0 = no counter; 1 and 241..255 reserved; 2..240 = counter runs 1..overflow.
inline constexpr uint8_t kSyncCounterMax = 240;

struct Sync {
  std::optional<uint8_t> counter;  // 1..240 when present
  friend bool operator==(const Sync&, const Sync&) = default;
};

// DLC 0 without counter, DLC 1 with it; "canopen sync.counter: 0 outside 1..240".
absl::StatusOr<transport::CanFrame> EncodeSync(const Sync& sync, uint16_t cob_id = kSyncCobId);
// InvalidArgument for another identifier, RTR/extended frames, DLC > 1 or a counter outside
// 1..240.
absl::StatusOr<Sync> DecodeSync(const transport::CanFrame& frame, uint16_t cob_id = kSyncCobId);

// The counter after `counter` with 1019h = `overflow` (2..240): counter + 1, back to 1 after
// `overflow` (§7.2.5.2). A counter of 0 (not started) yields 1.
uint8_t NextSyncCounter(uint8_t counter, uint8_t overflow);

}  // namespace drivegw::canopen
