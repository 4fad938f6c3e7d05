// Curve info block and data block codec (docs/decisions/706-linmot-curve-info-block.md).
#include "adapters/linmot/linudp/curve_info_block.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace drivegw::linmot::linudp {
namespace {

using L = LinMotParametricCurve;

void Put16(std::vector<uint8_t>& b, size_t at, uint16_t v) {
  b[at] = static_cast<uint8_t>(v);
  b[at + 1] = static_cast<uint8_t>(v >> 8);
}
void Put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (size_t i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
uint16_t Get16(std::span<const uint8_t> b, size_t at) {
  return static_cast<uint16_t>(b[at] | (b[at + 1] << 8));
}
uint32_t Get32(std::span<const uint8_t> b, size_t at) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v |= static_cast<uint32_t>(b[at + i]) << (8 * i);
  return v;
}

// Byte offsets (decision 706; x-Length at 32 is linmot-mc.md §7 L1000).
constexpr size_t kAtDataOffset = 0;
constexpr size_t kAtObjectType = 2;
constexpr size_t kAtPointCount = 4;
constexpr size_t kAtDataTypeSize = 6;
constexpr size_t kAtName = 8;
constexpr size_t kAtCurveId = 30;
constexpr size_t kAtXLength = 32;
constexpr size_t kAtXDim = 36;
constexpr size_t kAtYDim = 38;
constexpr size_t kAtWizardType = 40;
constexpr size_t kAtOffset = 42;
constexpr size_t kAtAmplitude = 46;
constexpr size_t kAtTimeScale = 50;

// A value in `unit` steps as a whole number, or an error naming the field.
absl::StatusOr<int64_t> Whole(const char* field, double value, double unit, double min,
                              double max) {
  const double steps = value / unit;
  const double rounded = std::round(steps);
  if (!std::isfinite(steps) || std::abs(steps - rounded) > 1e-6 * std::max(1.0, std::abs(steps)) ||
      rounded < min || rounded > max) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " is not a whole number of ",
                                                   unit, " in [", min * unit, ", ", max * unit,
                                                   "]"));
  }
  return static_cast<int64_t>(rounded);
}

}  // namespace

std::vector<uint8_t> EncodeCurveInfoBlock(const CurveInfoBlock& info) {
  std::vector<uint8_t> b(kCurveInfoBlockSize, 0);
  Put16(b, kAtDataOffset, info.data_offset);
  Put16(b, kAtObjectType, info.object_type);
  Put16(b, kAtPointCount, info.point_count);
  Put16(b, kAtDataTypeSize, info.data_type_size);
  for (size_t i = 0; i < info.name.size() && i + 1 < kCurveNameBytes; ++i) {
    b[kAtName + i] = static_cast<uint8_t>(info.name[i]);
  }
  Put16(b, kAtCurveId, info.curve_id);
  Put32(b, kAtXLength, info.x_length);
  Put16(b, kAtXDim, info.x_dim_upid);
  Put16(b, kAtYDim, info.y_dim_upid);
  Put16(b, kAtWizardType, info.wizard_type);
  Put32(b, kAtOffset, static_cast<uint32_t>(info.default_offset));
  Put32(b, kAtAmplitude, static_cast<uint32_t>(info.default_amplitude_scale));
  Put32(b, kAtTimeScale, info.default_time_scale);
  return b;
}

absl::StatusOr<CurveInfoBlock> DecodeCurveInfoBlock(std::span<const uint8_t> b) {
  if (b.size() < kCurveInfoBlockSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "curve info block: ", b.size(), " bytes, the layout needs ", kCurveInfoBlockSize));
  }
  CurveInfoBlock info;
  info.data_offset = Get16(b, kAtDataOffset);
  info.object_type = Get16(b, kAtObjectType);
  info.point_count = Get16(b, kAtPointCount);
  info.data_type_size = Get16(b, kAtDataTypeSize);
  for (size_t i = 0; i < kCurveNameBytes - 1 && b[kAtName + i] != 0; ++i) {
    info.name.push_back(static_cast<char>(b[kAtName + i]));
  }
  info.curve_id = Get16(b, kAtCurveId);
  info.x_length = Get32(b, kAtXLength);
  info.x_dim_upid = Get16(b, kAtXDim);
  info.y_dim_upid = Get16(b, kAtYDim);
  info.wizard_type = Get16(b, kAtWizardType);
  if (info.wizard_type == kCurveWizardGatewayDefaults) {
    info.default_offset = static_cast<int32_t>(Get32(b, kAtOffset));
    info.default_amplitude_scale = static_cast<int32_t>(Get32(b, kAtAmplitude));
    info.default_time_scale = Get32(b, kAtTimeScale);
  }
  return info;
}

std::vector<uint8_t> EncodeCurveData(std::span<const int32_t> points) {
  std::vector<uint8_t> b(points.size() * kCurvePointSize, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    Put32(b, i * kCurvePointSize, static_cast<uint32_t>(points[i]));
  }
  return b;
}

absl::StatusOr<std::vector<int32_t>> DecodeCurveData(std::span<const uint8_t> b) {
  if (b.size() % kCurvePointSize != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("curve data block: ", b.size(), " bytes is not a whole number of SInt32"));
  }
  std::vector<int32_t> points(b.size() / kCurvePointSize);
  for (size_t i = 0; i < points.size(); ++i) {
    points[i] = static_cast<int32_t>(Get32(b, i * kCurvePointSize));
  }
  return points;
}

absl::StatusOr<WireCurve> ToWireCurve(const LinMotParametricCurve& curve, const std::string& name) {
  if (absl::Status s = ValidateCurveShape(Curve{name, "", curve}); !s.ok()) return s;
  WireCurve w;
  w.points = curve.points;
  CurveInfoBlock& i = w.info;
  i.point_count = static_cast<uint16_t>(curve.points.size());  // <= kMaxPoints (validated)
  i.name = name.substr(0, kCurveNameBytes - 1);
  i.curve_id = static_cast<uint16_t>(curve.curve_id);
  auto x = Whole("x_length_s", curve.x_length_s, L::kTimeUnitS, 1, 4294967295.0);
  if (!x.ok()) return x.status();
  i.x_length = static_cast<uint32_t>(*x);
  auto offset = Whole("offset_mm", curve.offset_mm, L::kPointUnitMm,
                      std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max());
  if (!offset.ok()) return offset.status();
  i.default_offset = static_cast<int32_t>(*offset);
  auto amp = Whole("amplitude_scale_pct", curve.amplitude_scale_pct, L::kAmplitudeScaleUnitPct,
                   -20000, 20000);
  if (!amp.ok()) return amp.status();
  i.default_amplitude_scale = static_cast<int32_t>(*amp);
  auto time = Whole("time_scale_pct", curve.time_scale_pct, L::kTimeScaleUnitPct, 1, 20000);
  if (!time.ok()) return time.status();
  i.default_time_scale = static_cast<uint32_t>(*time);
  return w;
}

absl::StatusOr<LinMotParametricCurve> FromWireCurve(const WireCurve& w) {
  const CurveInfoBlock& i = w.info;
  auto bad = [&](const char* field, int64_t value, const std::string& want) {
    return absl::InvalidArgumentError(absl::StrCat("curve ", i.curve_id, " info block ", field,
                                                   ": ", value, ", expected ", want));
  };
  if (i.object_type != kCurveObjectPositionVsTime) {
    return bad("object_type", i.object_type, "3 (position vs time)");
  }
  if (i.data_type_size != kCurvePointSize) return bad("data_type_size", i.data_type_size, "4");
  if (i.y_dim_upid != kCurveDimPosition) return bad("y_dim_upid", i.y_dim_upid, "5 (position)");
  if (i.point_count != w.points.size()) {
    return bad("point_count", i.point_count,
               absl::StrCat(w.points.size(), " (the data block's points)"));
  }
  LinMotParametricCurve c;
  c.curve_id = i.curve_id;
  // Divisions by the exact step counts per unit: the nearest double to the decimal value, so a
  // curve given as 0.5 s / 10 mm reads back equal.
  c.x_length_s = static_cast<double>(i.x_length) / 1e5;
  c.y_unit = L::YUnit::kPosition0p1um;
  c.points = w.points;
  c.offset_mm = static_cast<double>(i.default_offset) / 1e4;
  c.amplitude_scale_pct = static_cast<double>(i.default_amplitude_scale) / 10.0;
  c.time_scale_pct = static_cast<double>(i.default_time_scale) / 100.0;
  return c;
}

std::string FirstDifference(const WireCurve& want, const WireCurve& got) {
  const CurveInfoBlock& a = want.info;
  const CurveInfoBlock& b = got.info;
  auto diff = [](const char* field, auto sent, auto read) {
    return absl::StrCat(field, ": sent ", sent, ", read ", read);
  };
  if (a.data_offset != b.data_offset) return diff("data_offset", a.data_offset, b.data_offset);
  if (a.object_type != b.object_type) return diff("object_type", a.object_type, b.object_type);
  if (a.point_count != b.point_count) return diff("point_count", a.point_count, b.point_count);
  if (a.data_type_size != b.data_type_size) {
    return diff("data_type_size", a.data_type_size, b.data_type_size);
  }
  if (a.name != b.name) return diff("name", "'" + a.name + "'", "'" + b.name + "'");
  if (a.curve_id != b.curve_id) return diff("curve_id", a.curve_id, b.curve_id);
  if (a.x_length != b.x_length) return diff("x_length", a.x_length, b.x_length);
  if (a.x_dim_upid != b.x_dim_upid) return diff("x_dim_upid", a.x_dim_upid, b.x_dim_upid);
  if (a.y_dim_upid != b.y_dim_upid) return diff("y_dim_upid", a.y_dim_upid, b.y_dim_upid);
  if (a.wizard_type != b.wizard_type) return diff("wizard_type", a.wizard_type, b.wizard_type);
  if (a.default_offset != b.default_offset) {
    return diff("default_offset", a.default_offset, b.default_offset);
  }
  if (a.default_amplitude_scale != b.default_amplitude_scale) {
    return diff("default_amplitude_scale", a.default_amplitude_scale, b.default_amplitude_scale);
  }
  if (a.default_time_scale != b.default_time_scale) {
    return diff("default_time_scale", a.default_time_scale, b.default_time_scale);
  }
  const size_t n = std::min(want.points.size(), got.points.size());
  for (size_t i = 0; i < n; ++i) {
    if (want.points[i] != got.points[i]) {
      return diff(absl::StrCat("points[", i, "]").c_str(), want.points[i], got.points[i]);
    }
  }
  if (want.points.size() != got.points.size()) {
    return diff("points.size", want.points.size(), got.points.size());
  }
  return "";
}

}  // namespace drivegw::linmot::linudp
