// Fuzz target for the curve-set import path (server/core/curve_set_io.cpp, decision 014): curve
// sets arrive only as API messages (no file importer; docs/reliability.md section 2), so the
// input is the JSON body of CreateCurveSet as REST receives it (a v1.CurveSet, parsed by
// protobuf's JSON parser), and every curve goes through CurveFromProto and the shape checks the
// service applies. Invariants: no crash; CurveFromProto errors are InvalidArgument naming the
// field; a curve that passes ValidateCurveShape plots (CurvePlotOf), goes back to a message
// (CurveToProto) that converts to the same curve, and a LinMot curve hashes.
#include <google/protobuf/util/json_util.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <variant>

#include "adapters/core/curve.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "server/core/curve_set_io.h"

namespace {

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string json(reinterpret_cast<const char*>(data), size);
  drivegw::v1::CurveSet set;
  if (!google::protobuf::util::JsonStringToMessage(json, &set).ok()) return 0;
  for (int i = 0; i < set.curves_size(); ++i) {
    const std::string field = "curve_set.curves[" + std::to_string(i) + "]";
    auto curve = drivegw::server::CurveFromProto(field, set.curves(i));
    if (!curve.ok()) {
      Check(curve.status().code() == absl::StatusCode::kInvalidArgument);
      Check(curve.status().message().find(field) != std::string::npos);
      continue;
    }
    if (!drivegw::ValidateCurveShape(*curve).ok()) continue;
    (void)drivegw::server::CurvePlotOf(*curve);
    auto again = drivegw::server::CurveFromProto(field, drivegw::server::CurveToProto(*curve));
    Check(again.ok() && *again == *curve);
    if (const auto* lm = std::get_if<drivegw::LinMotParametricCurve>(&curve->shape)) {
      Check(drivegw::server::LinMotCurveHash(*lm).substr(0, 8) == "fnv1a64:");
    }
  }
  return 0;
}
