// The LinUDP realtime-configuration (RTC) parameter channel of the simulated drive (linudp §5,
// count handshake, parameter access, UPID lists, error log.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/codec.h"
#include "sim/linmot/error_log.h"
#include "sim/linmot/options.h"
#include "sim/linmot/parameters.h"

namespace drivegw::sim::linmot {

// What the device has to do after an RTC command besides replying.
enum class RtcEffect {
  kNone,
  kRestart,  // 0x30: stop answering for the boot time, then power up
  kStopMc,   // 0x35
  kStartMc,  // 0x36
};

struct RtcResult {
  linudp::RtcReply reply;
  RtcEffect effect = RtcEffect::kNone;
};

// Everything an RTC command may read or change on the device.
struct RtcContext {
  Parameters& params;
  const ErrorLog& error_log;
  bool mc_stopped = false;
  Duration now{0};  // simulated time, for the flash-save duration
};

class RtcChannel {
 public:
  explicit RtcChannel(const SimOptions& options)
      : busy_telegrams_(options.rtc_busy_telegrams), flash_save_time_(options.flash_save_time) {}

  // count reference 0 and an all-zero last reply after boot.
  void PowerUp();

  // One telegram: `request` is the RTC block if present. A new count executes the command; the
  // same count (or no block) repeats the last result. The reply is always the one to send.
  RtcResult Handle(const std::optional<linudp::RtcRequest>& request, RtcContext& ctx);

  uint8_t count() const { return count_; }
  uint64_t commands() const { return commands_; }
  const linudp::RtcReply& last_reply() const { return last_; }

  // Curve storage (0x40-0x62): the bytes as the master sent them (decision 603 §9); the layout
  // is adapters/linmot/linudp/curve_info_block.h (decision 706).
  struct StoredCurve {
    std::vector<uint8_t> info;
    std::vector<uint8_t> data;
  };
  // nullptr when no curve is stored under `curve_id`.
  const StoredCurve* FindCurve(uint16_t curve_id) const;
  // Fault injection (decision 607): the next curve whose transfer completes is stored with set
  // point `index` changed (its lowest byte incremented); an index beyond the points changes
  // nothing.
  void CorruptNextStoredPoint(size_t index) { corrupt_next_point_ = index; }

 private:
  RtcResult Execute(const linudp::RtcRequest& request, RtcContext& ctx);
  linudp::RtcReply Parameter(const linudp::RtcRequest& request, RtcContext& ctx);
  linudp::RtcReply CommandTable(const linudp::RtcRequest& request, RtcContext& ctx);
  linudp::RtcReply Curve(const linudp::RtcRequest& request);

  // Options.
  int busy_telegrams_;
  Duration flash_save_time_;

  // Handshake.
  uint8_t count_ = 0;
  linudp::RtcReply last_;     // reported while the count does not change
  linudp::RtcReply pending_;  // A-09 busy emulation: the result after the busy phase
  int busy_left_ = 0;
  std::optional<Duration> flash_done_at_;  // A-13 0x80 while MC is stopped
  uint64_t commands_ = 0;

  // UPID list cursors (0x20-0x23).
  std::optional<uint32_t> list_next_;
  std::optional<uint32_t> modified_next_;

  // Command table storage (0x81-0x8E): entry -> bytes; announced entry being written or read.
  std::map<uint8_t, std::vector<uint8_t>> ct_entries_;
  std::optional<uint8_t> ct_write_entry_;
  size_t ct_write_size_ = 0;
  std::vector<uint8_t> ct_write_buffer_;
  size_t ct_read_offset_ = 0;

  // Curve storage: curve number -> info block, data block.
  std::map<uint16_t, StoredCurve> curves_;
  std::optional<size_t> corrupt_next_point_;
  struct CurveTransfer {
    uint16_t curve = 0;
    size_t info_size = 0;
    size_t data_size = 0;
    size_t info_offset = 0;
    size_t data_offset = 0;
    bool modify = false;
    StoredCurve staged;
  };
  std::optional<CurveTransfer> curve_write_;
  std::optional<CurveTransfer> curve_read_;
};

}  // namespace drivegw::sim::linmot
