// The catalogue of the parameters the simulated motion core exposes (stober-motion.md §5,
// §10.1); ids and CANopen addresses come from adapters/stober/param_id.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/stober/param_id.h"

namespace drivegw::sim::stober {

// Ids and CANopen addressing live in adapters/stober/param_id.h (shared with the gateway,
// decision 1171); re-exported here so the simulator's code keeps its names.
using drivegw::stober::CanOpenAddress;
using drivegw::stober::FromCanOpen;
using drivegw::stober::P;
using drivegw::stober::ParamId;
using drivegw::stober::ParseParamId;
using drivegw::stober::ToCanOpen;
using drivegw::stober::ToString;

enum class ParamType { kBool, kInt, kReal };
enum class Access { kReadWrite, kReadOnly };

// One catalogue entry. Values are doubles in user units (G-01: the manual gives no units; the
// simulator works in u, u/s, u/s², u/s³, ms, %, torque in % of rated).
struct ParamInfo {
  ParamId id;
  std::string_view name;
  ParamType type = ParamType::kReal;
  std::string_view unit;
  double min = 0;
  double max = 0;
  double default_value = 0;
  Access access = Access::kReadWrite;
  // Why the default is what it is: "manual" (stated), "F-LIN" (§10.1 fixture, the manual gives
  // none), "P" (project choice, decision 1141+).
  std::string_view default_source;
};

// Every parameter the model exposes, ordered by id.
const std::vector<ParamInfo>& Catalogue();
// nullptr if the model does not expose `id`.
const ParamInfo* FindParam(ParamId id);

}  // namespace drivegw::sim::stober
