// Fuzz target for dgw_transport's wire parsers: python-can udp_multicast messages (msgpack),
// the msgpack reader itself, candump log lines and --can specs. Must never crash; what
// decodes must re-encode to the same frame.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "adapters/transport/can_channel.h"
#include "adapters/transport/candump_trace.h"
#include "adapters/transport/msgpack_lite.h"
#include "adapters/transport/udp_multicast_channel.h"

namespace {

using namespace drivegw::transport;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

void DecodeMessage(const std::vector<uint8_t>& bytes) {
  auto frame = DecodePythonCanMessage(bytes);
  if (!frame.ok()) return;
  Check(frame->dlc <= kCanMaxDlc);
  auto again = DecodePythonCanMessage(EncodePythonCanMessage(*frame, 1.0));
  Check(again.ok() && *again == *frame);
}

void ParseLine(std::string_view text) {
  auto record = ParseCandumpLine(text);
  if (!record.ok()) return;
  Check(record->frame.dlc <= kCanMaxDlc);
  auto again = ParseCandumpLine(FormatCandumpLine(*record));
  Check(again.ok() && *again == *record);
}

// Valid inputs whose bytes the fuzzer input overwrites: random bytes alone rarely make a map.
std::vector<uint8_t> Overlay(std::vector<uint8_t> base, const uint8_t* data, size_t size) {
  for (size_t i = 0; i + 1 < size; i += 2) {
    if (base.empty()) break;
    base[data[i] % base.size()] = data[i + 1];
  }
  if (size % 7 == 3 && !base.empty()) base.resize(data[0] % base.size());
  return base;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t mode = data[0] % 6;
  ++data;
  --size;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  switch (mode) {
    case 0:
      DecodeMessage(std::vector<uint8_t>(data, data + size));
      break;
    case 1: {
      const std::vector<uint8_t> eight{1, 2, 3, 4, 5, 6, 7, 8};
      const CanFrame base =
          (size % 2) ? MakeCanFrame(0x1ABCDEF0, eight, true) : MakeCanRtrFrame(0x7FF, 4);
      DecodeMessage(Overlay(EncodePythonCanMessage(base, 1700000000.5), data, size));
      break;
    }
    case 2: {
      msgpack::Reader r(std::span<const uint8_t>(data, size));
      while (!r.at_end() && r.Skip().ok()) {
      }
      break;
    }
    case 3:
      ParseLine(text);
      break;
    case 4: {
      const std::string line = "(1700000000.123456) can0 1ABCDEF0#0011223344556677 T";
      const std::vector<uint8_t> base(line.begin(), line.end());
      const auto mutated = Overlay(base, data, size);
      ParseLine(std::string_view(reinterpret_cast<const char*>(mutated.data()), mutated.size()));
      break;
    }
    case 5: {
      auto spec = ParseCanSpec(text);
      if (spec.ok()) {
        auto again = ParseCanSpec(CanSpecString(*spec));
        Check(again.ok() && CanSpecString(*again) == CanSpecString(*spec));
      }
      break;
    }
  }
  return 0;
}
