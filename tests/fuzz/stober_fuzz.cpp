// Fuzz target for the STOBER object map (adapters/stober/object_map.cpp): the values the gateway
// reads off the CAN bus. Byte 0 chooses what the rest of the input is:
//   - the payload of TPDO1/TPDO2 (DecodeStatusTpdo, DecodeActualTpdo; StoberDrive::OnTpdo) and of
//     every PDO of the default layout (UnpackLayout; the simulator decodes the RPDOs);
//   - the bytes of an SDO upload of one bound object (Decode; StoberDrive::ReadParameter), the
//     object chosen by bytes 0-1 (bit 7 of byte 0 set) among
//     ObjectMap().
// Invariants: no crash; a PDO payload decodes exactly when it holds the layout's bytes (longer
// payloads are accepted, CiA 301 §7.2.2.3); what decodes and packs again gives back the bytes it
// came from; an SDO value decodes only from exactly its wire size and re-encodes to those bytes.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "adapters/stober/object_map.h"

namespace {

using namespace drivegw::stober;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

size_t LayoutBytes(const PdoLayout& layout) {
  size_t bits = 0;
  for (const PdoField& f : layout.fields) bits += WireTypeBits(f.type);
  return bits / 8;
}

void CheckPdo(const PdoLayout& layout, std::span<const uint8_t> payload) {
  auto values = UnpackLayout(layout, payload);
  Check(values.ok() == (payload.size() >= LayoutBytes(layout)));
  if (!values.ok()) return;
  Check(values->size() == layout.fields.size());
  // A boolean field holding 2..255 decodes but refuses to pack (ToRaw): nothing to compare.
  auto packed = PackLayout(layout, *values);
  if (!packed.ok()) return;
  Check(packed->size() == LayoutBytes(layout));
  for (size_t i = 0; i < packed->size(); ++i) Check((*packed)[i] == payload[i]);
}

void CheckTpdos(std::span<const uint8_t> payload) {
  const PdoLayout* t1 = FindDefaultPdo(drivegw::canopen::PdoKind::kTpdo, 1);
  const PdoLayout* t2 = FindDefaultPdo(drivegw::canopen::PdoKind::kTpdo, 2);
  Check(t1 != nullptr && t2 != nullptr);
  auto status = DecodeStatusTpdo(payload);
  Check(status.ok() == (payload.size() >= LayoutBytes(*t1)));
  if (status.ok()) {
    Check(status->status_word == (payload[0] | payload[1] << 8));
    (void)status->error();
    (void)status->done();
    Check(status->command_state() >= 0 && status->command_state() <= 3);
  }
  auto actual = DecodeActualTpdo(payload);
  Check(actual.ok() == (payload.size() >= LayoutBytes(*t2)));
  for (const PdoLayout& layout : DefaultPdoLayout()) CheckPdo(layout, payload);
}

void CheckSdo(const ObjectBinding& b, std::span<const uint8_t> bytes) {
  auto value = Decode(b, bytes);
  const size_t n = WireTypeBits(b.type) / 8;
  if (bytes.size() != n) {
    Check(!value.ok());
    return;
  }
  if (!value.ok()) {
    Check(b.boolean);  // only a boolean's 2..max refuses a value of the right size
    return;
  }
  auto again = Encode(b, *value);
  Check(again.ok());
  Check(again->size() == n);
  for (size_t i = 0; i < n; ++i) Check((*again)[i] == bytes[i]);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::span<const uint8_t> rest(data + 1, size - 1);
  if (data[0] & 0x80) {
    if (size < 2) return 0;
    const std::vector<ObjectBinding>& map = ObjectMap();
    const size_t index = (size_t{data[0] & 0x7Fu} << 8 | data[1]) % map.size();
    CheckSdo(map[index], rest.subspan(1));
  } else {
    CheckTpdos(rest);
  }
  return 0;
}
