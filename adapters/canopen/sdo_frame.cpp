// SDO frame layouts (CiA 301 v4.2.0 §7.2.4.3.3-§7.2.4.3.8 and §7.2.4.3.17, Figures 23-30): byte 0
// carries the command specifier in bits 7..5 and the t/n/e/s/c bits; bytes 1..3 the multiplexer
// (index LE, sub-index); bytes 4..7 or 1..7 the data.
#include <algorithm>
#include <array>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/sdo.h"

namespace drivegw::canopen {
namespace {

// How the 8 bytes of a command are laid out.
enum class Layout : uint8_t {
  kInitiateData,  // cs | n e s, multiplexer, expedited data or size
  kMultiplexer,   // cs, multiplexer, reserved
  kSegmentData,   // cs | t n c, 7 data bytes
  kToggle,        // cs | t, reserved
  kAbort,         // cs, multiplexer, abort code
  kBlock,         // not implemented beyond the command specifier (decision 1101)
};

struct CommandSpec {
  uint8_t cs;
  SdoDirection direction;
  SdoCommand command;
  Layout layout;
};

// The command specifiers of both directions (ccs for requests, scs for responses).
constexpr std::array<CommandSpec, 14> kCommands = {{
    {0, SdoDirection::kRequest, SdoCommand::kDownloadSegment, Layout::kSegmentData},
    {1, SdoDirection::kRequest, SdoCommand::kInitiateDownload, Layout::kInitiateData},
    {2, SdoDirection::kRequest, SdoCommand::kInitiateUpload, Layout::kMultiplexer},
    {3, SdoDirection::kRequest, SdoCommand::kUploadSegment, Layout::kToggle},
    {4, SdoDirection::kRequest, SdoCommand::kAbort, Layout::kAbort},
    {5, SdoDirection::kRequest, SdoCommand::kBlockUpload, Layout::kBlock},
    {6, SdoDirection::kRequest, SdoCommand::kBlockDownload, Layout::kBlock},
    {0, SdoDirection::kResponse, SdoCommand::kUploadSegment, Layout::kSegmentData},
    {1, SdoDirection::kResponse, SdoCommand::kDownloadSegment, Layout::kToggle},
    {2, SdoDirection::kResponse, SdoCommand::kInitiateUpload, Layout::kInitiateData},
    {3, SdoDirection::kResponse, SdoCommand::kInitiateDownload, Layout::kMultiplexer},
    {4, SdoDirection::kResponse, SdoCommand::kAbort, Layout::kAbort},
    {5, SdoDirection::kResponse, SdoCommand::kBlockDownload, Layout::kBlock},
    {6, SdoDirection::kResponse, SdoCommand::kBlockUpload, Layout::kBlock},
}};

const CommandSpec* FindByCs(uint8_t cs, SdoDirection direction) {
  for (const CommandSpec& c : kCommands) {
    if (c.cs == cs && c.direction == direction) return &c;
  }
  return nullptr;
}

const CommandSpec* FindByCommand(SdoCommand command, SdoDirection direction) {
  for (const CommandSpec& c : kCommands) {
    if (c.command == command && c.direction == direction) return &c;
  }
  return nullptr;
}

const char* DirectionName(SdoDirection d) {
  return d == SdoDirection::kRequest ? "request" : "response";
}

uint32_t Le32(std::span<const uint8_t> b) {
  return static_cast<uint32_t>(b[0]) | static_cast<uint32_t>(b[1]) << 8 |
         static_cast<uint32_t>(b[2]) << 16 | static_cast<uint32_t>(b[3]) << 24;
}
void PutLe32(uint8_t* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<uint8_t>(v >> (8 * i));
}

SdoFrame WithData(SdoFrame f, std::span<const uint8_t> data, size_t max) {
  f.data_size = static_cast<uint8_t>(std::min(data.size(), max));
  std::copy_n(data.begin(), f.data_size, f.data.begin());
  return f;
}

}  // namespace

std::string_view SdoCommandName(SdoCommand command) {
  switch (command) {
    case SdoCommand::kInitiateDownload:
      return "initiate_download";
    case SdoCommand::kDownloadSegment:
      return "download_segment";
    case SdoCommand::kInitiateUpload:
      return "initiate_upload";
    case SdoCommand::kUploadSegment:
      return "upload_segment";
    case SdoCommand::kAbort:
      return "abort";
    case SdoCommand::kBlockUpload:
      return "block_upload";
    case SdoCommand::kBlockDownload:
      return "block_download";
  }
  return "unknown";
}

absl::StatusOr<SdoFrame> DecodeSdo(std::span<const uint8_t> bytes, SdoDirection direction) {
  if (bytes.size() != kSdoFrameSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen sdo frame: ", bytes.size(), " bytes, need ", kSdoFrameSize));
  }
  const uint8_t b0 = bytes[0];
  const uint8_t cs = b0 >> 5;
  const CommandSpec* spec = FindByCs(cs, direction);
  if (spec == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("canopen sdo ", DirectionName(direction),
                                                   ".command_specifier: ", cs,
                                                   " is unknown (0..6)"));
  }
  SdoFrame f;
  f.command = spec->command;
  std::copy(bytes.begin(), bytes.end(), f.raw.begin());
  const auto mux = [&] {
    f.index = static_cast<uint16_t>(bytes[1] | bytes[2] << 8);
    f.sub = bytes[3];
  };
  switch (spec->layout) {
    case Layout::kInitiateData: {
      mux();
      f.expedited = (b0 & 0x02) != 0;
      f.size_indicated = (b0 & 0x01) != 0;
      if (f.expedited) {
        // e = 1: n (bits 3..2) counts the bytes of 4..7 without data, valid only with s = 1;
        // without size indication all four bytes are passed on (decision 1102).
        const size_t n = f.size_indicated ? (b0 >> 2) & 0x03 : 0;
        f = WithData(f, bytes.subspan(4), kSdoExpeditedMax - n);
      } else if (f.size_indicated) {
        f.size = Le32(bytes.subspan(4));
      }
      break;
    }
    case Layout::kMultiplexer:
    case Layout::kBlock:
      mux();
      break;
    case Layout::kSegmentData: {
      f.toggle = (b0 & 0x10) != 0;
      f.last = (b0 & 0x01) != 0;
      const size_t n = (b0 >> 1) & 0x07;
      f = WithData(f, bytes.subspan(1), kSdoSegmentMax - n);
      break;
    }
    case Layout::kToggle:
      f.toggle = (b0 & 0x10) != 0;
      break;
    case Layout::kAbort:
      mux();
      f.abort_code = Le32(bytes.subspan(4));
      break;
  }
  return f;
}

absl::StatusOr<std::array<uint8_t, 8>> EncodeSdo(const SdoFrame& frame, SdoDirection direction) {
  const CommandSpec* spec = FindByCommand(frame.command, direction);
  if (spec == nullptr || spec->layout == Layout::kBlock) {
    return absl::InvalidArgumentError(absl::StrCat(
        "canopen sdo ", DirectionName(direction), ".", std::string(SdoCommandName(frame.command)),
        ": not generated (block transfer, decision 1101)"));
  }
  std::array<uint8_t, 8> out{};
  out[0] = static_cast<uint8_t>(spec->cs << 5);
  const auto mux = [&] {
    out[1] = static_cast<uint8_t>(frame.index);
    out[2] = static_cast<uint8_t>(frame.index >> 8);
    out[3] = frame.sub;
  };
  const std::string what = absl::StrCat("canopen sdo ", DirectionName(direction), ".",
                                        std::string(SdoCommandName(frame.command)));
  switch (spec->layout) {
    case Layout::kInitiateData:
      mux();
      if (frame.expedited) {
        const size_t max = kSdoExpeditedMax;
        if (frame.data_size > max || (frame.size_indicated && frame.data_size == 0)) {
          return absl::InvalidArgumentError(absl::StrCat(
              what, ".data: ", frame.data_size, " bytes outside 1..", max, " (expedited)"));
        }
        out[0] |= 0x02;
        if (frame.size_indicated) {
          out[0] |= static_cast<uint8_t>(0x01 | (kSdoExpeditedMax - frame.data_size) << 2);
        }
        std::copy_n(frame.data.begin(), frame.data_size, out.begin() + 4);
      } else if (frame.size_indicated) {
        out[0] |= 0x01;
        PutLe32(&out[4], frame.size);
      }
      break;
    case Layout::kMultiplexer:
      mux();
      break;
    case Layout::kSegmentData:
      if (frame.data_size > kSdoSegmentMax) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ".data: ", frame.data_size, " bytes exceed ", kSdoSegmentMax));
      }
      out[0] |=
          static_cast<uint8_t>((frame.toggle ? 0x10 : 0) | (kSdoSegmentMax - frame.data_size) << 1 |
                               (frame.last ? 0x01 : 0));
      std::copy_n(frame.data.begin(), frame.data_size, out.begin() + 1);
      break;
    case Layout::kToggle:
      out[0] |= frame.toggle ? 0x10 : 0;
      break;
    case Layout::kAbort:
      mux();
      PutLe32(&out[4], frame.abort_code);
      break;
    case Layout::kBlock:
      break;
  }
  return out;
}

SdoFrame InitiateDownloadExpedited(uint16_t index, uint8_t sub, std::span<const uint8_t> data) {
  SdoFrame f;
  f.command = SdoCommand::kInitiateDownload;
  f.index = index;
  f.sub = sub;
  f.expedited = true;
  f.size_indicated = true;
  return WithData(f, data, kSdoExpeditedMax);
}

SdoFrame InitiateDownloadSegmented(uint16_t index, uint8_t sub, uint32_t size) {
  SdoFrame f;
  f.command = SdoCommand::kInitiateDownload;
  f.index = index;
  f.sub = sub;
  f.size_indicated = true;
  f.size = size;
  return f;
}

SdoFrame InitiateDownloadResponse(uint16_t index, uint8_t sub) {
  SdoFrame f;
  f.command = SdoCommand::kInitiateDownload;
  f.index = index;
  f.sub = sub;
  return f;
}

SdoFrame DownloadSegment(bool toggle, std::span<const uint8_t> data, bool last) {
  SdoFrame f;
  f.command = SdoCommand::kDownloadSegment;
  f.toggle = toggle;
  f.last = last;
  return WithData(f, data, kSdoSegmentMax);
}

SdoFrame DownloadSegmentResponse(bool toggle) {
  SdoFrame f;
  f.command = SdoCommand::kDownloadSegment;
  f.toggle = toggle;
  return f;
}

SdoFrame InitiateUploadRequest(uint16_t index, uint8_t sub) {
  SdoFrame f;
  f.command = SdoCommand::kInitiateUpload;
  f.index = index;
  f.sub = sub;
  return f;
}

SdoFrame InitiateUploadExpedited(uint16_t index, uint8_t sub, std::span<const uint8_t> data) {
  SdoFrame f = InitiateDownloadExpedited(index, sub, data);
  f.command = SdoCommand::kInitiateUpload;
  return f;
}

SdoFrame InitiateUploadSegmented(uint16_t index, uint8_t sub, uint32_t size) {
  SdoFrame f = InitiateDownloadSegmented(index, sub, size);
  f.command = SdoCommand::kInitiateUpload;
  return f;
}

SdoFrame UploadSegmentRequest(bool toggle) {
  SdoFrame f;
  f.command = SdoCommand::kUploadSegment;
  f.toggle = toggle;
  return f;
}

SdoFrame UploadSegment(bool toggle, std::span<const uint8_t> data, bool last) {
  SdoFrame f = DownloadSegment(toggle, data, last);
  f.command = SdoCommand::kUploadSegment;
  return f;
}

SdoFrame AbortFrame(uint16_t index, uint8_t sub, SdoAbortCode code) {
  SdoFrame f;
  f.command = SdoCommand::kAbort;
  f.index = index;
  f.sub = sub;
  f.abort_code = static_cast<uint32_t>(code);
  return f;
}

absl::StatusOr<SdoChannel> DefaultSdoChannel(uint8_t node) {
  if (auto s = ValidateNodeId(node, "sdo.node_id"); !s.ok()) return s;
  return SdoChannel{node, static_cast<uint16_t>(0x600 + node), static_cast<uint16_t>(0x580 + node)};
}

absl::StatusOr<transport::CanFrame> ToCanFrame(const SdoFrame& frame, SdoDirection direction,
                                               const SdoChannel& channel) {
  auto bytes = EncodeSdo(frame, direction);
  if (!bytes.ok()) return bytes.status();
  const uint16_t id =
      direction == SdoDirection::kRequest ? channel.request_id : channel.response_id;
  if (id > kMaxCobId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen sdo channel cob id 0x%X: exceeds 0x7FF", id));
  }
  return transport::MakeCanFrame(id, *bytes);
}

}  // namespace drivegw::canopen
