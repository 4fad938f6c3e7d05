// The LinMot curve as the Curve Service moves it: a 70-byte info block and a data block of SInt32
// set points (linmot-linudp.md §5.3 0x50-0x62, L310; linmot-mc.md §7 L989-L1011). The gateway's
// curve service and the simulated drive both use this one layout
// (docs/decisions/706-linmot-curve-info-block.md). Pure: bytes <-> structs, no I/O.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/curve.h"

namespace drivegw::linmot::linudp {

// Info block size: what [CS] announces with 0x50 (linmot-linudp.md L310 "info 70").
inline constexpr size_t kCurveInfoBlockSize = 70;
// Bytes per data block entry: one SInt32 set point (linmot-mc.md §7 L1001).
inline constexpr size_t kCurvePointSize = 4;
// Object type "position vs time" (decision 706).
inline constexpr uint16_t kCurveObjectPositionVsTime = 0x0003;
// Dimension UPIDs of the x and y axes (decision 706): time and position.
inline constexpr uint16_t kCurveDimTime = 0x001A;
inline constexpr uint16_t kCurveDimPosition = 0x0005;
// Wizard type marking "the three wizard words hold the gateway's default start parameters"
// ('D','G'); any other value reads as offset 0, amplitude 100 %, time scale 100 %.
inline constexpr uint16_t kCurveWizardGatewayDefaults = 0x4744;
// Name field: 22 bytes, NUL-padded, so at most 21 characters.
inline constexpr size_t kCurveNameBytes = 22;

// The info block field by field, in wire units (byte offsets in decision 706).
struct CurveInfoBlock {
  uint16_t data_offset = kCurveInfoBlockSize;          // @0
  uint16_t object_type = kCurveObjectPositionVsTime;   // @2
  uint16_t point_count = 0;                            // @4
  uint16_t data_type_size = kCurvePointSize;           // @6
  std::string name;                                    // @8, 22 bytes
  uint16_t curve_id = 0;                               // @30
  uint32_t x_length = 0;                               // @32, 10 µs (linmot-mc.md §7 L1000)
  uint16_t x_dim_upid = kCurveDimTime;                 // @36
  uint16_t y_dim_upid = kCurveDimPosition;             // @38
  uint16_t wizard_type = kCurveWizardGatewayDefaults;  // @40
  int32_t default_offset = 0;                          // @42, 0.1 µm (14C9h's unit, §5.5 L524)
  int32_t default_amplitude_scale = 1000;              // @46, 0.1 % (14CAh)
  uint32_t default_time_scale = 10000;                 // @50, 0.01 % (14CBh)
  friend bool operator==(const CurveInfoBlock&, const CurveInfoBlock&) = default;
};

// Exactly kCurveInfoBlockSize bytes, little-endian; bytes 54..69 (unused wizard words) are 0.
std::vector<uint8_t> EncodeCurveInfoBlock(const CurveInfoBlock& info);
// InvalidArgument when the block is shorter than kCurveInfoBlockSize (naming both sizes).
absl::StatusOr<CurveInfoBlock> DecodeCurveInfoBlock(std::span<const uint8_t> bytes);

// The data block: point i at byte offset 4 i, little-endian SInt32 (§7 L1710-L1718).
std::vector<uint8_t> EncodeCurveData(std::span<const int32_t> points);
// InvalidArgument when the size is not a multiple of 4.
absl::StatusOr<std::vector<int32_t>> DecodeCurveData(std::span<const uint8_t> bytes);

// A curve in wire form: what is downloaded and what a read-back is compared with.
struct WireCurve {
  CurveInfoBlock info;
  std::vector<int32_t> points;
  friend bool operator==(const WireCurve&, const WireCurve&) = default;
};

// `curve` in wire units (x-Length in 10 µs, scales in 0.1 % / 0.01 %, offset in 0.1 µm).
// InvalidArgument naming the field for what ValidateCurveShape refuses (IDs, point counts,
// ranges, units that are not whole).
absl::StatusOr<WireCurve> ToWireCurve(const LinMotParametricCurve& curve,
                                      const std::string& name = "drivegw");
// The model of a stored curve. InvalidArgument naming the field when the block does not describe
// a position/time curve of SInt32 points whose count matches the data block.
absl::StatusOr<LinMotParametricCurve> FromWireCurve(const WireCurve& wire);

// The first field (info block order, then "points[i]") in which `got` differs from `want`, as
// "x_length: sent 50000, read 50001"; empty when they are equal.
std::string FirstDifference(const WireCurve& want, const WireCurve& got);

}  // namespace drivegw::linmot::linudp
