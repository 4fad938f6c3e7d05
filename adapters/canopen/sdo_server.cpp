// SDO server state machine (CiA 301 v4.2.0 §7.2.4.3.3-§7.2.4.3.8, §7.2.4.3.17): expedited and
// segmented download/upload over an ObjectAccess, toggle checking and aborts.
#include <algorithm>
#include <array>
#include <limits>

#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {

SdoServer::SdoServer(const SdoChannel& channel, ObjectAccess& objects, size_t max_download)
    : channel_(channel), objects_(objects), max_download_(max_download) {}

std::optional<transport::CanFrame> SdoServer::Respond(const SdoFrame& frame) {
  // The builders only make frames EncodeSdo accepts; the id is masked so nothing can throw.
  const std::array<uint8_t, 8> bytes =
      EncodeSdo(frame, SdoDirection::kResponse).value_or(std::array<uint8_t, 8>{});
  return transport::MakeCanFrame(channel_.response_id & 0x7FF, bytes);
}

std::optional<transport::CanFrame> SdoServer::Abort(uint16_t index, uint8_t sub,
                                                    SdoAbortCode code) {
  state_ = State::kIdle;
  buffer_.clear();
  return Respond(AbortFrame(index, sub, code));
}

std::optional<transport::CanFrame> SdoServer::OnFrame(const transport::CanFrame& frame) {
  if (frame.id != channel_.request_id || frame.extended || frame.rtr || frame.error) {
    return std::nullopt;
  }
  // SDO frames have 8 bytes (§7.2.4.3); others are not answered (decision 1105).
  if (frame.dlc != kSdoFrameSize) return std::nullopt;
  const auto payload = frame.payload();
  auto decoded = DecodeSdo(payload, SdoDirection::kRequest);
  if (!decoded.ok()) {
    // Command specifier 7: name the multiplexer as received.
    return Abort(static_cast<uint16_t>(payload[1] | payload[2] << 8), payload[3],
                 SdoAbortCode::kInvalidCommand);
  }
  const SdoFrame& f = *decoded;
  switch (f.command) {
    case SdoCommand::kAbort:
      state_ = State::kIdle;
      buffer_.clear();
      return std::nullopt;
    case SdoCommand::kInitiateDownload:
      return OnInitiateDownload(f);
    case SdoCommand::kInitiateUpload:
      return OnInitiateUpload(f);
    case SdoCommand::kDownloadSegment:
      if (state_ != State::kDownloading) {
        return Abort(index_, sub_, SdoAbortCode::kInvalidCommand);
      }
      return OnDownloadSegment(f);
    case SdoCommand::kUploadSegment:
      if (state_ != State::kUploading) return Abort(index_, sub_, SdoAbortCode::kInvalidCommand);
      return OnUploadSegment(f);
    case SdoCommand::kBlockUpload:
    case SdoCommand::kBlockDownload:
      // Block transfer is not offered (decision 1101): 0504 0001h tells the client to fall back.
      return Abort(f.index, f.sub, SdoAbortCode::kInvalidCommand);
  }
  return Abort(f.index, f.sub, SdoAbortCode::kInvalidCommand);
}

std::optional<transport::CanFrame> SdoServer::OnInitiateDownload(const SdoFrame& f) {
  // A new initiate abandons whatever was in progress (decision 1105).
  state_ = State::kIdle;
  buffer_.clear();
  index_ = f.index;
  sub_ = f.sub;
  if (f.expedited) {
    const absl::Status written = objects_.Write(f.index, f.sub, f.bytes());
    if (!written.ok()) return Abort(f.index, f.sub, AbortCodeForStatus(written));
    return Respond(InitiateDownloadResponse(f.index, f.sub));
  }
  expected_.reset();
  if (f.size_indicated) {
    if (f.size > max_download_) return Abort(f.index, f.sub, SdoAbortCode::kOutOfMemory);
    expected_ = f.size;
  }
  state_ = State::kDownloading;
  toggle_ = false;
  return Respond(InitiateDownloadResponse(f.index, f.sub));
}

std::optional<transport::CanFrame> SdoServer::OnDownloadSegment(const SdoFrame& f) {
  if (f.toggle != toggle_) return Abort(index_, sub_, SdoAbortCode::kToggleBit);
  buffer_.insert(buffer_.end(), f.data.begin(), f.data.begin() + f.data_size);
  if (buffer_.size() > max_download_) return Abort(index_, sub_, SdoAbortCode::kOutOfMemory);
  if (expected_ && buffer_.size() > *expected_) {
    return Abort(index_, sub_, SdoAbortCode::kLengthTooHigh);
  }
  const bool toggle = toggle_;
  if (f.last) {
    if (expected_ && buffer_.size() != *expected_) {
      return Abort(index_, sub_, SdoAbortCode::kLengthMismatch);
    }
    const absl::Status written = objects_.Write(index_, sub_, buffer_);
    if (!written.ok()) return Abort(index_, sub_, AbortCodeForStatus(written));
    state_ = State::kIdle;
    buffer_.clear();
    return Respond(DownloadSegmentResponse(toggle));
  }
  toggle_ = !toggle_;
  return Respond(DownloadSegmentResponse(toggle));
}

std::optional<transport::CanFrame> SdoServer::OnInitiateUpload(const SdoFrame& f) {
  state_ = State::kIdle;
  buffer_.clear();
  index_ = f.index;
  sub_ = f.sub;
  auto read = objects_.Read(f.index, f.sub);
  if (!read.ok()) return Abort(f.index, f.sub, AbortCodeForStatus(read.status()));
  if (!read->empty() && read->size() <= kSdoExpeditedMax) {
    return Respond(InitiateUploadExpedited(f.index, f.sub, *read));
  }
  if (read->size() > std::numeric_limits<uint32_t>::max()) {
    return Abort(f.index, f.sub, SdoAbortCode::kOutOfMemory);
  }
  buffer_ = std::move(*read);
  offset_ = 0;
  toggle_ = false;
  state_ = State::kUploading;
  return Respond(InitiateUploadSegmented(f.index, f.sub, static_cast<uint32_t>(buffer_.size())));
}

std::optional<transport::CanFrame> SdoServer::OnUploadSegment(const SdoFrame& f) {
  if (f.toggle != toggle_) return Abort(index_, sub_, SdoAbortCode::kToggleBit);
  const size_t chunk = std::min(kSdoSegmentMax, buffer_.size() - offset_);
  const bool last = offset_ + chunk == buffer_.size();
  const SdoFrame segment =
      UploadSegment(toggle_, std::span<const uint8_t>(buffer_.data() + offset_, chunk), last);
  offset_ += chunk;
  if (last) {
    state_ = State::kIdle;
    buffer_.clear();
  } else {
    toggle_ = !toggle_;
  }
  return Respond(segment);
}

std::optional<transport::CanFrame> SdoServer::Timeout() {
  if (state_ == State::kIdle) return std::nullopt;
  return Abort(index_, sub_, SdoAbortCode::kTimeout);
}

}  // namespace drivegw::canopen
