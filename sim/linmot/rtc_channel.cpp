// RTC channel: the command handshake of linmot-linudp.md §5.1 and the commands of §5.3 with the
// simulated drive's side of.
#include "sim/linmot/rtc_channel.h"

#include <algorithm>
#include <cstring>

#include "adapters/core/log.h"
#include "adapters/linmot/mc/error_codes.h"

namespace drivegw::sim::linmot {

using linudp::RtcCommand;
using linudp::RtcReply;
using linudp::RtcRequest;

namespace {

uint16_t Lo(uint32_t v) { return static_cast<uint16_t>(v & 0xFFFF); }
uint16_t Hi(uint32_t v) { return static_cast<uint16_t>(v >> 16); }
uint32_t Value32(const RtcRequest& r) { return uint32_t{r.word3} | (uint32_t{r.word4} << 16); }

RtcReply Status(uint8_t status, uint16_t w2 = 0, uint16_t w3 = 0, uint16_t w4 = 0) {
  return RtcReply{0, status, w2, w3, w4};
}

// unknown UPID 0xC0, value outside min/max 0xC2, read-only (or no ROM) 0xC3.
uint8_t ToRtcStatus(const absl::Status& s) {
  switch (s.code()) {
    case absl::StatusCode::kOk:
      return linudp::kRtcStatusDone;
    case absl::StatusCode::kNotFound:
      return linudp::kRtcStatusUpidError;
    case absl::StatusCode::kOutOfRange:
      return linudp::kRtcStatusRangeError;
    case absl::StatusCode::kFailedPrecondition:
      return linudp::kRtcStatusAddressUsageError;
    default:
      return linudp::kRtcStatusParameterTypeError;
  }
}

// Four bytes of a buffer as (word3, word4), little-endian, zero past the end.
std::pair<uint16_t, uint16_t> Words(const std::vector<uint8_t>& b, size_t off) {
  uint8_t x[4] = {0, 0, 0, 0};
  for (size_t i = 0; i < 4 && off + i < b.size(); ++i) x[i] = b[off + i];
  return {static_cast<uint16_t>(x[0] | (x[1] << 8)), static_cast<uint16_t>(x[2] | (x[3] << 8))};
}

void Append(std::vector<uint8_t>& b, const RtcRequest& r, size_t limit) {
  const uint8_t x[4] = {static_cast<uint8_t>(r.word3), static_cast<uint8_t>(r.word3 >> 8),
                        static_cast<uint8_t>(r.word4), static_cast<uint8_t>(r.word4 >> 8)};
  for (uint8_t v : x) {
    if (b.size() < limit) b.push_back(v);
  }
}

}  // namespace

void RtcChannel::PowerUp() {
  count_ = 0;
  last_ = RtcReply{};
  pending_ = RtcReply{};
  busy_left_ = 0;
  flash_done_at_.reset();
  list_next_.reset();
  modified_next_.reset();
  ct_write_entry_.reset();
  curve_write_.reset();
  curve_read_.reset();
}

RtcResult RtcChannel::Handle(const std::optional<RtcRequest>& request, RtcContext& ctx) {
  // the flash save finishes after its configured time, reported on a later telegram.
  if (flash_done_at_ && ctx.now >= *flash_done_at_) {
    flash_done_at_.reset();
    last_.status = linudp::kRtcStatusDone;
  }
  if (!request || (request->count & 0x0F) == count_) {
    // linudp 5.1.2: the same count evaluates nothing; the last result is repeated.
    if (busy_left_ > 0) {
      if (--busy_left_ == 0) last_ = pending_;
    }
    return RtcResult{last_, RtcEffect::kNone};
  }
  count_ = request->count & 0x0F;
  ++commands_;
  RtcResult result = Execute(*request, ctx);
  result.reply.count = count_;
  if (busy_telegrams_ > 0 && result.effect == RtcEffect::kNone &&
      result.reply.status != linudp::kRtcStatusCommandRunning) {
    // A-09 test option: report 0x02 for N telegrams before the result.
    pending_ = result.reply;
    busy_left_ = busy_telegrams_;
    result.reply = RtcReply{count_, linudp::kRtcStatusCommandRunning, request->word2, 0, 0};
  }
  last_ = result.reply;
  return result;
}

RtcResult RtcChannel::Execute(const RtcRequest& r, RtcContext& ctx) {
  const auto command = linudp::RtcCommandFromId(r.command_id);
  if (!command) {
    // unknown command ID -> 0xC0.
    log::Debug("linmot_sim.rtc_unknown", log::Fields().Add("id", int{r.command_id}));
    return RtcResult{Status(linudp::kRtcStatusUpidError, r.word2), RtcEffect::kNone};
  }
  switch (*command) {
    case RtcCommand::kNoOperation:
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kNone};
    case RtcCommand::kReadRomValueByUpid:
    case RtcCommand::kReadRamValueByUpid:
    case RtcCommand::kWriteRomValueByUpid:
    case RtcCommand::kWriteRamValueByUpid:
    case RtcCommand::kWriteRamAndRomValueByUpid:
    case RtcCommand::kGetMinimalValueByUpid:
    case RtcCommand::kGetMaximalValueByUpid:
    case RtcCommand::kGetDefaultValueByUpid:
      return RtcResult{Parameter(r, ctx), RtcEffect::kNone};

    case RtcCommand::kStartGettingUpidList:
      list_next_ = r.word2;
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kNone};
    case RtcCommand::kStartGettingModifiedUpidList:
      modified_next_ = r.word2;
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kNone};
    case RtcCommand::kGetNextUpidListItem:
    case RtcCommand::kGetNextModifiedUpidListItem: {
      const bool modified = *command == RtcCommand::kGetNextModifiedUpidListItem;
      auto& cursor = modified ? modified_next_ : list_next_;
      if (!cursor) return RtcResult{Status(linudp::kRtcStatusNoUpidListStarted), RtcEffect::kNone};
      const auto found = ctx.params.NextUpid(*cursor, modified);
      if (!found) return RtcResult{Status(linudp::kRtcStatusEndOfUpidList), RtcEffect::kNone};
      cursor = uint32_t{*found} + 1;
      if (modified) {
        const uint32_t v = Parameters::ToWire(ctx.params.ReadRom(*found).value_or(0));
        return RtcResult{Status(linudp::kRtcStatusDone, *found, Lo(v), Hi(v)), RtcEffect::kNone};
      }
      // "Address usage" (undocumented): bit 0 = RAM value, bit 1 = ROM value (decision 603).
      const uint16_t usage = ctx.params.Find(*found)->variable ? 0x0001 : 0x0003;
      return RtcResult{Status(linudp::kRtcStatusDone, *found, usage), RtcEffect::kNone};
    }

    case RtcCommand::kRestartDrive:
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kRestart};
    case RtcCommand::kSetRomDefaultsOsSw:
    case RtcCommand::kSetRomDefaultsMcSw:
    case RtcCommand::kSetRomDefaultsInterfaceSw:
    case RtcCommand::kSetRomDefaultsApplicationSw:
      // Every simulated parameter belongs to MC or interface SW; RAM follows at the next boot.
      ctx.params.RestoreRomDefaults();
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kNone};
    case RtcCommand::kStopMcAndApplicationSw:
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kStopMc};
    case RtcCommand::kStartMcAndApplicationSw:
      return RtcResult{Status(linudp::kRtcStatusDone), RtcEffect::kStartMc};

    case RtcCommand::kSaveAllCurvesToFlash:
    case RtcCommand::kDeleteAllCurves:
    case RtcCommand::kStartAddingCurve:
    case RtcCommand::kAddCurveInfoBlock:
    case RtcCommand::kAddCurveData:
    case RtcCommand::kStartModifyingCurve:
    case RtcCommand::kModifyCurveInfoBlock:
    case RtcCommand::kModifyCurveData:
    case RtcCommand::kStartGettingCurve:
    case RtcCommand::kGetCurveInfoBlock:
    case RtcCommand::kGetCurveData:
      return RtcResult{Curve(r), RtcEffect::kNone};

    case RtcCommand::kGetErrorLogEntryCounter:
      return RtcResult{
          Status(linudp::kRtcStatusDone, 0, static_cast<uint16_t>(ctx.error_log.logged()),
                 static_cast<uint16_t>(ctx.error_log.occurred())),
          RtcEffect::kNone};
    case RtcCommand::kGetErrorLogEntryErrorCode:
    case RtcCommand::kGetErrorLogEntryTimeLow:
    case RtcCommand::kGetErrorLogEntryTimeHigh: {
      const auto entry = ctx.error_log.Entry(r.word2);
      if (!entry) return RtcResult{Status(linudp::kRtcStatusRangeError, r.word2), RtcEffect::kNone};
      if (*command == RtcCommand::kGetErrorLogEntryErrorCode) {
        return RtcResult{Status(linudp::kRtcStatusDone, r.word2, entry->code), RtcEffect::kNone};
      }
      const uint32_t v =
          *command == RtcCommand::kGetErrorLogEntryTimeLow ? entry->milliseconds : entry->hours;
      return RtcResult{Status(linudp::kRtcStatusDone, r.word2, Lo(v), Hi(v)), RtcEffect::kNone};
    }
    case RtcCommand::kGetErrorCodeTextStringlet: {
      const auto* code = mc::FindErrorCode(r.word2);
      if (!code) return RtcResult{Status(linudp::kRtcStatusUpidError, r.word2), RtcEffect::kNone};
      if (r.word3 > 7)
        return RtcResult{Status(linudp::kRtcStatusRangeError, r.word2), RtcEffect::kNone};
      const std::string_view text(code->text);
      std::vector<uint8_t> bytes(text.begin(), text.end());
      const auto [w3, w4] = Words(bytes, size_t{r.word3} * 4);
      return RtcResult{Status(linudp::kRtcStatusDone, r.word2, w3, w4), RtcEffect::kNone};
    }

    case RtcCommand::kCommandTableSaveToFlash:
      // refused while MC runs; while stopped 0x02 for the configured time, then 0x00.
      if (!ctx.mc_stopped) {
        return RtcResult{Status(linudp::kRtcStatusAddressUsageError), RtcEffect::kNone};
      }
      flash_done_at_ = ctx.now + flash_save_time_;
      return RtcResult{Status(linudp::kRtcStatusCommandRunning), RtcEffect::kNone};
    default:
      return RtcResult{CommandTable(r, ctx), RtcEffect::kNone};
  }
}

RtcReply RtcChannel::Parameter(const RtcRequest& r, RtcContext& ctx) {
  const uint16_t u = r.word2;
  const auto command = static_cast<RtcCommand>(r.command_id);
  auto reply_value = [&](const absl::StatusOr<int64_t>& v) {
    if (!v.ok()) return Status(ToRtcStatus(v.status()), u);
    const uint32_t w = Parameters::ToWire(*v);
    return Status(linudp::kRtcStatusDone, u, Lo(w), Hi(w));
  };
  switch (command) {
    case RtcCommand::kReadRomValueByUpid:
      return reply_value(ctx.params.ReadRom(u));
    case RtcCommand::kReadRamValueByUpid:
      return reply_value(ctx.params.ReadRam(u));
    case RtcCommand::kGetMinimalValueByUpid:
    case RtcCommand::kGetMaximalValueByUpid:
    case RtcCommand::kGetDefaultValueByUpid: {
      const ParamDef* def = ctx.params.Find(u);
      if (!def) return Status(linudp::kRtcStatusUpidError, u);
      return reply_value(command == RtcCommand::kGetMinimalValueByUpid   ? def->min
                         : command == RtcCommand::kGetMaximalValueByUpid ? def->max
                                                                         : def->default_value);
    }
    default:
      break;
  }
  // Writes: the value is checked against the type, then against min/max and read-only, for
  // RAM and ROM alike before anything changes (0x14 never half-succeeds).
  const auto value = ctx.params.FromWire(u, Value32(r));
  if (!value.ok()) return Status(ToRtcStatus(value.status()), u, r.word3, r.word4);
  const bool ram = command != RtcCommand::kWriteRomValueByUpid;
  const bool rom = command != RtcCommand::kWriteRamValueByUpid;
  if (rom && ctx.params.Find(u)->variable) {
    return Status(linudp::kRtcStatusAddressUsageError, u, r.word3, r.word4);
  }
  absl::Status s = ram ? ctx.params.WriteRam(u, *value) : ctx.params.WriteRom(u, *value);
  if (s.ok() && ram && rom) s = ctx.params.WriteRom(u, *value);
  return Status(ToRtcStatus(s), u, r.word3, r.word4);
}

RtcReply RtcChannel::CommandTable(const RtcRequest& r, RtcContext&) {
  const auto command = static_cast<RtcCommand>(r.command_id);
  const uint8_t entry = static_cast<uint8_t>(r.word2);
  constexpr size_t kMaxEntrySize = 64;  // linudp §5.3: entries read back are 64 bytes
  switch (command) {
    case RtcCommand::kCommandTableDeleteAllEntries:
      ct_entries_.clear();
      return Status(linudp::kRtcStatusDone);
    case RtcCommand::kCommandTableDeleteEntry:
      ct_entries_.erase(entry);
      return Status(linudp::kRtcStatusDone, r.word2);
    case RtcCommand::kCommandTableWriteEntry:
      if (r.word2 > 255) return Status(linudp::kRtcStatusRangeError, r.word2);
      if (r.word3 % 2 != 0) return Status(linudp::kRtcStatusOddAddress, r.word2, r.word3);
      if (r.word3 > kMaxEntrySize) return Status(linudp::kRtcStatusSizeError, r.word2, r.word3);
      ct_write_entry_ = entry;
      ct_write_size_ = r.word3;
      ct_write_buffer_.clear();
      if (ct_write_size_ == 0) {
        ct_entries_[entry] = {};
        ct_write_entry_.reset();
      }
      return Status(linudp::kRtcStatusDone, r.word2, r.word3);
    case RtcCommand::kCommandTableWriteEntryData:
      if (!ct_write_entry_ || *ct_write_entry_ != entry || r.word2 > 255) {
        return Status(linudp::kRtcStatusAddressUsageError, r.word2);
      }
      Append(ct_write_buffer_, r, ct_write_size_);
      if (ct_write_buffer_.size() < ct_write_size_) {
        return Status(linudp::kRtcStatusBlockAccepted, r.word2, r.word3, r.word4);
      }
      ct_entries_[entry] = ct_write_buffer_;
      ct_write_entry_.reset();
      return Status(linudp::kRtcStatusDone, r.word2, r.word3, r.word4);
    case RtcCommand::kCommandTableGetEntry: {
      auto it = ct_entries_.find(entry);
      if (r.word2 > 255 || it == ct_entries_.end()) {
        return Status(linudp::kRtcStatusRangeError, r.word2);
      }
      ct_read_offset_ = 0;
      return Status(linudp::kRtcStatusDone, r.word2, static_cast<uint16_t>(it->second.size()));
    }
    case RtcCommand::kCommandTableGetEntryData: {
      auto it = ct_entries_.find(entry);
      if (r.word2 > 255 || it == ct_entries_.end()) {
        return Status(linudp::kRtcStatusRangeError, r.word2);
      }
      const auto [w3, w4] = Words(it->second, ct_read_offset_);
      ct_read_offset_ += 4;
      const bool more = ct_read_offset_ < it->second.size();
      return Status(more ? linudp::kRtcStatusBlockAccepted : linudp::kRtcStatusDone, r.word2, w3,
                    w4);
    }
    default:
      break;
  }
  if (r.command_id >= 0x87 && r.command_id <= 0x8E) {
    // Presence list: a set bit means "entry undefined" (linudp §5.3 notes).
    const int group = r.command_id - 0x87;
    uint8_t bytes[4] = {0xFF, 0xFF, 0xFF, 0xFF};
    for (int k = 0; k < 32; ++k) {
      if (ct_entries_.count(static_cast<uint8_t>(group * 32 + k))) {
        bytes[k / 8] = static_cast<uint8_t>(bytes[k / 8] & ~(1u << (k % 8)));
      }
    }
    return Status(linudp::kRtcStatusDone, static_cast<uint16_t>(group * 4),
                  static_cast<uint16_t>(bytes[0] | (bytes[1] << 8)),
                  static_cast<uint16_t>(bytes[2] | (bytes[3] << 8)));
  }
  return Status(linudp::kRtcStatusUpidError, r.word2);
}

const RtcChannel::StoredCurve* RtcChannel::FindCurve(uint16_t curve_id) const {
  auto it = curves_.find(curve_id);
  return it == curves_.end() ? nullptr : &it->second;
}

RtcReply RtcChannel::Curve(const RtcRequest& r) {
  const auto command = static_cast<RtcCommand>(r.command_id);
  const uint16_t curve = r.word2;
  switch (command) {
    case RtcCommand::kSaveAllCurvesToFlash:
      return Status(linudp::kRtcStatusDone);  // curves live as long as the process anyway
    case RtcCommand::kDeleteAllCurves:
      curves_.clear();
      return Status(linudp::kRtcStatusDone);
    case RtcCommand::kStartAddingCurve:
    case RtcCommand::kStartModifyingCurve: {
      const bool modify = command == RtcCommand::kStartModifyingCurve;
      if (curve < 1 || curve > 100) return Status(linudp::kRtcStatusRangeError, curve);
      if (modify != (curves_.count(curve) == 1)) {
        return Status(linudp::kRtcStatusCurveDefinedOrMissing, curve);
      }
      curve_write_ = CurveTransfer{curve, r.word3, r.word4, 0, 0, modify, {}};
      return Status(linudp::kRtcStatusDone, curve, r.word3, r.word4);
    }
    case RtcCommand::kAddCurveInfoBlock:
    case RtcCommand::kAddCurveData:
    case RtcCommand::kModifyCurveInfoBlock:
    case RtcCommand::kModifyCurveData: {
      if (!curve_write_ || curve_write_->curve != curve) {
        return Status(linudp::kRtcStatusAddressUsageError, curve);
      }
      CurveTransfer& t = *curve_write_;
      const bool info =
          command == RtcCommand::kAddCurveInfoBlock || command == RtcCommand::kModifyCurveInfoBlock;
      auto& buffer = info ? t.staged.info : t.staged.data;
      const size_t limit = info ? t.info_size : t.data_size;
      if (buffer.size() >= limit) return Status(linudp::kRtcStatusSizeError, curve);
      Append(buffer, r, limit);
      if (t.staged.info.size() < t.info_size || t.staged.data.size() < t.data_size) {
        return Status(linudp::kRtcStatusBlockAccepted, curve, r.word3, r.word4);
      }
      if (corrupt_next_point_) {
        // Decision 607: a stored point differs from the sent one (read-back tests).
        const size_t at = *corrupt_next_point_ * 4;
        if (at + 4 <= t.staged.data.size()) ++t.staged.data[at];
        corrupt_next_point_.reset();
      }
      curves_[curve] = std::move(t.staged);
      curve_write_.reset();
      return Status(linudp::kRtcStatusDone, curve, r.word3, r.word4);
    }
    case RtcCommand::kStartGettingCurve: {
      auto it = curves_.find(curve);
      if (it == curves_.end()) return Status(linudp::kRtcStatusCurveDefinedOrMissing, curve);
      curve_read_ =
          CurveTransfer{curve, it->second.info.size(), it->second.data.size(), 0, 0, false, {}};
      return Status(linudp::kRtcStatusDone, curve, static_cast<uint16_t>(it->second.info.size()),
                    static_cast<uint16_t>(it->second.data.size()));
    }
    case RtcCommand::kGetCurveInfoBlock:
    case RtcCommand::kGetCurveData: {
      auto it = curves_.find(curve);
      if (!curve_read_ || curve_read_->curve != curve || it == curves_.end()) {
        return Status(linudp::kRtcStatusAddressUsageError, curve);
      }
      const bool info = command == RtcCommand::kGetCurveInfoBlock;
      size_t& off = info ? curve_read_->info_offset : curve_read_->data_offset;
      const auto& buffer = info ? it->second.info : it->second.data;
      if (off >= buffer.size()) return Status(linudp::kRtcStatusSizeError, curve);
      const auto [w3, w4] = Words(buffer, off);
      off += 4;
      return Status(linudp::kRtcStatusDone, curve, w3, w4);
    }
    default:
      return Status(linudp::kRtcStatusUpidError, curve);
  }
}

}  // namespace drivegw::sim::linmot
