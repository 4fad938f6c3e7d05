// Fuzz target for the LinMot DeviceNet codec: byte 0 picks a message kind; the rest is decoded
// as that kind, and what decodes must re-encode to the same bytes (abort() otherwise); fragment
// sequences are fed to Reassemblers whose output must survive a Fragmenter round trip.
// Input layout per mode: tests/fuzz/corpus/linmot_devicenet/README.md.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/commands.h"

namespace {

using namespace drivegw::linmot::devicenet;
using Bytes = std::vector<uint8_t>;
using Span = std::span<const uint8_t>;

void Check(bool ok) {
  if (!ok) std::abort();
}

bool Same(Span a, Span b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin());
}

// The layouts a gateway meets: the §13.1 fixtures and §7.8 candidate Q.
std::vector<IoLayout> Layouts() {
  IoLayout f1_prime = DefaultLayoutP();
  f1_prime.modules.control_in = false;
  IoLayout q;
  q.modules = ModuleSet{true, false, true, true, false, true, true};
  IoLayout big_endian = DefaultLayoutP();
  big_endian.byte_order = ByteOrder::kBigEndian;
  return {DefaultLayoutP(), f1_prime, Example1Layout(), Example2Layout(), q, big_endian};
}

void CheckSlot(CommandSlot slot, Module module, uint16_t response_value) {
  auto d = DecodeCommand(slot, module);
  if (!d.ok()) {
    Check(GetCodedError(d.status()).has_value());  // every refusal names the coded error
    return;
  }
  Check(d->spec != nullptr && d->word.raw() == slot.word && d->raw_value == slot.value);
  (void)CheckRange(*d->spec, d->value);
  // Re-encoding the decoded command (non-strict) gives the same slot, reserved bits aside.
  Command c{d->word.id, d->motor, d->word.toggle, d->value};
  auto again = EncodeCommand(c, module, /*strict=*/false);
  if (again.ok()) {
    // Reserved bits 11..8 are dropped; motor bits survive only where they select a motor.
    const uint16_t expected =
        static_cast<uint16_t>((slot.word & 0x00FF) | (d->motor ? MotorBit(*d->motor) << 12 : 0));
    Check(again->word == expected);
    Check(d->spec->request.type == ValueType::kDontCare || again->value == slot.value);
  }
  if (d->spec->response_kind == ResponseKind::kNoResponse) {
    Check(!EncodeResponse(*d).ok());
    return;
  }
  auto r = EncodeResponse(*d, d->spec->response.type == ValueType::kInt16
                                  ? int32_t{static_cast<int16_t>(response_value)}
                                  : int32_t{response_value});
  if (!r.ok()) return;
  Check(ResponseMatches(slot, *r));
  auto back = DecodeResponse(*r);
  Check(back.ok() && back->spec == d->spec && back->raw_value == r->value);
}

void CheckConsumed(const IoLayout& layout, Span b) {
  auto img = DecodeConsumed(layout, b);
  if (!img.ok()) {
    Check(b.size() != ConsumedSize(layout));
    return;
  }
  auto again = EncodeConsumed(layout, *img);
  Check(again.ok() && Same(*again, b));
  if (img->addressed) CheckSlot(*img->addressed, Module::kAddressed, 0x1234);
  for (CommandSlot s : img->direct) CheckSlot(s, Module::kDirect, 0);
}

void CheckProduced(const IoLayout& layout, Span b) {
  auto img = DecodeProduced(layout, b);
  if (!img.ok()) {
    Check(b.size() != ProducedSize(layout));
    return;
  }
  auto again = EncodeProduced(layout, *img);
  Check(again.ok() && Same(*again, b));
  if (img->addressed) (void)DecodeResponse(*img->addressed);
}

void CheckExplicitRequest(Span b, BodyFormat format) {
  auto r = DecodeExplicitRequest(b, format);
  if (!r.ok()) return;
  auto again = EncodeExplicitRequest(*r, format);
  Check(again.ok() && Same(*again, b));
  (void)DecodeAllocate(*r);
  (void)DecodeRelease(*r);
}

void CheckExplicitResponse(Span b) {
  auto r = DecodeExplicitResponse(b);
  if (!r.ok()) return;
  auto again = EncodeExplicitResponse(*r);
  Check(again.ok() && Same(*again, b));
  (void)DecodeAllocateResponse(*r);
  auto e = DecodeErrorResponse(*r);
  if (e.ok()) {
    const absl::Status s = ErrorResponseStatus(0x0E, *e);
    Check(GetErrorResponse(s) == *e);
  }
}

void CheckFragmentAck(Span b) {
  auto a = DecodeFragmentAck(b);
  if (!a.ok()) return;
  Check(IsFragmentAck(b));
  auto again = EncodeFragmentAck(*a);
  Check(again.ok() && Same(*again, b));
}

void CheckUcmm(Span b) {
  if (auto r = DecodeUcmmOpenRequest(b); r.ok()) {
    auto again = EncodeUcmmOpenRequest(*r);
    Check(again.ok() && again->size() == 4 && (*again)[0] == b[0] && (*again)[1] == b[1] &&
          (*again)[2] == (b[2] & 0x0F) && (*again)[3] == b[3]);
  }
  if (auto r = DecodeUcmmOpenResponse(b); r.ok()) {
    auto again = EncodeUcmmOpenResponse(*r);
    Check(again.ok() && again->size() == 6 && (*again)[2] == (b[2] & 0x0F));
  }
}

// A completed message must come back unchanged through a Fragmenter and a fresh Reassembler.
void CheckRefragment(const Bytes& message, bool is_explicit, size_t max) {
  auto fr = is_explicit ? Fragmenter::ForExplicit(message) : Fragmenter::ForIo(message);
  if (!fr.ok()) return;  // fits one frame, or more than 64 fragments
  Reassembler r(max);
  std::optional<Bytes> out;
  for (size_t i = 0; i < fr->fragment_count(); ++i) {
    auto step = is_explicit ? r.FeedExplicit(fr->fragment(i)) : r.FeedIo(fr->fragment(i));
    Check(step.ok());
    if (step->has_value()) {
      Check(i + 1 == fr->fragment_count());
      out = **step;
    }
  }
  Check(out.has_value() && *out == message);
}

// [max size][len][bytes] [len][bytes] ...
void FeedSequence(Span rest, bool is_explicit) {
  if (rest.empty()) return;
  const size_t max = 8 + rest[0] * 2u;
  Reassembler r(max);
  size_t at = 1;
  while (at < rest.size()) {
    const size_t len = rest[at] % 10;
    ++at;
    const Span frag = rest.subspan(at, std::min(len, rest.size() - at));
    at += frag.size();
    auto step = is_explicit ? r.FeedExplicit(frag) : r.FeedIo(frag);
    Check(r.buffered() <= max);
    if (!step.ok()) continue;
    if (step->has_value()) {
      Check(r.idle());
      const Bytes& m = **step;
      Check(m.size() <= max + (is_explicit ? 1 : 0));
      CheckRefragment(m, is_explicit, max + 1);
      if (is_explicit) {
        CheckExplicitRequest(m, BodyFormat::k8_8);
        CheckExplicitResponse(m);
      }
    }
  }
}

void CheckFrame(Span rest) {
  if (rest.size() < 2) return;
  const uint16_t raw = static_cast<uint16_t>(rest[0] | (rest[1] << 8));
  const Span payload = rest.subspan(2, std::min<size_t>(8, rest.size() - 2));
  auto frame = MakeFrame(raw, payload);
  if (!frame.ok()) {
    Check(raw > kMaxIdentifier);
    return;
  }
  auto text = ParseFrame(FrameToString(*frame));
  Check(text.ok() && *text == *frame);
  auto id = DecodeIdentifier(raw);
  if (!id.ok()) return;
  auto again = EncodeIdentifier(*id);
  Check(again.ok() && *again == raw);
  const uint8_t msg = id->message_id;
  switch (id->group) {
    case MessageGroup::kGroup2:
      if (msg == kG2ExplicitRequest || msg == kG2UnconnectedRequest) {
        CheckExplicitRequest(payload, BodyFormat::k8_8);
        CheckFragmentAck(payload);
        Reassembler r;
        (void)r.FeedExplicit(payload);
      } else if (msg == kG2ExplicitResponse) {
        CheckExplicitResponse(payload);
        CheckFragmentAck(payload);
      } else if (msg == kG2DuplicateMacCheck) {
        auto d = DecodeDuplicateMacCheck(payload);
        if (d.ok()) {
          auto e = EncodeDuplicateMacCheck(*d);
          Check(e.ok() && Same(*e, payload));
        }
      } else if (msg == kG2PollCommand) {
        for (const IoLayout& l : Layouts()) {
          CheckConsumed(l, payload);
          IoReceiver rx(ConsumedSize(l));
          (void)rx.Feed(payload);
        }
      }
      break;
    case MessageGroup::kGroup1:
      if (msg == kG1PollResponse || msg == kG1ChangeOfState) {
        for (const IoLayout& l : Layouts()) {
          CheckProduced(l, payload);
          IoReceiver rx(ProducedSize(l));
          (void)rx.Feed(payload);
        }
      }
      break;
    case MessageGroup::kGroup3:
      CheckUcmm(payload);
      break;
    case MessageGroup::kGroup4:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const Span rest(data + 1, size - 1);
  switch (data[0] % 8) {
    case 0:  // one CAN frame: [id lo][id hi][payload]
      CheckFrame(rest);
      break;
    case 1:  // explicit message: [body format][bytes]
      if (!rest.empty()) {
        CheckExplicitRequest(rest.subspan(1), static_cast<BodyFormat>(rest[0] % 4));
        CheckExplicitResponse(rest.subspan(1));
        CheckFragmentAck(rest.subspan(1));
        CheckUcmm(rest.subspan(1));
      }
      break;
    case 2:  // I/O image: [modules, bit 7 = big-endian][master drives][bytes]
      if (rest.size() >= 2) {
        IoLayout l;
        const uint8_t m = rest[0];
        l.modules = ModuleSet{(m & 1) != 0,  (m & 2) != 0,  (m & 4) != 0, (m & 8) != 0,
                              (m & 16) != 0, (m & 32) != 0, (m & 64) != 0};
        l.byte_order = (m & 0x80) ? ByteOrder::kBigEndian : ByteOrder::kLittleEndian;
        l.master_drives = rest[1];
        if (!ValidateLayout(l).ok()) {
          Check(!DecodeConsumed(l, rest.subspan(2)).ok());
          break;
        }
        CheckConsumed(l, rest.subspan(2));
        CheckProduced(l, rest.subspan(2));
      }
      break;
    case 3:  // command slot: [module][word lo][word hi][value lo][value hi][resp lo][resp hi]
      if (rest.size() >= 7) {
        const CommandSlot slot{static_cast<uint16_t>(rest[1] | (rest[2] << 8)),
                               static_cast<uint16_t>(rest[3] | (rest[4] << 8))};
        CheckSlot(slot, (rest[0] & 1) ? Module::kDirect : Module::kAddressed,
                  static_cast<uint16_t>(rest[5] | (rest[6] << 8)));
      }
      break;
    case 4:  // I/O fragment sequence: [max][len][bytes]...
      FeedSequence(rest, false);
      break;
    case 5:  // explicit fragment sequence
      FeedSequence(rest, true);
      break;
    case 6:  // whole message through Fragmenter and Reassembler
      CheckRefragment(Bytes(rest.begin(), rest.end()), false, kMaxFragmentedMessage);
      CheckRefragment(Bytes(rest.begin(), rest.end()), true, kMaxFragmentedMessage);
      break;
    case 7: {  // candump-style text
      auto f = ParseFrame(std::string(rest.begin(), rest.end()));
      if (f.ok()) {
        auto again = ParseFrame(FrameToString(*f));
        Check(again.ok() && *again == *f);
      }
      break;
    }
  }
  return 0;
}
