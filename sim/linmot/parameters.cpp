// UPID table of the simulated LinMot drive: defaults, typed wire conversion, RAM/ROM (D-31).
#include "sim/linmot/parameters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::sim::linmot {
namespace {

int64_t TypeMin(ParamType type) {
  switch (type) {
    case ParamType::kBool:
    case ParamType::kUInt16:
    case ParamType::kUInt32:
      return 0;
    case ParamType::kSInt16:
      return std::numeric_limits<int16_t>::min();
    case ParamType::kSInt32:
      return std::numeric_limits<int32_t>::min();
  }
  return 0;
}

int64_t TypeMax(ParamType type) {
  switch (type) {
    case ParamType::kBool:
      return 1;
    case ParamType::kUInt16:
      return std::numeric_limits<uint16_t>::max();
    case ParamType::kUInt32:
      return std::numeric_limits<uint32_t>::max();
    case ParamType::kSInt16:
      return std::numeric_limits<int16_t>::max();
    case ParamType::kSInt32:
      return std::numeric_limits<int32_t>::max();
  }
  return 0;
}

std::string Hex(uint16_t upid) { return absl::StrFormat("%04Xh", upid); }

int64_t Round(double v) { return static_cast<int64_t>(std::llround(v)); }

// A parameter spanning its whole type.
ParamDef Param(uint16_t upid, std::string name, ParamType type, int64_t def) {
  return ParamDef{upid, std::move(name), type, def, TypeMin(type), TypeMax(type), false, false};
}
ParamDef Ranged(uint16_t upid, std::string name, ParamType type, int64_t def, int64_t min,
                int64_t max) {
  return ParamDef{upid, std::move(name), type, def, min, max, false, false};
}
ParamDef Variable(uint16_t upid, std::string name, ParamType type) {
  return ParamDef{upid, std::move(name), type, 0, TypeMin(type), TypeMax(type), true, true};
}

}  // namespace

const char* ParamTypeName(ParamType type) {
  switch (type) {
    case ParamType::kBool:
      return "Bool";
    case ParamType::kSInt16:
      return "SInt16";
    case ParamType::kUInt16:
      return "UInt16";
    case ParamType::kSInt32:
      return "SInt32";
    case ParamType::kUInt32:
      return "UInt32";
  }
  return "?";
}

Parameters::Parameters(std::vector<ParamDef> defs) {
  slots_.reserve(defs.size());
  for (auto& d : defs) {
    Slot s;
    s.ram = s.rom = d.default_value;
    s.def = std::move(d);
    slots_.push_back(std::move(s));
  }
  std::sort(slots_.begin(), slots_.end(),
            [](const Slot& a, const Slot& b) { return a.def.upid < b.def.upid; });
}

Parameters Parameters::ForOptions(const SimOptions& o) {
  using T = ParamType;
  constexpr int64_t kPosMax = std::numeric_limits<int32_t>::max();
  constexpr int64_t kPosMin = std::numeric_limits<int32_t>::min();
  constexpr int64_t kLimitMax = 0x7FFF'FFFF;  // linmot-mc.md §6.1: 0 ... 7FFF'FFFFh
  std::vector<ParamDef> d = {
      Variable(upid::kOperatingSubHours, "Operating Sub Hours", T::kUInt32),
      Ranged(upid::kActivePositionControllerSet, "Active Position Controller Set", T::kUInt16, 0, 0,
             1),
      Ranged(upid::kMaximalCurrentSetA, "Maximal Current Set A", T::kUInt16, 8000, 0, 32000),
      Ranged(upid::kMaximalCurrentSetB, "Maximal Current Set B", T::kUInt16, 8000, 0, 32000),
      Param(upid::kHomePosition, "Home Position", T::kSInt32, Round(o.home_position_mm * 1e4)),
      Param(upid::kSliderHomePosition, "Slider Home Position", T::kSInt32, 0),
      // D-14: 16-bit value x scale = internal value; defaults 10 um, 1 mm/s, 0.01 m/s^2.
      Ranged(upid::kScalePosition16, "16 Bit Scaling Position", T::kSInt32, 100, 1, 100000),
      Ranged(upid::kScaleVelocity16, "16 Bit Scaling Velocity", T::kSInt32, 1000, 1, 100000),
      Ranged(upid::kScaleAcceleration16, "16 Bit Scaling Acceleration", T::kSInt32, 1000, 1,
             100000),
      Ranged(upid::kScaleJerk16, "16 Bit Scaling Jerk", T::kSInt32, 1000, 1, 100000),
      Param(upid::kMinimalPosition, "Minimal Position", T::kSInt32, Round(o.stroke_min_mm * 1e4)),
      Param(upid::kMaximalPosition, "Maximal Position", T::kSInt32, Round(o.stroke_max_mm * 1e4)),
      Ranged(upid::kPositionLagMovingMax, "Position Lag Always Max", T::kSInt32, 100000, 0,
             kPosMax),
      Ranged(upid::kPositionLagStandingMax, "Position Lag Standing Max", T::kSInt32, 10000, 0,
             kPosMax),
      Ranged(upid::kPredefVelocity, "Predef VAI Maximal Velocity", T::kUInt32, 1'000'000, 0,
             kLimitMax),
      Ranged(upid::kPredefAcceleration, "Predef VAI Acceleration", T::kUInt32, 1'000'000, 0,
             kLimitMax),
      Ranged(upid::kPredefDeceleration, "Predef VAI Deceleration", T::kUInt32, 1'000'000, 0,
             kLimitMax),
      Ranged(upid::kPredefJerk, "Predef VAJI Jerk", T::kUInt32, 1'000'000, 0, 0x5FFF'FFFF),
      // Curve defaults for 040h/041h/042h (§5.5 L524; units and ranges of 044h, L528).
      Param(upid::kCurveOffset, "Curve Offset", T::kSInt32, 0),
      Ranged(upid::kCurveAmplitudeScale, "Curve Amplitude Scale", T::kSInt16, 1000, -20000, 20000),
      Ranged(upid::kCurveTimeScale, "Curve Time Scale", T::kUInt16, 10000, 0, 20000),
      Ranged(upid::kTriggerMode, "Trigger Mode", T::kUInt16, 0, 0, 4),
      Ranged(upid::kQuickStopDeceleration, "Quick Stop Deceleration", T::kUInt32, 5'000'000, 1,
             kLimitMax),
      Variable(upid::kDemandPosition, "Demand Position", T::kSInt32),
      Variable(upid::kDemandVelocity, "Demand Velocity", T::kSInt32),
      Variable(upid::kActualPosition, "Actual Position", T::kSInt32),
      Variable(upid::kActualVelocity, "Actual Velocity", T::kSInt32),
      Variable(upid::kDifferencePosition, "Difference Position", T::kSInt32),
      Variable(upid::kDemandCurrent, "Demand Current", T::kSInt32),
      Variable(upid::kControlWord, "Control Word", T::kUInt16),
      Variable(upid::kCapturePosition, "Captured Position", T::kSInt32),
      Param(upid::kCmdTabVar1, "Command Table Var 1", T::kSInt32, 0),
      Param(upid::kCmdTabVar2, "Command Table Var 2", T::kSInt32, 0),
      Param(upid::kMonitoringChannel1, "Monitoring Channel 1 UPID", T::kUInt16, 0),
      Param(upid::kMonitoringChannel1 + 1, "Monitoring Channel 2 UPID", T::kUInt16, 0),
      Param(upid::kMonitoringChannel1 + 2, "Monitoring Channel 3 UPID", T::kUInt16, 0),
      Param(upid::kMonitoringChannel1 + 3, "Monitoring Channel 4 UPID", T::kUInt16, 0),
      Ranged(upid::kInTargetWindow, "In Target Position Window", T::kSInt32,
             Round(o.in_target_window_mm * 1e4), 0, kPosMax),
      Ranged(upid::kHomingVelocity, "Homing Maximal Velocity", T::kUInt32,
             Round(o.homing_velocity_mm_s * 1e3), 1, kLimitMax),
      Ranged(upid::kHomingAcceleration, "Homing Acceleration", T::kUInt32,
             Round(o.homing_acceleration_mm_s2 * 1e2), 1, kLimitMax),
      Param(upid::kMotorRequiresHoming, "Motor Requires Homing", T::kBool,
            o.requires_homing ? 1 : 0),
      Ranged(upid::kPositionLagWarnLimit, "Position Lag Warn Limit", T::kSInt32, 50000, 0, kPosMax),
      Ranged(upid::kHomingTargetPosition, "Homing Target Position", T::kSInt32,
             Round(o.home_position_mm * 1e4), kPosMin, kPosMax),
      Param(upid::kGoToPositionTarget, "Go To Position Target", T::kSInt32,
            Round((o.stroke_min_mm + o.stroke_max_mm) / 2 * 1e4)),
      Param(upid::kInitialPosition, "Initial Position", T::kSInt32,
            Round(o.initial_position_mm * 1e4)),
      Ranged(upid::kJogVelocity, "Jog Maximal Velocity", T::kUInt32, 50'000, 1, kLimitMax),
  };
  return Parameters(std::move(d));
}

Parameters::Slot* Parameters::FindSlot(uint16_t upid) {
  auto it = std::lower_bound(slots_.begin(), slots_.end(), upid,
                             [](const Slot& s, uint16_t u) { return s.def.upid < u; });
  return (it != slots_.end() && it->def.upid == upid) ? &*it : nullptr;
}
const Parameters::Slot* Parameters::FindSlot(uint16_t upid) const {
  return const_cast<Parameters*>(this)->FindSlot(upid);
}

const ParamDef* Parameters::Find(uint16_t upid) const {
  const Slot* s = FindSlot(upid);
  return s ? &s->def : nullptr;
}

absl::StatusOr<int64_t> Parameters::ReadRam(uint16_t upid) const {
  const Slot* s = FindSlot(upid);
  if (!s) return absl::NotFoundError(absl::StrCat("upid ", Hex(upid), ": unknown"));
  return s->ram;
}

absl::StatusOr<int64_t> Parameters::ReadRom(uint16_t upid) const {
  const Slot* s = FindSlot(upid);
  if (!s) return absl::NotFoundError(absl::StrCat("upid ", Hex(upid), ": unknown"));
  if (s->def.variable) {
    return absl::FailedPreconditionError(
        absl::StrCat("upid ", Hex(upid), " (", s->def.name, "): a variable has no ROM value"));
  }
  return s->rom;
}

namespace {
absl::Status CheckWritable(const ParamDef* def, uint16_t upid, int64_t value) {
  if (!def) return absl::NotFoundError(absl::StrCat("upid ", Hex(upid), ": unknown"));
  if (def->read_only) {
    return absl::FailedPreconditionError(
        absl::StrCat("upid ", Hex(upid), " (", def->name, "): read-only"));
  }
  if (value < def->min || value > def->max) {
    return absl::OutOfRangeError(absl::StrCat("upid ", Hex(upid), " (", def->name, "): ", value,
                                              " is outside [", def->min, ", ", def->max, "]"));
  }
  return absl::OkStatus();
}
}  // namespace

absl::Status Parameters::WriteRam(uint16_t upid, int64_t value) {
  Slot* s = FindSlot(upid);
  if (absl::Status st = CheckWritable(s ? &s->def : nullptr, upid, value); !st.ok()) return st;
  s->ram = value;
  return absl::OkStatus();
}

absl::Status Parameters::WriteRom(uint16_t upid, int64_t value) {
  Slot* s = FindSlot(upid);
  if (absl::Status st = CheckWritable(s ? &s->def : nullptr, upid, value); !st.ok()) return st;
  s->rom = value;
  return absl::OkStatus();
}

absl::StatusOr<int64_t> Parameters::FromWire(uint16_t upid, uint32_t raw) const {
  const ParamDef* def = Find(upid);
  if (!def) return absl::NotFoundError(absl::StrCat("upid ", Hex(upid), ": unknown"));
  int64_t v = 0;
  switch (def->type) {
    case ParamType::kSInt16:
    case ParamType::kSInt32:
      v = static_cast<int32_t>(raw);
      break;
    case ParamType::kBool:
    case ParamType::kUInt16:
    case ParamType::kUInt32:
      v = raw;
      break;
  }
  if (v < TypeMin(def->type) || v > TypeMax(def->type)) {
    return absl::OutOfRangeError(absl::StrCat("upid ", Hex(upid), " (", def->name, "): ", v,
                                              " does not fit ", ParamTypeName(def->type)));
  }
  return v;
}

absl::StatusOr<int64_t> Parameters::FromLiveWrite(uint16_t upid, uint32_t raw) const {
  const ParamDef* def = Find(upid);
  if (!def) return absl::NotFoundError(absl::StrCat("upid ", Hex(upid), ": unknown"));
  // linmot-mc.md §9.1, MC22 L1152: the drive uses only the relevant bits (a Bool uses bit 0).
  switch (def->type) {
    case ParamType::kBool:
      return static_cast<int64_t>(raw & 1u);
    case ParamType::kSInt16:
      return static_cast<int64_t>(static_cast<int16_t>(raw & 0xFFFFu));
    case ParamType::kUInt16:
      return static_cast<int64_t>(raw & 0xFFFFu);
    case ParamType::kSInt32:
      return static_cast<int64_t>(static_cast<int32_t>(raw));
    case ParamType::kUInt32:
      return static_cast<int64_t>(raw);
  }
  return absl::InternalError("unreachable");
}

uint32_t Parameters::ToWire(int64_t value) { return static_cast<uint32_t>(value); }

int64_t Parameters::Get(uint16_t upid) const {
  const Slot* s = FindSlot(upid);
  return s ? s->ram : 0;
}

void Parameters::Set(uint16_t upid, int64_t value) {
  Slot* s = FindSlot(upid);
  if (!s) return;
  s->ram = std::clamp(value, TypeMin(s->def.type), TypeMax(s->def.type));
}

void Parameters::Boot() {
  for (Slot& s : slots_) {
    if (!s.def.variable) s.ram = s.rom;
  }
}

void Parameters::RestoreRomDefaults() {
  for (Slot& s : slots_) {
    if (!s.def.variable) s.rom = s.def.default_value;
  }
}

std::optional<uint16_t> Parameters::NextUpid(uint32_t from, bool modified_only) const {
  for (const Slot& s : slots_) {
    if (s.def.upid < from) continue;
    if (modified_only && (s.def.variable || s.rom == s.def.default_value)) continue;
    return s.def.upid;
  }
  return std::nullopt;
}

}  // namespace drivegw::sim::linmot
