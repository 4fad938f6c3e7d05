// SYNC object (CiA 301 v4.2.0 §7.2.5, 1005h, 1019h).
#include "adapters/canopen/sync.h"

#include <array>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::canopen {

absl::StatusOr<transport::CanFrame> EncodeSync(const Sync& sync, uint16_t cob_id) {
  if (cob_id > 0x7FF) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen sync.cob_id: 0x%X exceeds 0x7FF", cob_id));
  }
  if (!sync.counter) return transport::MakeCanFrame(cob_id, {});
  if (*sync.counter < 1 || *sync.counter > kSyncCounterMax) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen sync.counter: ", *sync.counter, " outside 1..", kSyncCounterMax));
  }
  const std::array<uint8_t, 1> bytes = {*sync.counter};
  return transport::MakeCanFrame(cob_id, bytes);
}

absl::StatusOr<Sync> DecodeSync(const transport::CanFrame& frame, uint16_t cob_id) {
  if (frame.extended || frame.rtr || frame.error || frame.id != cob_id) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "canopen sync: frame 0x%X is no SYNC data frame on 0x%03X", frame.id, cob_id));
  }
  if (frame.dlc > 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen sync.dlc: ", frame.dlc, " bytes exceed 1"));
  }
  Sync out;
  if (frame.dlc == 1) {
    const uint8_t c = frame.data[0];
    if (c < 1 || c > kSyncCounterMax) {
      return absl::InvalidArgumentError(
          absl::StrCat("canopen sync.counter: ", c, " outside 1..", kSyncCounterMax));
    }
    out.counter = c;
  }
  return out;
}

uint8_t NextSyncCounter(uint8_t counter, uint8_t overflow) {
  // §7.2.5.2: the counter starts at 1 and is reset to 1 after reaching the overflow value.
  if (overflow < 2) overflow = 2;
  if (overflow > kSyncCounterMax) overflow = kSyncCounterMax;
  if (counter == 0 || counter >= overflow) return 1;
  return static_cast<uint8_t>(counter + 1);
}

}  // namespace drivegw::canopen
