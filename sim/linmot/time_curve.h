// A running LinMot time curve (linmot-mc.md §5.5 040h-045h, §7 model D-29 L1009): the stored
// points, the start parameters a command resolved, and the demand position they give at time t.
// Pure: the device advances it (docs/decisions/606-linmot-sim-time-curves.md).
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "sim/linmot/interpreter.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/rtc_channel.h"

namespace drivegw::sim::linmot {

struct TimeCurve {
  uint16_t curve_id = 0;
  std::vector<int32_t> points;  // y, 0.1 um, N >= 2
  double offset_mm = 0;
  double amplitude = 1;  // 1 = 100 %
  // Curve time Tc; +infinity for a time scale of 0 % (the curve stands at y(0), decision 606).
  double duration_s = std::numeric_limits<double>::infinity();
  double elapsed_s = 0;

  // D-29: offset + amplitude x (y(t / Tc) - y(0)), y linearly interpolated over tau in [0, 1].
  double At(double t_s) const;
  double end_mm() const { return At(duration_s); }
};

// What a time-curve command resolves to: a curve to run, or the §10 error the drive raises.
struct TimeCurvePlan {
  std::optional<TimeCurve> curve;
  uint16_t error = 0;  // 0062h Curve Not Defined, 0089h Curve Amp Scale Error
  std::string reason;  // for the simulator log
};

// Resolves `cmd` against the stored curve (nullptr: none under that ID), the 040h defaults in
// 14C9h-14CBh and the demand position (041h-043h offsets), per §5.5 and D-29.
TimeCurvePlan PlanTimeCurve(const action::RunCurve& cmd, const RtcChannel::StoredCurve* stored,
                            const Parameters& params, double demand_mm);

}  // namespace drivegw::sim::linmot
