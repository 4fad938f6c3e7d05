// The LinUDP curve service sequences (linmot-linudp.md §5.3 0x50-0x62, §5.4 L350-L351): download
// with read-back verification and upload of one curve, over any RTC transaction function (the
// drive passes its own: count handshake, busy wait, time-out; ).
// docs/decisions/707-linudp-curve-download-run.md.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/linudp/curve_info_block.h"

namespace drivegw::linmot::linudp {

// One RTC command, answered once the drive is no longer busy (0x02/0x05, linudp 5.1.3); the
// reply's status may be 0x04 or an error (>= 0xC0). `what` names the step for errors.
using RtcTransaction = std::function<absl::StatusOr<RtcReply>(
    uint8_t command_id, uint16_t word2, uint16_t word3, uint16_t word4, const std::string& what)>;

class CurveService {
 public:
  CurveService(std::string drive_name, RtcTransaction transact)
      : drive_(std::move(drive_name)), transact_(std::move(transact)) {}

  // 0x50 (sizes) -> 0x51 x ceil(70 / 4) -> 0x52 per point; a curve the drive already holds
  // (0xD4 at 0x50) is replaced in place with 0x53/0x54/0x55 (decision 707). Every block but the
  // last must answer 0x04, the last 0x00. Then Upload and compare: DataLoss naming the first
  // differing field or point. Errors name the step and the curve ID.
  absl::Status Download(const WireCurve& curve);
  // 0x60 -> 0x61 x ceil(info / 4) -> 0x62 per point (the count from the info block). NotFound
  // when the drive holds no curve under `curve_id` (0xD4 at 0x60).
  absl::StatusOr<WireCurve> Upload(uint16_t curve_id);

 private:
  // The reply of one step; an RTC error status becomes an error naming the step.
  absl::StatusOr<RtcReply> Step(uint8_t command_id, uint16_t curve_id, uint16_t word3,
                                uint16_t word4, const std::string& what);
  // Sends `bytes` 4 per telegram with `command_id`; `last` = these are the transfer's final
  // blocks (the last one must answer 0x00, all others 0x04).
  absl::Status SendBlocks(uint8_t command_id, uint16_t curve_id, const std::vector<uint8_t>& bytes,
                          bool last, const char* what);

  const std::string drive_;
  RtcTransaction transact_;
};

}  // namespace drivegw::linmot::linudp
