// Fuzz target for the Trinamic codec: the input is decoded as a 9-byte command, an R8 and an R9
// reply and a CAN frame (id low, id high, dlc, 8 data bytes); what decodes must re-encode to the
// input with unused bytes zeroed and decode to the same struct (abort() otherwise).
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "adapters/trinamic/codec.h"

namespace {

using namespace drivegw::trinamic;

// The parameter bytes P0..P6 with every byte no field covers set to 00 (decision 1012, G-02).
std::array<uint8_t, kParamCount> Canonical(std::span<const FieldSpec> fields,
                                           std::span<const uint8_t> params) {
  std::array<uint8_t, kParamCount> out{};
  for (const FieldSpec& f : fields) {
    for (size_t b = 0; b < FieldWidth(f.type); ++b) out[f.param + b] = params[f.param + b];
  }
  return out;
}

void CheckCommand(std::span<const uint8_t> bytes) {
  auto command = DecodeCommand(bytes);
  if (!command.ok()) return;
  auto wire = EncodeCommand(*command);
  if (!wire.ok() || wire->size() != kCommandSize) std::abort();
  if ((*wire)[0] != bytes[0] || (*wire)[1] != bytes[1]) std::abort();
  const auto params = Canonical(SpecOf(command->opcode).Fields(), bytes.subspan(2));
  for (size_t i = 0; i < kParamCount; ++i) {
    if ((*wire)[i + 2] != params[i]) std::abort();
  }
  auto again = DecodeCommand(*wire);
  if (!again.ok() || !(*again == *command)) std::abort();
  auto frame = EncodeCommandCan(*command);
  if (!frame.ok()) std::abort();
  auto from_can = DecodeCommandCan(*frame);
  if (!from_can.ok() || !(*from_can == *command)) std::abort();
}

void CheckReply(std::span<const uint8_t> bytes, ReplyFraming framing) {
  auto reply = DecodeReply(bytes, framing);
  if (!reply.ok()) return;
  auto wire = EncodeReply(*reply, framing);
  if (!wire.ok() || wire->size() != bytes.size()) std::abort();
  const size_t body = framing == ReplyFraming::kR9 ? 1 : 0;
  for (size_t i = 0; i < body + 1; ++i) {
    if ((*wire)[i] != bytes[i]) std::abort();
  }
  const auto params = Canonical(SpecOf(reply->opcode).ReplyFields(), bytes.subspan(body + 1));
  for (size_t i = 0; i < kParamCount; ++i) {
    if ((*wire)[body + 1 + i] != params[i]) std::abort();
  }
  auto again = DecodeReply(*wire, framing);
  if (!again.ok() || !(*again == *reply)) std::abort();
  // Under R9 the first byte is RA, which the framing detector must recognise.
  if (framing == ReplyFraming::kR9) {
    auto detected = DetectReplyFraming(bytes[0], reply->response_address);
    if (!detected.ok() || *detected != ReplyFraming::kR9) std::abort();
  }
}

void CheckCan(std::span<const uint8_t> bytes) {
  CanFrame frame;
  frame.id = static_cast<uint16_t>((bytes[0] | (bytes[1] << 8)) & 0x7FF);
  frame.dlc = bytes[2];
  for (size_t i = 0; i < 8; ++i) frame.data[i] = bytes[3 + i];
  if (auto command = DecodeCommandCan(frame); command.ok()) {
    auto again = EncodeCommandCan(*command);
    if (!again.ok() || again->id != frame.id || again->dlc != 8) std::abort();
    auto back = DecodeCommandCan(*again);
    if (!back.ok() || !(*back == *command)) std::abort();
  }
  if (auto reply = DecodeReplyCan(frame); reply.ok()) {
    auto again = EncodeReplyCan(*reply);
    if (!again.ok() || again->id != frame.id || again->data[0] != frame.data[0]) std::abort();
    auto back = DecodeReplyCan(*again);
    if (!back.ok() || !(*back == *reply)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  if (size >= 2) (void)DetectReplyFraming(bytes[0], bytes[1]);
  if (size >= kReplyBodySize) CheckReply(bytes.first(kReplyBodySize), ReplyFraming::kR8);
  if (size >= kCommandSize) {
    CheckCommand(bytes.first(kCommandSize));
    CheckReply(bytes.first(kCommandSize), ReplyFraming::kR9);
  }
  if (size >= 11) CheckCan(bytes.first(11));
  return 0;
}
