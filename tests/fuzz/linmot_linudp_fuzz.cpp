// Fuzz target for the LinUDP V2 codec: every input is decoded as a request and as a reply; what
// decodes must re-encode to bytes that decode to the same struct (abort() otherwise).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "adapters/linmot/linudp/codec.h"

namespace {

using namespace drivegw::linmot::linudp;

void CheckRequest(std::span<const uint8_t> bytes) {
  auto request = DecodeRequest(bytes);
  if (!request.ok()) {
    // only a datagram shorter than its layout may fail.
    if (bytes.size() >= kHeaderSize) {
      const uint32_t def = uint32_t{bytes[0]} | (uint32_t{bytes[1]} << 8) |
                           (uint32_t{bytes[2]} << 16) | (uint32_t{bytes[3]} << 24);
      if (bytes.size() >= RequestLayoutSize(def)) std::abort();
    }
    return;
  }
  const std::vector<uint8_t> wire = EncodeRequest(*request);
  if (wire.size() != RequestLayoutSize(RequestDefinitionOf(*request))) std::abort();
  // The re-encoded telegram is the decoded prefix of the input with reserved bits cleared.
  for (size_t i = kHeaderSize; i < wire.size(); ++i) {
    const uint8_t expected = bytes[i];
    if (wire[i] != expected) {
      const bool rtc_count = request->rtc && i == wire.size() - kRtcRequestSize;
      if (!rtc_count || wire[i] != (expected & 0x0F)) std::abort();
    }
  }
  auto again = DecodeRequest(wire);
  if (!again.ok() || !(*again == *request)) std::abort();
}

void CheckReply(std::span<const uint8_t> bytes) {
  auto reply = DecodeReply(bytes);
  if (!reply.ok()) {
    if (bytes.size() >= kHeaderSize) {
      const uint32_t def = uint32_t{bytes[4]} | (uint32_t{bytes[5]} << 8) |
                           (uint32_t{bytes[6]} << 16) | (uint32_t{bytes[7]} << 24);
      if (bytes.size() >= ResponseLayoutSize(def)) std::abort();
    }
    return;
  }
  for (size_t min_payload : {size_t{0}, kMinReplyPayload, kManualReplyPayload}) {
    const std::vector<uint8_t> wire = EncodeReply(*reply, min_payload);
    const size_t layout = ResponseLayoutSize(reply->response_definition);
    if (wire.size() != std::max(layout, min_payload)) std::abort();
    // The header survives unchanged (A-02: the drive's definition fields are data).
    for (size_t i = 0; i < kHeaderSize; ++i) {
      if (wire[i] != bytes[i]) std::abort();
    }
    auto again = DecodeReply(wire);
    if (!again.ok() || !(*again == *reply)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  // The first byte steers: most of the time it is consumed and a plausible header is built from
  // it, so that random bytes reach the block parsers instead of failing on the lengths.
  const uint8_t mode = data[0];
  std::span<const uint8_t> rest(data + 1, size - 1);
  if (mode < 0xC0) {
    std::vector<uint8_t> bytes(rest.begin(), rest.end());
    if (bytes.size() < kHeaderSize) bytes.resize(kHeaderSize, 0);
    // Low bits of mode pick the request blocks, the rest (and the input) the response blocks;
    // mode bit 7 leaves the reserved bits as they came.
    if ((mode & 0x80) == 0) {
      bytes[0] = mode & 0x07;
      for (size_t i = 1; i < 4; ++i) bytes[i] = 0;
      bytes[5] &= 0x01;
      bytes[6] = 0;
      bytes[7] = 0;
    }
    CheckRequest(bytes);
    CheckReply(bytes);
    // Also as a reply cut just short of / exactly at its layout.
    const size_t layout = ResponseLayoutSize(uint32_t{bytes[4]} | (uint32_t{bytes[5]} << 8));
    if (bytes.size() < layout) bytes.resize(layout, 0);
    CheckReply(std::span<const uint8_t>(bytes.data(), layout));
    CheckReply(std::span<const uint8_t>(bytes.data(), layout - 1));
    CheckRequest(std::span<const uint8_t>(bytes.data(), layout - 1));
  } else {
    CheckRequest(std::span<const uint8_t>(data, size));
    CheckReply(std::span<const uint8_t>(data, size));
  }
  return 0;
}
