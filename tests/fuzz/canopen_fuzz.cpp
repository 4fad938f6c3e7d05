// Fuzz target for the CANopen CiA 301 library (adapters/canopen). The input is a sequence of
// 11-byte CAN frame records: identifier low, identifier high (bits 2..0 = id bits 10..8, bit 7 =
// RTR), DLC (low nibble, 9..15 kept as the driver would report it), 8 data bytes. Every frame goes
// through every decoder (what decodes must re-encode and decode to the same value), into an
// SdoServer for node 5 (requests on 605h) and into an SdoClientTransfer on the same channel
// (responses on 585h), whose outputs must be valid SDO frames. Finally a client and the server
// run one loopback transfer whose size comes from the first byte and must succeed.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/emcy.h"
#include "adapters/canopen/nmt.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"
#include "adapters/canopen/sync.h"

namespace {

using namespace drivegw::canopen;
using drivegw::transport::CanFrame;

constexpr size_t kRecord = 11;

void Check(bool ok) {
  if (!ok) std::abort();
}

// Small dictionary: anything written can be read back (at most 64 objects, 2100h always for the
// loopback); 1000h:00 is fixed; 1008h read-only.
class Objects : public ObjectAccess {
 public:
  absl::StatusOr<std::vector<uint8_t>> Read(uint16_t index, uint8_t sub) override {
    if (index == 0x1000 && sub == 0) return std::vector<uint8_t>{0x92, 0x01, 0x02, 0x00};
    auto it = map_.find({index, sub});
    if (it == map_.end()) return absl::NotFoundError("no object");
    return it->second;
  }
  absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) override {
    if (index == 0x1008) return SdoAbortStatus(SdoAbortCode::kReadOnly, "1008h");
    if (index != 0x2100 && map_.size() > 64) return absl::ResourceExhaustedError("full");
    map_[{index, sub}] = std::vector<uint8_t>(data.begin(), data.end());
    return absl::OkStatus();
  }

 private:
  std::map<std::pair<uint16_t, uint8_t>, std::vector<uint8_t>> map_;
};

CanFrame FrameOf(std::span<const uint8_t> r) {
  CanFrame f;
  f.id = static_cast<uint32_t>(r[0] | (r[1] & 0x07) << 8);
  f.rtr = (r[1] & 0x80) != 0;
  f.dlc = r[2] & 0x0F;
  for (size_t i = 0; i < 8; ++i) f.data[i] = r[3 + i];
  return f;
}

bool SamePayload(const CanFrame& a, const CanFrame& b) {
  const auto pa = a.payload();
  const auto pb = b.payload();
  return a.id == b.id && pa.size() == pb.size() && std::equal(pa.begin(), pa.end(), pb.begin());
}

bool SameSdo(const SdoFrame& a, const SdoFrame& b) {
  return a.command == b.command && a.index == b.index && a.sub == b.sub &&
         a.expedited == b.expedited && a.size_indicated == b.size_indicated && a.size == b.size &&
         a.toggle == b.toggle && a.last == b.last && a.abort_code == b.abort_code &&
         a.data_size == b.data_size &&
         std::equal(a.data.begin(), a.data.begin() + a.data_size, b.data.begin());
}

void CheckSdoBytes(std::span<const uint8_t> bytes, SdoDirection direction) {
  auto f = DecodeSdo(bytes, direction);
  if (!f.ok()) {
    Check((bytes.size() != 8) || (bytes[0] >> 5) == 7);
    return;
  }
  Check(f->data_size <= 7);
  auto wire = EncodeSdo(*f, direction);
  if (f->command == SdoCommand::kBlockUpload || f->command == SdoCommand::kBlockDownload) {
    Check(!wire.ok());
    return;
  }
  Check(wire.ok());
  auto again = DecodeSdo(*wire, direction);
  Check(again.ok() && SameSdo(*f, *again));
}

// Anything the state machines send is an 8-byte SDO frame of the right direction and id.
void CheckSent(const CanFrame& f, uint32_t id, SdoDirection direction) {
  Check(f.id == id && f.dlc == 8 && !f.rtr && !f.extended);
  auto d = DecodeSdo(f.payload(), direction);
  Check(d.ok());
  Check(d->command != SdoCommand::kBlockUpload && d->command != SdoCommand::kBlockDownload);
}

void CheckDecoders(const CanFrame& frame) {
  if (auto c = ClassifyCobId(frame.id); c.ok()) {
    auto back = CobId(c->function, c->node);
    Check(back.ok() && *back == frame.id);
  }
  if (auto nmt = DecodeNmt(frame); nmt.ok()) {
    auto wire = EncodeNmt(*nmt);
    Check(wire.ok() && SamePayload(*wire, frame));
  }
  if (auto hb = DecodeErrorControl(frame); hb.ok()) {
    auto wire = EncodeErrorControl(*hb);
    Check(wire.ok());
    auto again = DecodeErrorControl(*wire);
    Check(again.ok() && *again == *hb);
    Check(hb->toggle || wire->data[0] == (frame.data[0] & 0x7F));
  }
  if (auto sync = DecodeSync(frame); sync.ok()) {
    auto wire = EncodeSync(*sync);
    Check(wire.ok() && SamePayload(*wire, frame));
  }
  if (auto emcy = DecodeEmcy(frame); emcy.ok()) {
    auto wire = EncodeEmcy(*emcy);
    Check(wire.ok() && wire->id == frame.id);
    Check(DecodeEmcy(*wire).value() == *emcy);
    Check(!EmcyCodeName(emcy->error_code).empty());
  }
  CheckSdoBytes(frame.payload(), SdoDirection::kRequest);
  CheckSdoBytes(frame.payload(), SdoDirection::kResponse);
  // The data bytes as a PDO: mapping from the identifier's bits, unpack/pack round trip.
  PdoMapping mapping;
  size_t bits = 0;
  for (size_t i = 0; i < 4; ++i) {
    const uint8_t width = static_cast<uint8_t>(1 + ((frame.id >> (i * 3)) & 0x07) * 4);
    if (bits + width > kPdoMaxBits) break;
    mapping.push_back({static_cast<uint16_t>(0x6000 + i), 0, width});
    bits += width;
  }
  if (auto raw = UnpackPdoRaw(mapping, frame.payload()); raw.ok()) {
    auto packed = PackPdoRaw(mapping, *raw);
    Check(packed.ok() && packed->size() == MappingBytes(mapping));
    auto again = UnpackPdoRaw(mapping, *packed);
    Check(again.ok() && *again == *raw);
  } else {
    Check(frame.payload().size() < MappingBytes(mapping));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> input(data, size);
  const SdoChannel channel = DefaultSdoChannel(5).value();
  Objects objects;
  SdoServer server(channel, objects, 4096);
  const bool upload = size > 0 && (data[0] & 1) != 0;
  auto make_client = [&] {
    return upload ? SdoClientTransfer::Upload(channel, 0x2000, 1, 256)
                  : SdoClientTransfer::Download(channel, 0x2000, 1,
                                                std::vector<uint8_t>(size % 40, 0xA5));
  };
  SdoClientTransfer client = make_client();
  CheckSent(client.Start(), 0x605, SdoDirection::kRequest);

  for (size_t off = 0; off + kRecord <= input.size(); off += kRecord) {
    const CanFrame frame = FrameOf(input.subspan(off, kRecord));
    CheckDecoders(frame);
    if (auto response = server.OnFrame(frame)) {
      CheckSent(*response, 0x585, SdoDirection::kResponse);
    }
    const SdoStep step = client.OnFrame(frame);
    if (step.frame) CheckSent(*step.frame, 0x605, SdoDirection::kRequest);
    if (step.kind == SdoStep::Kind::kFailed) Check(!step.status.ok());
    if (step.kind == SdoStep::Kind::kDone || step.kind == SdoStep::Kind::kFailed) {
      Check(client.finished());
      client = make_client();
      CheckSent(client.Start(), 0x605, SdoDirection::kRequest);
    }
  }
  if (auto t = server.Timeout()) CheckSent(*t, 0x585, SdoDirection::kResponse);
  if (auto t = client.Timeout(); t.frame) CheckSent(*t.frame, 0x605, SdoDirection::kRequest);

  // Loopback: whatever state the fuzzed frames left the server in, a fresh transfer succeeds.
  const size_t n = size == 0 ? 0 : data[0] % 64;
  std::vector<uint8_t> payload(n);
  for (size_t i = 0; i < n; ++i) payload[i] = static_cast<uint8_t>(i * 7 + size);
  SdoClientTransfer down = SdoClientTransfer::Download(channel, 0x2100, 2, payload);
  CanFrame request = down.Start();
  for (int guard = 0;; ++guard) {
    Check(guard < 64);
    auto response = server.OnFrame(request);
    Check(response.has_value());
    const SdoStep step = down.OnFrame(*response);
    if (step.kind == SdoStep::Kind::kDone) break;
    Check(step.kind == SdoStep::Kind::kSend);
    request = *step.frame;
  }
  SdoClientTransfer up = SdoClientTransfer::Upload(channel, 0x2100, 2);
  request = up.Start();
  for (int guard = 0;; ++guard) {
    Check(guard < 64);
    auto response = server.OnFrame(request);
    Check(response.has_value());
    const SdoStep step = up.OnFrame(*response);
    if (step.kind == SdoStep::Kind::kDone) {
      Check(step.data == payload);
      break;
    }
    Check(step.kind == SdoStep::Kind::kSend);
    request = *step.frame;
  }
  return 0;
}
