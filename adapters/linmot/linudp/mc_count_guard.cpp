// MC count guard (mc_count_guard.h, decision 1461).
#include "adapters/linmot/linudp/mc_count_guard.h"

namespace drivegw::linmot::linudp {

void McCountGuard::Arm(uint8_t count, std::optional<uint8_t> drive_echo) {
  count &= 0x0F;
  if (current_ && *current_ != count) superseded_ |= Bit(*current_);
  superseded_ &= static_cast<uint16_t>(~Bit(count));  // the count is live again
  current_ = count;
  echoed_ = false;
  base_.reset();
  if (drive_echo) base_ = static_cast<uint8_t>(*drive_echo & 0x0F);
}

McCountGuard::Verdict McCountGuard::OnEcho(uint8_t echo) {
  echo &= 0x0F;
  if (!current_) return Verdict::kNone;
  if (echo == *current_) {
    echoed_ = true;
    return Verdict::kEcho;
  }
  if (echo == 0 || (superseded_ & Bit(echo)) == 0) return Verdict::kNone;
  // Not yet echoed: the drive may still show the count it held when the block was armed; when
  // that is unknown, nothing can be told apart.
  if (!echoed_ && (!base_ || echo == *base_)) return Verdict::kNone;
  // The drive went to an older count of ours: our telegrams carry only the current block, and
  // an older block travelled only until its own echo, so a telegram sent before that echo was
  // delivered late and executed (decision 1461).
  Arm(echo, std::nullopt);
  echoed_ = true;
  return Verdict::kStale;
}

}  // namespace drivegw::linmot::linudp
