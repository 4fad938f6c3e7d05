// Curve sets <-> API v1 messages, plots and the download hash.
#include "server/core/curve_set_io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

using google::protobuf::util::TimeUtil;
using LM = LinMotParametricCurve;

constexpr absl::string_view kSetPrefix = "curveSets/";

google::protobuf::Timestamp ToProto(storage::Time t) {
  return TimeUtil::MillisecondsToTimestamp(
      std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count());
}

void CurvesToProto(const std::vector<Curve>& in,
                   google::protobuf::RepeatedPtrField<v1::Curve>* out) {
  for (const auto& c : in) *out->Add() = CurveToProto(c);
}

// FNV-1a, 64 bit (offset basis 14695981039346656037, prime 1099511628211): stable across runs
// and platforms, unlike std::hash / absl::Hash; collisions only matter for an operator comparing
// two audit entries, not for security.
class Fnv1a64 {
 public:
  void Bytes(const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < n; ++i) {
      h_ ^= p[i];
      h_ *= 1099511628211ull;
    }
  }
  // Little-endian, whatever the host order is.
  void U32(uint32_t v) {
    const uint8_t b[4] = {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8),
                          static_cast<uint8_t>(v >> 16), static_cast<uint8_t>(v >> 24)};
    Bytes(b, 4);
  }
  void I64(int64_t v) {
    U32(static_cast<uint32_t>(static_cast<uint64_t>(v)));
    U32(static_cast<uint32_t>(static_cast<uint64_t>(v) >> 32));
  }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 14695981039346656037ull;
};

}  // namespace

absl::StatusOr<Curve> CurveFromProto(const std::string& field, const v1::Curve& in) {
  Curve out;
  out.name = in.name();
  out.description = in.description();
  switch (in.shape_case()) {
    case v1::Curve::kPositionTime: {
      PositionTimeCurve pt;
      pt.time_step_s = in.position_time().time_step_s();
      pt.positions_mm.assign(in.position_time().positions_mm().begin(),
                             in.position_time().positions_mm().end());
      out.shape = std::move(pt);
      break;
    }
    case v1::Curve::kLinmot: {
      const v1::LinMotCurve& l = in.linmot();
      if (l.y_unit() != v1::LINMOT_Y_UNIT_UNSPECIFIED &&
          l.y_unit() != v1::LINMOT_Y_UNIT_POSITION_0P1UM) {
        return FieldError(
            absl::StrCat(field, ".linmot.y_unit"),
            absl::StrCat(static_cast<int>(l.y_unit()),
                         " is not a unit (only position in 0.1 um, linmot-mc.md §7)"));
      }
      LM lm;
      lm.curve_id = l.curve_id();
      lm.x_length_s = l.x_length_s();
      lm.y_unit = LM::YUnit::kPosition0p1um;
      lm.points.assign(l.points().begin(), l.points().end());
      lm.offset_mm = l.offset_mm();
      lm.amplitude_scale_pct = l.has_amplitude_scale_pct() ? l.amplitude_scale_pct().value() : 100;
      lm.time_scale_pct = l.has_time_scale_pct() ? l.time_scale_pct().value() : 100;
      out.shape = std::move(lm);
      break;
    }
    default:
      return FieldError(
          field, absl::StrCat("curve '", in.name(), "' needs a shape (position_time or linmot)"));
  }
  return out;
}

v1::Curve CurveToProto(const Curve& in) {
  v1::Curve out;
  out.set_name(in.name);
  out.set_description(in.description);
  if (const auto* pt = std::get_if<PositionTimeCurve>(&in.shape)) {
    auto* p = out.mutable_position_time();
    p->set_time_step_s(pt->time_step_s);
    p->mutable_positions_mm()->Assign(pt->positions_mm.begin(), pt->positions_mm.end());
    return out;
  }
  const auto& lm = std::get<LM>(in.shape);
  auto* l = out.mutable_linmot();
  l->set_curve_id(lm.curve_id);
  l->set_x_length_s(lm.x_length_s);
  l->set_y_unit(v1::LINMOT_Y_UNIT_POSITION_0P1UM);
  l->mutable_points()->Assign(lm.points.begin(), lm.points.end());
  l->set_offset_mm(lm.offset_mm);
  l->mutable_amplitude_scale_pct()->set_value(lm.amplitude_scale_pct);
  l->mutable_time_scale_pct()->set_value(lm.time_scale_pct);
  return out;
}

v1::CurveSet CurveSetToProto(const storage::StoredCurveSet& in) {
  v1::CurveSet out;
  out.set_name(absl::StrCat(std::string(kSetPrefix), in.set.name));
  out.set_description(in.set.description);
  CurvesToProto(in.set.curves, out.mutable_curves());
  out.set_version(in.version);
  out.set_etag(in.etag);
  out.set_author(in.author);
  *out.mutable_create_time() = ToProto(in.created_at);
  *out.mutable_update_time() = ToProto(in.updated_at);
  return out;
}

v1::CurveSetVersion CurveSetVersionToProto(const std::string& set_name,
                                           const storage::CurveSetVersion& in) {
  v1::CurveSetVersion out;
  out.set_name(absl::StrCat(std::string(kSetPrefix), set_name));
  out.set_version(in.version);
  CurvesToProto(in.curves, out.mutable_curves());
  out.set_author(in.author);
  out.set_comment(in.comment);
  *out.mutable_create_time() = ToProto(in.created_at);
  return out;
}

absl::StatusOr<v1::CurvePlot> CurvePlotOf(const Curve& curve) {
  auto samples = SampleCurve(curve);
  if (!samples.ok()) return samples.status();
  auto summary = SummarizeCurve(curve);
  if (!summary.ok()) return summary.status();
  v1::CurvePlot out;
  out.set_curve(curve.name);
  out.set_time_step_s(samples->time_step_s);
  out.mutable_t_s()->Assign(samples->t_s.begin(), samples->t_s.end());
  out.mutable_position_mm()->Assign(samples->position_mm.begin(), samples->position_mm.end());
  out.mutable_velocity_mm_s()->Assign(samples->velocity_mm_s.begin(), samples->velocity_mm_s.end());
  out.mutable_acceleration_mm_s2()->Assign(samples->acceleration_mm_s2.begin(),
                                           samples->acceleration_mm_s2.end());
  auto* s = out.mutable_summary();
  s->set_duration_s(summary->duration_s);
  s->set_start_mm(summary->start_mm);
  s->set_end_mm(summary->end_mm);
  s->set_min_mm(summary->min_mm);
  s->set_max_mm(summary->max_mm);
  s->set_peak_velocity_mm_s(summary->peak_velocity_mm_s);
  s->set_peak_acceleration_mm_s2(summary->peak_acceleration_mm_s2);
  return out;
}

std::string LinMotCurveHash(const LinMotParametricCurve& curve) {
  Fnv1a64 h;
  // Wire units as decision 012 lists them: x-Length UInt32 [10 us], scales [0.1 %] / [0.01 %],
  // offset SInt32 [0.1 um] (linmot-mc.md §7 L1000-L1002, §5.5 044h L528).
  h.U32(static_cast<uint32_t>(curve.curve_id));
  h.I64(std::llround(curve.x_length_s / LM::kTimeUnitS));
  h.U32(static_cast<uint32_t>(curve.y_unit));
  h.U32(static_cast<uint32_t>(curve.points.size()));
  for (const int32_t p : curve.points) h.U32(static_cast<uint32_t>(p));
  h.I64(std::llround(curve.offset_mm / LM::kPointUnitMm));
  h.I64(std::llround(curve.amplitude_scale_pct / LM::kAmplitudeScaleUnitPct));
  h.I64(std::llround(curve.time_scale_pct / LM::kTimeScaleUnitPct));
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.value()));
  return absl::StrCat("fnv1a64:", hex);
}

}  // namespace drivegw::server
