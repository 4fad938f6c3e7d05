// Curve sets between API v1 messages and the core value types (issue 6 "Curve sets", decision
// 014): Curve/CurveSet <-> v1 messages, the plot of one curve, and the LinMot wire hash audited
// with every download. Pure conversions; validation lives in adapters/core/curve.h.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "adapters/core/curve.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "storage/curve_set_repo.h"

namespace drivegw::server {

// A curve of a request; InvalidArgument naming `field` ("curve_set.curves[2]") when it has no
// shape or an unknown y unit. Absent LinMot scales are 100 %.
absl::StatusOr<Curve> CurveFromProto(const std::string& field, const v1::Curve& in);
v1::Curve CurveToProto(const Curve& in);

// "curveSets/<name>" with every stored field.
v1::CurveSet CurveSetToProto(const storage::StoredCurveSet& in);
v1::CurveSetVersion CurveSetVersionToProto(const std::string& set_name,
                                           const storage::CurveSetVersion& in);

// The samples and summary of `curve` (SampleCurve / SummarizeCurve, decision 012).
absl::StatusOr<v1::CurvePlot> CurvePlotOf(const Curve& curve);

// "fnv1a64:<16 hex digits>" over the LinMot wire form: curve ID, x-Length in 10 us, y unit,
// every point, offset, amplitude and time scale in their wire units (little-endian). Identifies
// what a download stored without logging every point (decision 014).
std::string LinMotCurveHash(const LinMotParametricCurve& curve);

}  // namespace drivegw::server
