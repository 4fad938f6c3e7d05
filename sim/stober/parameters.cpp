// The catalogue of the simulated axis (stober-motion.md §5, §10.1)
#include "sim/stober/parameters.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <limits>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::stober {
namespace {

constexpr double kBig = 1e9;  // value range of unbounded user-unit quantities (G-01)
constexpr double kInf = std::numeric_limits<double>::infinity();

using enum ParamType;
constexpr Access RO = Access::kReadOnly;
constexpr Access RW = Access::kReadWrite;

std::vector<ParamInfo> MakeCatalogue() {
  std::vector<ParamInfo> c = {
      // Group A: drive controller / CiA 402 objects (§5.1).
      {P("A150"), "cycle time motion core", kReal, "ms", 0.125, 32, 1, RW, "F-LIN"},
      {P("A291"), "controller cycle time", kReal, "ms", 0.125, 1000, 1, RW, "F-CYC"},
      {P("A340"), "velocity override (CiA 402 source)", kReal, "%", 0, 1000, 100, RW, "F-LIN"},
      {P("A515"), "control word", kInt, "", 0, 65535, 0, RW, "P"},
      {P("A516"), "status word", kInt, "", 0, 65535, 0, RO, "P"},
      {P("A541"), "modes of operation", kInt, "", -128, 127, 0, RW, "manual"},
      {P("A542"), "modes of operation display", kInt, "", -128, 127, 0, RO, "manual"},
      {P("A545"), "position actual value", kReal, "u", -kInf, kInf, 0, RO, "P"},
      {P("A558"), "target torque/force", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("A561"), "torque/force slope", kReal, "%/s", 0, kBig, 0, RW, "P"},
      {P("A567"), "target position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A569"), "reference position (home offset)", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A574"), "profile velocity", kReal, "u/s", -kBig, kBig, 500, RW, "F-LIN default move"},
      {P("A576"), "profile acceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("A577"), "profile deceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("A586"), "homing method", kInt, "", -4, 37, 0, RW, "manual (0 inactive)"},
      {P("A587[0]"), "homing speed fast", kReal, "u/s", 0, kBig, 100, RW, "P"},
      {P("A587[1]"), "homing speed slow", kReal, "u/s", 0, kBig, 10, RW, "P"},
      {P("A588"), "homing acceleration", kReal, "u/s²", 0, kBig, 1000, RW, "P"},
      {P("A590"), "profile jerk", kReal, "u/s³", 0, kBig, 50000, RW, "F-LIN default move"},
      {P("A592"), "velocity component (cyclic)", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      {P("A593"), "torque/force component (CST)", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("A601"), "set position IP mode", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("A621"), "positioning option code", kInt, "", 0, 65535, 0, RW, "P"},
      {P("A638"), "target velocity", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      // Groups C, E, F (§5.2).
      {P("C40"), "velocity window", kReal, "u/s", 0, kBig, 5, RW, "F-LIN"},
      {P("E07"), "calculated set velocity", kReal, "u/s", -kInf, kInf, 0, RO, "P"},
      {P("E65"), "maximum torque/force positive", kReal, "%", 0, 1000, 300, RW, "P (G-34)"},
      {P("E66"), "maximum torque/force negative", kReal, "%", 0, 1000, 300, RW, "P (G-34)"},
      {P("E90"), "actual torque/force", kReal, "%", -kInf, kInf, 0, RO, "P"},
      {P("F00"), "brake control", kInt, "", 0, 1, 1, RW, "F-LIN"},
      // Group I: configuration and limits (§5.3).
      {P("I00"), "travel range", kInt, "", 0, 1, 0, RW, "F-LIN"},
      {P("I01"), "revolution length", kReal, "u", 1e-6, kBig, 360, RW, "F-END"},
      {P("I04"), "permitted direction", kInt, "", 0, 2, 0, RW, "P (G-21)"},
      {P("I10"), "maximum velocity", kReal, "u/s", 0, kBig, 1000, RW, "F-LIN"},
      {P("I11"), "maximum acceleration", kReal, "u/s²", 0, kBig, 10000, RW, "F-LIN"},
      {P("I16"), "maximum jerk", kReal, "u/s³", 0, kBig, 100000, RW, "F-LIN"},
      {P("I22"), "position window", kReal, "u", 0, kBig, 1, RW, "F-LIN"},
      {P("I25"), "velocity feedforward", kReal, "%", 0, 100, 100, RW, "P"},
      {P("I28"), "homing torque/force limit", kReal, "%", 0, 1000, 50, RW, "P"},
      {P("I29"), "time homing torque/force limit", kReal, "ms", 0, 60000, 100, RW, "P"},
      {P("I30"), "referencing type", kInt, "", 0, 5, 0, RW, "P"},
      {P("I31"), "referencing direction", kInt, "", 0, 1, 0, RW, "P (0 positive, 1 negative)"},
      {P("I32"), "referencing speed fast", kReal, "u/s", 0, kBig, 100, RW, "P"},
      {P("I33"), "referencing speed slow", kReal, "u/s", 0, kBig, 10, RW, "P"},
      {P("I34"), "reference position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I35"), "referencing with zero pulse", kInt, "", 0, 1, 0, RW, "P"},
      {P("I37"), "index search distance", kReal, "u", 0, kBig, 360, RW, "P"},
      {P("I39"), "referencing acceleration", kReal, "u/s²", 0, kBig, 1000, RW, "P"},
      {P("I42"), "brake wait time", kReal, "ms", 0, 60000, 0, RW, "P"},
      {P("I43"), "move to reference position", kInt, "", 0, 1, 0, RW, "P"},
      {P("I44"), "reference jerk", kReal, "u/s³", 0, kBig, 10000, RW, "P"},
      {P("I50"), "software limit switch positive", kReal, "u", -kBig, kBig, 10000, RW, "F-LIN"},
      {P("I51"), "software limit switch negative", kReal, "u", -kBig, kBig, -10000, RW, "F-LIN"},
      // Status (§5.3 status and limit flags).
      {P("I80"), "actual position", kReal, "u", -kInf, kInf, 0, RO, "P (G-27)"},
      {P("I82"), "active motion ID", kInt, "", -kBig, kBig, 0, RO, "P"},
      {P("I83"), "state motion command", kInt, "", 0, 2, 0, RO, "P (G-08)"},
      {P("I85"), "motion profile done", kBool, "", 0, 1, 0, RO, "P"},
      {P("I86"), "in reference", kBool, "", 0, 1, 1, RO, "F-LIN"},
      {P("I87"), "position window time", kReal, "ms", 0, 60000, 10, RW, "F-LIN"},
      {P("I88"), "actual velocity", kReal, "u/s", -kInf, kInf, 0, RO, "P"},
      {P("I89"), "PLCopen state", kInt, "", 0, 11, 2, RO, "F-LIN"},
      {P("I90"), "PLCopen ErrorStop cause", kInt, "", 0, 255, 0, RO, "P (G-06)"},
      {P("I91"), "error", kBool, "", 0, 1, 0, RO, "P"},
      {P("I92"), "done", kBool, "", 0, 1, 0, RO, "P"},
      {P("I96"), "calculated set position", kReal, "u", -kInf, kInf, 0, RO, "P"},
      {P("I100"), "source Execute", kInt, "", 0, 255, 0, RW, "P"},
      {P("I101"), "source positive limit switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I102"), "source negative limit switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I103"), "source reference switch", kInt, "", 0, 255, 0, RW, "P"},
      {P("I113"), "MC_MoveVelocity mode (1 cyclical takeover)", kInt, "", 0, 1, 0, RW, "manual"},
      {P("I119"), "disable v-set at command change (1 only at start)", kInt, "", 0, 1, 0, RW,
       "manual"},
      {P("I180"), "actual position in window", kBool, "", 0, 1, 0, RO, "P"},
      {P("I183"), "speed reached", kBool, "", 0, 1, 0, RO, "P"},
      {P("I190"), "velocity limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I191"), "acceleration/jerk limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I192"), "cyclical position limiting active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I193"), "cyclical velocity limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I194"), "cyclical torque/force limit active", kBool, "", 0, 1, 0, RO, "P (G-27)"},
      {P("I195"), "cyclical acceleration limit active", kBool, "", 0, 1, 0, RO, "P"},
      {P("I199"), "set and actual velocity zero", kBool, "", 0, 1, 1, RO, "P (G-37)"},
      {P("I216"), "cyclic acceleration (MoveSpeed)", kReal, "u/s²", 0, kBig, 0, RW, "P (G-27)"},
      {P("I217"), "cyclic deceleration (MoveSpeed)", kReal, "u/s²", 0, kBig, 0, RW, "P (G-27)"},
      {P("I230"), "velocity override", kReal, "%", 0, 1000, 100, RW, "F-LIN"},
      // Motion-core inputs (§5.3 command interface).
      {P("I400"), "motion ID", kInt, "", -kBig, kBig, 0, RW, "P"},
      {P("I401"), "command", kInt, "", 0, 11, 0, RW, "manual (0 DoNothing)"},
      {P("I402"), "execute", kBool, "", 0, 1, 0, RW, "P"},
      {P("I403"), "position", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I404"), "velocity", kReal, "u/s", -kBig, kBig, 500, RW, "F-LIN default move"},
      {P("I405"), "acceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("I406"), "deceleration", kReal, "u/s²", 0, kBig, 5000, RW, "F-LIN default move"},
      {P("I407"), "jerk", kReal, "u/s³", 0, kBig, 50000, RW, "F-LIN default move"},
      {P("I409"), "command mode (0 aborting, 1 buffered)", kInt, "", 0, 1, 0, RW,
       "P (G-09, decision 1162)"},
      {P("I410"), "engage brake at the end", kBool, "", 0, 1, 0, RW, "F-LIN"},
      {P("I411"), "movement direction", kInt, "", 0, 3, 0, RW, "manual"},
      {P("I421"), "cyclic position reference value", kReal, "u", -kBig, kBig, 0, RW, "P"},
      {P("I423"), "extrapolation time", kReal, "ms", 0, 60000, 5, RW, "F-CYC"},
      {P("I425"), "feedforward source / interpolation type", kInt, "", 0, 2, 0, RW, "P"},
      {P("I426"), "cyclic reference speed", kReal, "u/s", -kBig, kBig, 0, RW, "P"},
      {P("I428"), "cyclic reference torque/force", kReal, "%", -1000, 1000, 0, RW, "P"},
      {P("I429"), "end velocity", kReal, "u/s", 0, kBig, 0, RW, "P (G-09, decision 1161)"},
      {P("I430"), "torque/force ramp up", kReal, "%/s", 0, kBig, 0, RW, "P (0 = step)"},
      {P("I431"), "torque/force ramp down", kReal, "%/s", 0, kBig, 0, RW, "P (0 = step)"},
      {P("I441"), "signal positive limit switch", kBool, "", 0, 1, 0, RO, "P"},
      {P("I442"), "signal negative limit switch", kBool, "", 0, 1, 0, RO, "P"},
  };
  std::sort(c.begin(), c.end(), [](const ParamInfo& a, const ParamInfo& b) { return a.id < b.id; });
  return c;
}

}  // namespace

const std::vector<ParamInfo>& Catalogue() {
  static const std::vector<ParamInfo> kCatalogue = MakeCatalogue();
  return kCatalogue;
}

const ParamInfo* FindParam(ParamId id) {
  const std::vector<ParamInfo>& c = Catalogue();
  auto it = std::lower_bound(c.begin(), c.end(), id,
                             [](const ParamInfo& p, const ParamId& v) { return p.id < v; });
  if (it == c.end() || it->id != id) return nullptr;
  return &*it;
}

}  // namespace drivegw::sim::stober
