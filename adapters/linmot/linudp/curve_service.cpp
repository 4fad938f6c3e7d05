// Curve service sequences: download (add or modify), upload, read-back comparison.
#include "adapters/linmot/linudp/curve_service.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"
#include "adapters/linmot/linudp/rtc_error.h"

namespace drivegw::linmot::linudp {
namespace {

constexpr uint8_t Id(RtcCommand c) { return static_cast<uint8_t>(c); }

std::string StepName(RtcCommand c, uint16_t curve_id) {
  return absl::StrFormat("curve %d: %s (0x%02X)", curve_id, RtcCommandName(c), Id(c));
}

}  // namespace

absl::StatusOr<RtcReply> CurveService::Step(uint8_t command_id, uint16_t curve_id, uint16_t word3,
                                            uint16_t word4, const std::string& what) {
  DGW_ASSIGN_OR_RETURN(const RtcReply r, transact_(command_id, curve_id, word3, word4, what));
  if (IsRtcError(r.status)) return RtcStatusError(drive_, what, r.status);
  return r;
}

absl::Status CurveService::SendBlocks(uint8_t command_id, uint16_t curve_id,
                                      const std::vector<uint8_t>& bytes, bool last,
                                      const char* what) {
  const auto command = static_cast<RtcCommand>(command_id);
  for (size_t at = 0; at < bytes.size(); at += 4) {
    // Four bytes in memory order, the last block zero-padded (linudp §5.3 note 1, L327).
    auto byte = [&](size_t i) -> uint16_t { return i < bytes.size() ? bytes[i] : 0; };
    const auto w3 = static_cast<uint16_t>(byte(at) | (byte(at + 1) << 8));
    const auto w4 = static_cast<uint16_t>(byte(at + 2) | (byte(at + 3) << 8));
    const std::string step = absl::StrCat(StepName(command, curve_id), " ", what, " ", at / 4,
                                          " of ", (bytes.size() + 3) / 4);
    DGW_ASSIGN_OR_RETURN(const RtcReply r, Step(command_id, curve_id, w3, w4, step));
    const bool final_block = last && at + 4 >= bytes.size();
    // linudp 5.1.3: 0x04 = block accepted, more expected; 0x00 = transfer complete.
    const uint8_t want = final_block ? kRtcStatusDone : kRtcStatusBlockAccepted;
    if (r.status != want) {
      return absl::DataLossError(absl::StrFormat(
          "drive '%s': %s: status 0x%02X (%s), expected 0x%02X: the drive %s", drive_, step,
          r.status, RtcStatusText(r.status), want,
          final_block ? "still expects data after the last block" : "ended the transfer early"));
    }
  }
  return absl::OkStatus();
}

absl::Status CurveService::Download(const WireCurve& curve) {
  const uint16_t id = curve.info.curve_id;
  const std::vector<uint8_t> info = EncodeCurveInfoBlock(curve.info);
  const std::vector<uint8_t> data = EncodeCurveData(curve.points);
  const auto info_size = static_cast<uint16_t>(info.size());
  const auto data_size = static_cast<uint16_t>(data.size());  // <= 4 x 16383 (decision 012)
  RtcCommand start = RtcCommand::kStartAddingCurve;
  DGW_ASSIGN_OR_RETURN(RtcReply r,
                       transact_(Id(start), id, info_size, data_size, StepName(start, id)));
  if (r.status == kRtcStatusCurveDefinedOrMissing) {
    // Decision 707: the drive holds a curve under this ID; the service cannot delete one curve
    // (0x41 deletes all), so the curve is modified in place with the same sequence.
    start = RtcCommand::kStartModifyingCurve;
    DGW_ASSIGN_OR_RETURN(r, Step(Id(start), id, info_size, data_size, StepName(start, id)));
  } else if (IsRtcError(r.status)) {
    return RtcStatusError(drive_, StepName(start, id), r.status);
  }
  const bool modify = start == RtcCommand::kStartModifyingCurve;
  DGW_RETURN_IF_ERROR(
      SendBlocks(Id(modify ? RtcCommand::kModifyCurveInfoBlock : RtcCommand::kAddCurveInfoBlock),
                 id, info, data.empty(), "info block"));
  DGW_RETURN_IF_ERROR(
      SendBlocks(Id(modify ? RtcCommand::kModifyCurveData : RtcCommand::kAddCurveData), id, data,
                 true, "point"));
  // Issue 6: verified by reading it back, every field and every point.
  absl::StatusOr<WireCurve> back = Upload(id);
  if (!back.ok()) {
    return absl::Status(back.status().code(),
                        absl::StrCat(back.status().message(), " (read-back after download)"));
  }
  if (const std::string diff = FirstDifference(curve, *back); !diff.empty()) {
    return absl::DataLossError(absl::StrFormat(
        "drive '%s': curve %d: read-back differs from the download at %s", drive_, id, diff));
  }
  return absl::OkStatus();
}

absl::StatusOr<WireCurve> CurveService::Upload(uint16_t curve_id) {
  const RtcCommand start = RtcCommand::kStartGettingCurve;
  DGW_ASSIGN_OR_RETURN(const RtcReply r,
                       transact_(Id(start), curve_id, 0, 0, StepName(start, curve_id)));
  if (r.status == kRtcStatusCurveDefinedOrMissing) {
    // linudp §5.3 0x60: status 0x00 = curve present ([CS] LMcf_isCurveOnDrive).
    return absl::NotFoundError(
        absl::StrFormat("drive '%s': no curve %d on the drive (%s: RTC status 0xD4)", drive_,
                        curve_id, RtcCommandName(start)));
  }
  if (IsRtcError(r.status)) return RtcStatusError(drive_, StepName(start, curve_id), r.status);
  // Reply words 3/4 = info / data block size (linudp note 2, unverified): used when present,
  // the info block itself says how many points follow.
  const size_t info_size = r.word3 != 0 ? r.word3 : kCurveInfoBlockSize;
  std::vector<uint8_t> info;
  info.reserve(info_size + 3);
  const RtcCommand get_info = RtcCommand::kGetCurveInfoBlock;
  for (size_t at = 0; at < info_size; at += 4) {
    // [CS] sends the info block size in both words of 0x61 (note 3).
    DGW_ASSIGN_OR_RETURN(const RtcReply b,
                         Step(Id(get_info), curve_id, static_cast<uint16_t>(info_size),
                              static_cast<uint16_t>(info_size),
                              absl::StrCat(StepName(get_info, curve_id), " block ", at / 4)));
    for (uint16_t w : {b.word3, b.word4}) {
      info.push_back(static_cast<uint8_t>(w));
      info.push_back(static_cast<uint8_t>(w >> 8));
    }
  }
  info.resize(info_size);
  absl::StatusOr<CurveInfoBlock> block = DecodeCurveInfoBlock(info);
  if (!block.ok()) {
    return absl::DataLossError(
        absl::StrFormat("drive '%s': curve %d: %s", drive_, curve_id, block.status().message()));
  }
  // The info block carries its own curve ID (@30, linmot-linudp.md curve info block): a block
  // of another curve than the one asked for is a drive- or transfer-side mix-up, never a curve
  // to hand on under the requested ID.
  if (block->curve_id != curve_id) {
    return absl::DataLossError(
        absl::StrFormat("drive '%s': curve %d: the drive returned the info block of curve %d",
                        drive_, curve_id, block->curve_id));
  }
  if (r.word4 != 0 && r.word4 != block->point_count * kCurvePointSize) {
    return absl::DataLossError(absl::StrFormat(
        "drive '%s': curve %d: data block of %d bytes, the info block counts %d points", drive_,
        curve_id, r.word4, block->point_count));
  }
  WireCurve out;
  out.info = *block;
  out.points.reserve(block->point_count);
  const RtcCommand get_data = RtcCommand::kGetCurveData;
  for (size_t i = 0; i < block->point_count; ++i) {
    DGW_ASSIGN_OR_RETURN(const RtcReply d,
                         Step(Id(get_data), curve_id, 0, 0,
                              absl::StrCat(StepName(get_data, curve_id), " point ", i)));
    out.points.push_back(static_cast<int32_t>(uint32_t{d.word3} | (uint32_t{d.word4} << 16)));
  }
  return out;
}

}  // namespace drivegw::linmot::linudp
