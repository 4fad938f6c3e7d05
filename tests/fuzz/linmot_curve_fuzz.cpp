// Fuzz target for the LinMot curve as the LinUDP Curve Service moves it
// (adapters/linmot/linudp/curve_info_block.cpp, curve_service.cpp; decisions 706, 707): what a
// drive sends back when a curve is read. Byte 0 (mod 4) chooses what the rest of the input is:
//   0: an info block (DecodeCurveInfoBlock): decodes exactly when it has 70 bytes or more, and
//      encoding the result decodes to the same block;
//   1: a data block (DecodeCurveData): decodes exactly when its size is a multiple of 4 and
//      encodes back to the same bytes;
//   2: an info block (70 bytes) and its data block (FromWireCurve): a curve that also passes
//      ValidateCurveShape goes back to wire form (ToWireCurve) and gives the same curve;
//   3: the drive's RTC replies, 8 bytes each (count, status, word2, word3, word4 little-endian,
//      one byte spare), to CurveService::Upload of curve 1 and then to Download of a fixed
//      two-point curve; when they run out the transaction times out. A returned curve has as
//      many points as its info block counts.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "adapters/core/curve.h"
#include "adapters/linmot/linudp/curve_info_block.h"
#include "adapters/linmot/linudp/curve_service.h"

namespace {

using namespace drivegw::linmot::linudp;
using drivegw::LinMotParametricCurve;

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

void CheckInfo(std::span<const uint8_t> bytes) {
  auto info = DecodeCurveInfoBlock(bytes);
  Check(info.ok() == (bytes.size() >= kCurveInfoBlockSize));
  if (!info.ok()) return;
  Check(info->name.size() < kCurveNameBytes);
  const std::vector<uint8_t> wire = EncodeCurveInfoBlock(*info);
  Check(wire.size() == kCurveInfoBlockSize);
  auto again = DecodeCurveInfoBlock(wire);
  Check(again.ok() && *again == *info);
}

void CheckData(std::span<const uint8_t> bytes) {
  auto points = DecodeCurveData(bytes);
  Check(points.ok() == (bytes.size() % kCurvePointSize == 0));
  if (!points.ok()) return;
  Check(points->size() * kCurvePointSize == bytes.size());
  const std::vector<uint8_t> wire = EncodeCurveData(*points);
  Check(wire == std::vector<uint8_t>(bytes.begin(), bytes.end()));
}

void CheckWireCurve(std::span<const uint8_t> bytes) {
  if (bytes.size() < kCurveInfoBlockSize) return;
  auto info = DecodeCurveInfoBlock(bytes.first(kCurveInfoBlockSize));
  Check(info.ok());
  std::span<const uint8_t> data = bytes.subspan(kCurveInfoBlockSize);
  data = data.first(data.size() - data.size() % kCurvePointSize);
  auto points = DecodeCurveData(data);
  Check(points.ok());
  const WireCurve wire{*info, *points};
  auto curve = FromWireCurve(wire);
  if (!curve.ok()) return;
  // FromWireCurve checks the layout, not the model's ranges (curve ID 1..100, scales): the first
  // timed run found ID 65535 accepted and ToWireCurve refusing it (docs/reliability.md
  // "Fuzzing"). Only a curve the gateway itself would download must come back unchanged.
  if (!drivegw::ValidateCurveShape(drivegw::Curve{"c", "", *curve}).ok()) return;
  auto back = ToWireCurve(*curve);  // the gateway downloads under its own name
  Check(back.ok());
  auto again = FromWireCurve(*back);
  Check(again.ok() && *again == *curve);
}

// The drive's side of the RTC transactions, replayed from the input.
class ScriptedDrive {
 public:
  explicit ScriptedDrive(std::span<const uint8_t> script) : script_(script) {}
  absl::StatusOr<RtcReply> Transact(uint8_t, uint16_t, uint16_t, uint16_t,
                                    const std::string& what) {
    if (script_.size() < 8) return absl::DeadlineExceededError(what + ": no reply");
    const std::span<const uint8_t> b = script_.first(8);
    script_ = script_.subspan(8);
    auto word = [&](size_t i) { return static_cast<uint16_t>(b[i] | b[i + 1] << 8); };
    return RtcReply{b[0], b[1], word(2), word(4), word(6)};
  }

 private:
  std::span<const uint8_t> script_;
};

void CheckService(std::span<const uint8_t> script) {
  ScriptedDrive drive(script);
  CurveService service(
      "fz", [&drive](uint8_t c, uint16_t w2, uint16_t w3, uint16_t w4, const std::string& what) {
        return drive.Transact(c, w2, w3, w4, what);
      });
  auto up = service.Upload(1);
  if (up.ok()) Check(up->points.size() == up->info.point_count);
  LinMotParametricCurve model;
  model.curve_id = 2;
  model.x_length_s = 0.5;
  model.points = {0, 10000};
  auto wire = ToWireCurve(model);
  Check(wire.ok());
  (void)service.Download(*wire);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::span<const uint8_t> rest(data + 1, size - 1);
  switch (data[0] % 4) {
    case 0:
      CheckInfo(rest);
      break;
    case 1:
      CheckData(rest);
      break;
    case 2:
      CheckWireCurve(rest);
      break;
    default:
      CheckService(rest);
      break;
  }
  return 0;
}
