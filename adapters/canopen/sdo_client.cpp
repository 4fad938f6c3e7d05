// SDO client transfer state machine (CiA 301 v4.2.0 §7.2.4.3.3-§7.2.4.3.8: initiate, then
// segments with the toggle bit starting at 0 and alternating; §7.2.4.3.17 abort).
#include <algorithm>
#include <array>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {
namespace {

// The builders only make frames EncodeSdo accepts; the identifier is masked to 11 bits so that a
// hand-made channel with a bad id cannot make the state machine throw.
transport::CanFrame RequestFrame(const SdoFrame& frame, const SdoChannel& channel) {
  const std::array<uint8_t, 8> bytes =
      EncodeSdo(frame, SdoDirection::kRequest).value_or(std::array<uint8_t, 8>{});
  return transport::MakeCanFrame(channel.request_id & 0x7FF, bytes);
}

}  // namespace

SdoClientTransfer::SdoClientTransfer(const SdoChannel& channel, SdoTransferKind kind,
                                     uint16_t index, uint8_t sub, std::vector<uint8_t> data,
                                     size_t max_size)
    : channel_(channel),
      kind_(kind),
      index_(index),
      sub_(sub),
      data_(std::move(data)),
      max_size_(max_size) {}

SdoClientTransfer SdoClientTransfer::Upload(const SdoChannel& channel, uint16_t index, uint8_t sub,
                                            size_t max_size) {
  return SdoClientTransfer(channel, SdoTransferKind::kUpload, index, sub, {}, max_size);
}

SdoClientTransfer SdoClientTransfer::Download(const SdoChannel& channel, uint16_t index,
                                              uint8_t sub, std::vector<uint8_t> data) {
  const size_t size = data.size();
  return SdoClientTransfer(channel, SdoTransferKind::kDownload, index, sub, std::move(data), size);
}

std::string SdoClientTransfer::Context() const {
  return absl::StrFormat("sdo %s 0x%04X:%02X node %d",
                         kind_ == SdoTransferKind::kUpload ? "upload" : "download", index_, sub_,
                         channel_.node);
}

transport::CanFrame SdoClientTransfer::Start() {
  state_ = State::kWaitInitiateResponse;
  toggle_ = false;
  offset_ = 0;
  last_sent_ = false;
  expected_.reset();  // Start() again after a time-out begins a new transfer (decision 1481)
  SdoFrame first;
  if (kind_ == SdoTransferKind::kUpload) {
    data_.clear();
    first = InitiateUploadRequest(index_, sub_);
  } else if (!data_.empty() && data_.size() <= kSdoExpeditedMax) {
    first = InitiateDownloadExpedited(index_, sub_, data_);
  } else {
    // 0 bytes cannot be expedited (e = 1, s = 1 has 1..4 bytes): segmented with size 0 and one
    // empty last segment (decision 1102).
    first = InitiateDownloadSegmented(index_, sub_, static_cast<uint32_t>(data_.size()));
  }
  return RequestFrame(first, channel_);
}

SdoStep SdoClientTransfer::Send(const SdoFrame& frame) {
  SdoStep step;
  step.kind = SdoStep::Kind::kSend;
  step.frame = RequestFrame(frame, channel_);
  return step;
}

SdoStep SdoClientTransfer::Fail(SdoAbortCode code, bool send_abort, std::string_view detail) {
  state_ = State::kFinished;
  SdoStep step;
  step.kind = SdoStep::Kind::kFailed;
  std::string context = Context();
  if (!detail.empty()) absl::StrAppend(&context, ", ", std::string(detail));
  absl::StrAppend(&context, send_abort ? ": client aborted" : ": server aborted");
  step.status = SdoAbortStatus(code, context);
  if (send_abort) {
    step.frame = RequestFrame(AbortFrame(index_, sub_, code), channel_);
  }
  return step;
}

SdoStep SdoClientTransfer::Finish(std::vector<uint8_t> data) {
  state_ = State::kFinished;
  SdoStep step;
  step.kind = SdoStep::Kind::kDone;
  step.data = std::move(data);
  return step;
}

SdoStep SdoClientTransfer::OnFrame(const transport::CanFrame& frame) {
  if (state_ != State::kWaitInitiateResponse && state_ != State::kWaitSegment) return {};
  if (frame.id != channel_.response_id || frame.extended || frame.rtr || frame.error) return {};
  // CiA 301 §7.2.4.3: SDO frames have 8 bytes; shorter ones are not SDO frames (decision 1105).
  if (frame.dlc != kSdoFrameSize) return {};
  auto decoded = DecodeSdo(frame.payload(), SdoDirection::kResponse);
  if (!decoded.ok()) {
    return Fail(SdoAbortCode::kInvalidCommand, true,
                absl::StrFormat("server command specifier %d", frame.data[0] >> 5));
  }
  const SdoFrame& f = *decoded;
  if (f.command == SdoCommand::kAbort) {
    std::string detail;
    if (f.index != index_ || f.sub != sub_) {
      detail = absl::StrFormat("abort names 0x%04X:%02X", f.index, f.sub);
    }
    return Fail(static_cast<SdoAbortCode>(f.abort_code), false, detail);
  }
  return kind_ == SdoTransferKind::kUpload ? OnUploadResponse(f) : OnDownloadResponse(f);
}

SdoStep SdoClientTransfer::OnUploadResponse(const SdoFrame& f) {
  if (state_ == State::kWaitInitiateResponse) {
    if (f.command != SdoCommand::kInitiateUpload) {
      return Fail(SdoAbortCode::kInvalidCommand, true,
                  absl::StrCat("unexpected ", std::string(SdoCommandName(f.command)), " response"));
    }
    if (f.index != index_ || f.sub != sub_) {
      // The multiplexer must echo the request (§7.2.4.3.6); decision 1105 picks the code.
      return Fail(SdoAbortCode::kParameterIncompatible, true,
                  absl::StrFormat("response names 0x%04X:%02X", f.index, f.sub));
    }
    if (f.expedited) {
      return Finish(std::vector<uint8_t>(f.data.begin(), f.data.begin() + f.data_size));
    }
    if (f.size_indicated) {
      if (f.size > max_size_) {
        return Fail(SdoAbortCode::kOutOfMemory, true,
                    absl::StrCat("announced ", f.size, " bytes exceed ", max_size_));
      }
      expected_ = f.size;
    }
    state_ = State::kWaitSegment;
    toggle_ = false;
    return Send(UploadSegmentRequest(toggle_));
  }
  if (f.command != SdoCommand::kUploadSegment) {
    return Fail(SdoAbortCode::kInvalidCommand, true,
                absl::StrCat("unexpected ", std::string(SdoCommandName(f.command)), " response"));
  }
  if (f.toggle != toggle_) {
    return Fail(
        SdoAbortCode::kToggleBit, true,
        absl::StrCat("segment toggle ", f.toggle ? 1 : 0, " where ", toggle_ ? 1 : 0, " was due"));
  }
  data_.insert(data_.end(), f.data.begin(), f.data.begin() + f.data_size);
  if (data_.size() > max_size_) {
    return Fail(SdoAbortCode::kOutOfMemory, true,
                absl::StrCat("received ", data_.size(), " bytes exceed ", max_size_));
  }
  if (expected_ && data_.size() > *expected_) {
    return Fail(SdoAbortCode::kLengthTooHigh, true,
                absl::StrCat("received ", data_.size(), " bytes, announced ", *expected_));
  }
  if (f.last) {
    if (expected_ && data_.size() != *expected_) {
      return Fail(SdoAbortCode::kLengthMismatch, true,
                  absl::StrCat("received ", data_.size(), " bytes, announced ", *expected_));
    }
    return Finish(std::move(data_));
  }
  toggle_ = !toggle_;
  return Send(UploadSegmentRequest(toggle_));
}

SdoStep SdoClientTransfer::NextDownloadSegment() {
  const size_t chunk = std::min(kSdoSegmentMax, data_.size() - offset_);
  const bool last = offset_ + chunk == data_.size();
  const std::span<const uint8_t> bytes(data_.data() + offset_, chunk);
  offset_ += chunk;
  last_sent_ = last;
  return Send(DownloadSegment(toggle_, bytes, last));
}

SdoStep SdoClientTransfer::OnDownloadResponse(const SdoFrame& f) {
  if (state_ == State::kWaitInitiateResponse) {
    if (f.command != SdoCommand::kInitiateDownload) {
      return Fail(SdoAbortCode::kInvalidCommand, true,
                  absl::StrCat("unexpected ", std::string(SdoCommandName(f.command)), " response"));
    }
    if (f.index != index_ || f.sub != sub_) {
      return Fail(SdoAbortCode::kParameterIncompatible, true,
                  absl::StrFormat("response names 0x%04X:%02X", f.index, f.sub));
    }
    if (!data_.empty() && data_.size() <= kSdoExpeditedMax) return Finish({});
    state_ = State::kWaitSegment;
    toggle_ = false;
    return NextDownloadSegment();
  }
  if (f.command != SdoCommand::kDownloadSegment) {
    return Fail(SdoAbortCode::kInvalidCommand, true,
                absl::StrCat("unexpected ", std::string(SdoCommandName(f.command)), " response"));
  }
  if (f.toggle != toggle_) {
    return Fail(SdoAbortCode::kToggleBit, true,
                absl::StrCat("segment response toggle ", f.toggle ? 1 : 0, " where ",
                             toggle_ ? 1 : 0, " was due"));
  }
  if (last_sent_) return Finish({});
  toggle_ = !toggle_;
  return NextDownloadSegment();
}

SdoStep SdoClientTransfer::Timeout() {
  if (state_ != State::kWaitInitiateResponse && state_ != State::kWaitSegment) return {};
  return Fail(SdoAbortCode::kTimeout, true, "no response before the deadline");
}

SdoStep SdoClientTransfer::Cancel(SdoAbortCode code) {
  if (state_ != State::kWaitInitiateResponse && state_ != State::kWaitSegment) return {};
  return Fail(code, true, "cancelled");
}

}  // namespace drivegw::canopen
