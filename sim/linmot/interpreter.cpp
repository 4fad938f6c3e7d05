// MC interpreter: count rule, D-36 state rule, D-20 unknown IDs, and the table of VAI forms.
#include "sim/linmot/interpreter.h"

#include "absl/strings/str_format.h"
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/state_var.h"

namespace drivegw::sim::linmot {

using mc::MainState;
using sim::motion::StartFrom;

namespace {

// Parameter layouts of the VAI forms (linmot-mc.md §5.0 sets; D-14 for the 16-bit ones).
enum class Layout {
  kVa,           // pos, v, a, d
  kPredef,       // pos; v, a, d from 14BEh/14BFh/14C0h (§5.3)
  kPredefAcc,    // pos, v; a, d from 14BFh/14C0h (§5.9)
  kDecEqAcc,     // pos, v, a; d = a (§5.10; 0C5-0C7 add a current limit, not simulated)
  kS16,          // pos, v, a, d as SInt16/UInt16 x 1455h/1456h/1457h (§5.8)
  kS16Predef,    // pos x 1455h; v, a, d predefined (0Ax)
  kS16DecEqAcc,  // pos, v, a scaled; d = a (0D1)
  kV3,           // v, a, d; target from a variable (0D4-0D7)
};

struct VaiForm {
  uint8_t master;
  uint8_t sub;
  Layout layout;
  TargetRule rule;
  StartFrom start;
  Fire fire;
};

constexpr TargetRule kAbs = TargetRule::kAbsolute;
constexpr TargetRule kIncDem = TargetRule::kIncrementDemand;
constexpr TargetRule kIncTgt = TargetRule::kIncrementTarget;
constexpr TargetRule kIncAct = TargetRule::kIncrementActual;
constexpr StartFrom kDem = StartFrom::kDemand;
constexpr StartFrom kActV = StartFrom::kActualWithActualVelocity;
constexpr StartFrom kAct0 = StartFrom::kActualWithZeroVelocity;
constexpr Fire kNow = Fire::kNow;
constexpr Fire kAfter = Fire::kAfterActualCommand;
constexpr Fire kRise = Fire::kRisingTrigger;
constexpr Fire kFall = Fire::kFallingTrigger;

// Every VAI-interpreter motion of §5.2, 5.3, 5.8-5.11 the simulator runs. Start rules per the
// §5.0 table (MC22 L1213-1289); "like nnn" rows copy nnn's rule.
constexpr VaiForm kVaiForms[] = {
    // §5.2 VAI (VA layout)
    {0x01, 0x0, Layout::kVa, kAbs, kDem, kNow},
    {0x01, 0x1, Layout::kVa, kIncDem, kDem, kNow},
    {0x01, 0x2, Layout::kVa, kIncTgt, kDem, kNow},
    {0x01, 0x3, Layout::kVa, kAbs, kActV, kNow},
    {0x01, 0x4, Layout::kVa, kAbs, kAct0, kNow},
    {0x01, 0x5, Layout::kVa, kIncAct, kDem, kNow},
    {0x01, 0x6, Layout::kVa, kIncAct, kAct0, kNow},
    {0x01, 0x8, Layout::kVa, kAbs, kDem, kAfter},
    {0x01, 0xA, Layout::kVa, kAbs, kDem, kRise},
    {0x01, 0xB, Layout::kVa, kIncTgt, kDem, kRise},
    {0x01, 0xC, Layout::kVa, kAbs, kDem, kFall},
    {0x01, 0xD, Layout::kVa, kIncTgt, kDem, kFall},
    // §5.3 Predef VAI
    {0x02, 0x0, Layout::kPredef, kAbs, kDem, kNow},
    {0x02, 0x1, Layout::kPredef, kIncDem, kDem, kNow},
    {0x02, 0x2, Layout::kPredef, kIncTgt, kDem, kNow},
    {0x02, 0x3, Layout::kPredef, kAbs, kActV, kNow},
    {0x02, 0x4, Layout::kPredef, kAbs, kAct0, kNow},
    {0x02, 0x8, Layout::kPredef, kAbs, kDem, kAfter},
    {0x02, 0xA, Layout::kPredef, kAbs, kDem, kRise},
    {0x02, 0xB, Layout::kPredef, kIncTgt, kDem, kRise},
    {0x02, 0xC, Layout::kPredef, kAbs, kDem, kFall},
    {0x02, 0xD, Layout::kPredef, kIncTgt, kDem, kFall},  // errata 27: an increment
    // §5.8 16-bit VAI
    {0x09, 0x0, Layout::kS16, kAbs, kDem, kNow},
    {0x09, 0x1, Layout::kS16, kIncDem, kDem, kNow},
    {0x09, 0x2, Layout::kS16, kIncTgt, kDem, kNow},
    {0x09, 0x3, Layout::kS16, kAbs, kActV, kNow},
    {0x09, 0x4, Layout::kS16, kAbs, kAct0, kNow},
    {0x09, 0x5, Layout::kS16, kIncAct, kDem, kNow},
    {0x09, 0x6, Layout::kS16, kIncAct, kAct0, kNow},
    {0x09, 0x8, Layout::kS16, kAbs, kDem, kAfter},
    {0x09, 0xA, Layout::kS16, kAbs, kDem, kRise},
    {0x09, 0xB, Layout::kS16, kIncTgt, kDem, kRise},
    {0x09, 0xC, Layout::kS16, kAbs, kDem, kFall},
    {0x09, 0xD, Layout::kS16, kIncTgt, kDem, kFall},
    {0x0A, 0x0, Layout::kS16Predef, kAbs, kDem, kNow},
    {0x0A, 0x1, Layout::kS16Predef, kIncDem, kDem, kNow},
    {0x0A, 0x2, Layout::kS16Predef, kIncTgt, kDem, kNow},
    {0x0A, 0x3, Layout::kS16Predef, kAbs, kActV, kNow},
    {0x0A, 0x4, Layout::kS16Predef, kAbs, kAct0, kNow},
    {0x0A, 0x8, Layout::kS16Predef, kAbs, kDem, kAfter},
    {0x0A, 0xA, Layout::kS16Predef, kAbs, kDem, kRise},
    {0x0A, 0xB, Layout::kS16Predef, kIncTgt, kDem, kRise},
    {0x0A, 0xC, Layout::kS16Predef, kAbs, kDem, kFall},  // D-15: SInt16 scaled
    {0x0A, 0xD, Layout::kS16Predef, kIncTgt, kDem, kFall},
    // §5.9 Predef Acc (E1200/E1400 only: D-20 rejects them on other products)
    {0x0B, 0x0, Layout::kPredefAcc, kAbs, kDem, kNow},
    {0x0B, 0x1, Layout::kPredefAcc, kIncDem, kDem, kNow},
    {0x0B, 0x2, Layout::kPredefAcc, kIncTgt, kDem, kNow},
    {0x0B, 0x3, Layout::kPredefAcc, kAbs, kActV, kNow},
    {0x0B, 0x4, Layout::kPredefAcc, kAbs, kAct0, kNow},
    {0x0B, 0x8, Layout::kPredefAcc, kAbs, kDem, kAfter},
    {0x0B, 0xA, Layout::kPredefAcc, kAbs, kDem, kRise},
    {0x0B, 0xB, Layout::kPredefAcc, kIncTgt, kDem, kRise},
    {0x0B, 0xC, Layout::kPredefAcc, kAbs, kDem, kFall},
    {0x0B, 0xD, Layout::kPredefAcc, kIncTgt, kDem, kFall},
    // §5.10 Dec=Acc
    {0x0C, 0x0, Layout::kDecEqAcc, kAbs, kDem, kNow},
    {0x0C, 0x1, Layout::kDecEqAcc, kIncDem, kDem, kNow},
    {0x0C, 0x2, Layout::kDecEqAcc, kIncTgt, kDem, kNow},
    {0x0C, 0x3, Layout::kDecEqAcc, kAbs, kActV, kNow},
    {0x0C, 0x4, Layout::kDecEqAcc, kAbs, kAct0, kNow},
    {0x0C, 0x5, Layout::kDecEqAcc, kAbs, kDem, kNow},   // + current limit (not simulated)
    {0x0C, 0x6, Layout::kDecEqAcc, kAbs, kActV, kNow},  // like 013
    {0x0C, 0x7, Layout::kDecEqAcc, kAbs, kAct0, kNow},  // D-16: like 014
    {0x0C, 0x8, Layout::kDecEqAcc, kAbs, kDem, kAfter},
    {0x0C, 0xA, Layout::kDecEqAcc, kAbs, kDem, kRise},
    {0x0C, 0xB, Layout::kDecEqAcc, kIncTgt, kDem, kRise},
    {0x0C, 0xC, Layout::kDecEqAcc, kAbs, kDem, kFall},
    {0x0C, 0xD, Layout::kDecEqAcc, kIncTgt, kDem, kFall},
    // §5.11 variants
    {0x0D, 0x0, Layout::kVa, TargetRule::kCapturedIncrement, kDem, kNow},
    {0x0D, 0x1, Layout::kS16DecEqAcc, kAbs, kDem, kNow},  // errata 10
    {0x0D, 0x4, Layout::kV3, TargetRule::kCmdTabVar1, kDem, kNow},
    {0x0D, 0x5, Layout::kV3, TargetRule::kCmdTabVar2, kDem, kNow},
    {0x0D, 0x6, Layout::kV3, TargetRule::kCmdTabVar1, kActV, kNow},
    {0x0D, 0x7, Layout::kV3, TargetRule::kCmdTabVar2, kActV, kNow},
    {0x0D, 0x9, Layout::kVa, kIncAct, kAct0, kNow},  // I-part reset + 016
};

const VaiForm* FindForm(uint8_t master, uint8_t sub) {
  for (const VaiForm& f : kVaiForms) {
    if (f.master == master && f.sub == sub) return &f;
  }
  return nullptr;
}

int64_t Value(const mc::McCommand& c, size_t i) { return i < c.values.size() ? c.values[i] : 0; }

VaiMove MakeMove(const VaiForm& f, const mc::McCommand& c, const Parameters& p) {
  VaiMove m{f.rule, f.start, f.fire, 0, 0, 0, 0};
  const int64_t pv = p.Get(upid::kPredefVelocity);
  const int64_t pa = p.Get(upid::kPredefAcceleration);
  const int64_t pd = p.Get(upid::kPredefDeceleration);
  // D-14: internal value = 16-bit value x scaling parameter.
  const int64_t sp = p.Get(upid::kScalePosition16);
  const int64_t sv = p.Get(upid::kScaleVelocity16);
  const int64_t sa = p.Get(upid::kScaleAcceleration16);
  switch (f.layout) {
    case Layout::kVa:
      m.position = Value(c, 0), m.velocity = Value(c, 1), m.acceleration = Value(c, 2),
      m.deceleration = Value(c, 3);
      break;
    case Layout::kPredef:
      m.position = Value(c, 0), m.velocity = pv, m.acceleration = pa, m.deceleration = pd;
      break;
    case Layout::kPredefAcc:
      m.position = Value(c, 0), m.velocity = Value(c, 1), m.acceleration = pa, m.deceleration = pd;
      break;
    case Layout::kDecEqAcc:
      m.position = Value(c, 0), m.velocity = Value(c, 1), m.acceleration = Value(c, 2),
      m.deceleration = Value(c, 2);
      break;
    case Layout::kS16:
      m.position = Value(c, 0) * sp, m.velocity = Value(c, 1) * sv,
      m.acceleration = Value(c, 2) * sa, m.deceleration = Value(c, 3) * sa;
      break;
    case Layout::kS16Predef:
      m.position = Value(c, 0) * sp, m.velocity = pv, m.acceleration = pa, m.deceleration = pd;
      break;
    case Layout::kS16DecEqAcc:
      m.position = Value(c, 0) * sp, m.velocity = Value(c, 1) * sv,
      m.acceleration = Value(c, 2) * sa, m.deceleration = Value(c, 2) * sa;
      break;
    case Layout::kV3:
      m.velocity = Value(c, 0), m.acceleration = Value(c, 1), m.deceleration = Value(c, 2);
      break;
  }
  return m;
}

bool Is(const mc::McCommand& c, mc::CommandId id) { return c.id() == id; }

}  // namespace

std::string Interpretation::Describe() const {
  const uint16_t raw = header.raw();
  return absl::StrFormat("%03Xx %s", raw >> 4, spec ? spec->name : "(unknown ID)");
}

std::optional<Interpretation> Interpreter::Interpret(std::span<const uint8_t> block,
                                                     uint8_t main_state, bool accepting,
                                                     const Parameters& params) {
  auto header = mc::DecodeHeader(block);
  if (!header.ok()) return std::nullopt;  // cannot happen for a 32-byte block
  // §4.3 rule 1: only a changed count is a new command.
  if (header->count == count_) return std::nullopt;
  // D-36: the remembered count is updated in all cases.
  count_ = header->count;

  Interpretation out;
  out.header = *header;
  out.spec = mc::FindCommand(header->master_id, header->sub_id);
  const mc::CommandId id{header->master_id, header->sub_id};

  // §5.1: No Operation is allowed in any operational state.
  if (id == mc::kNoOperation) {
    out.action = action::Nop{};
    return out;
  }
  // §2.6 / §5.1: Reset is how a fatal error is left, so it is taken in every state
  // (docs/decisions/602-linmot-sim-interpreter.md).
  if (id == mc::kReset) {
    out.action = action::Reset{};
    return out;
  }
  // D-36: states 0-5 and 14 ignore the command; 6, 7, 9-13, 15-21 raise 0086h.
  if (main_state <= static_cast<uint8_t>(MainState::kHwTests) ||
      main_state == static_cast<uint8_t>(MainState::kErrorBehaviourQuickStop) || !accepting) {
    out.action = action::Ignored{};
    return out;
  }
  if (main_state != static_cast<uint8_t>(MainState::kOperationEnabled)) {
    out.action = action::Raise{mc::kMotionCommandInWrongState};
    return out;
  }
  // D-20: unknown IDs and IDs not available on the configured product raise 0081h.
  if (out.spec == nullptr || !out.spec->AvailableOn(product_, force_control_key_)) {
    out.action = action::Raise{mc::kUnknownMotionCommand};
    return out;
  }
  auto decoded = mc::DecodeMotionCommand(block);
  if (!decoded.ok()) {
    out.action = action::Raise{mc::kUnknownMotionCommand};
    return out;
  }
  out.action = Decide(*decoded, params);
  return out;
}

Action Interpreter::Decide(const mc::DecodedMotionCommand& d, const Parameters& p) const {
  const mc::McCommand& c = d.command;
  if (const VaiForm* f = FindForm(c.master_id, c.sub_id)) {
    return action::Move{MakeMove(*f, c, p)};
  }
  const int64_t quick_stop = p.Get(upid::kQuickStopDeceleration);
  // §5.1 system commands.
  if (Is(c, mc::kWriteInterfaceControlWord)) {
    return action::WriteControlWord{static_cast<uint16_t>(Value(c, 0))};
  }
  if (Is(c, mc::kWriteLiveParameter)) {
    return action::WriteLiveParameter{static_cast<uint16_t>(Value(c, 0)),
                                      static_cast<uint32_t>(Value(c, 1))};
  }
  if (Is(c, mc::kSelectPositionControllerSet)) {
    return action::SelectControllerSet{static_cast<uint16_t>(Value(c, 0))};
  }
  if (Is(c, mc::kClearEventEvaluation)) return action::ClearEvent{};
  if (Is(c, mc::kMasterHoming)) return action::MasterHoming{static_cast<int32_t>(Value(c, 0))};
  if (Is(c, mc::kResetIPositionController)) return action::ResetIController{};
  // Stops: 017 (given), 027/0A7 (1721h), 097 (scaled, D-14).
  if (Is(c, mc::kVaiStop)) return action::Stop{Value(c, 0)};
  if (Is(c, mc::kPredefVaiStop) || Is(c, mc::kPredefVai16BitStop)) return action::Stop{quick_stop};
  if (Is(c, mc::kVai16BitStop)) {
    return action::Stop{Value(c, 0) * p.Get(upid::kScaleAcceleration16)};
  }
  // Infinite motions: 02E/02F with the predefined limits, 0CE/0CF with Dec = Acc.
  if (Is(c, mc::kPredefVaiInfinitePositive) || Is(c, mc::kPredefVaiInfiniteNegative)) {
    return action::Infinite{Is(c, mc::kPredefVaiInfinitePositive) ? 1 : -1,
                            p.Get(upid::kPredefVelocity), p.Get(upid::kPredefAcceleration),
                            p.Get(upid::kPredefDeceleration)};
  }
  if (Is(c, mc::kVaiDecAccInfinitePositive) || Is(c, mc::kVaiDecAccInfiniteNegative)) {
    return action::Infinite{Is(c, mc::kVaiDecAccInfinitePositive) ? 1 : -1, Value(c, 0),
                            Value(c, 1), Value(c, 1)};
  }
  // 01E/01F (VA layout) and 09E/09F (scaled): position-transition event handler (§4.5).
  if (c.master_id == 0x01 && (c.sub_id == 0xE || c.sub_id == 0xF)) {
    return action::ChangeOnTransition{c.sub_id == 0xE ? 1 : -1, Value(c, 0), Value(c, 1),
                                      Value(c, 2), Value(c, 3)};
  }
  if (c.master_id == 0x09 && (c.sub_id == 0xE || c.sub_id == 0xF)) {
    const int64_t sa = p.Get(upid::kScaleAcceleration16);
    return action::ChangeOnTransition{
        c.sub_id == 0xE ? 1 : -1, Value(c, 0) * p.Get(upid::kScalePosition16),
        Value(c, 1) * p.Get(upid::kScaleVelocity16), Value(c, 2) * sa, Value(c, 3) * sa};
  }
  // §5.5 time curves 040h-045h (the trigger forms 046-04F stay unsimulated, decision 606).
  if (c.master_id == 0x04 && c.sub_id <= 0x5) {
    using F = action::RunCurve::Form;
    action::RunCurve r;
    r.curve_id = static_cast<uint16_t>(Value(c, 0));
    switch (c.sub_id) {
      case 0x0:
        r.form = F::kDefault;
        break;
      case 0x1:
        r.form = F::kDefaultFromDemand;
        break;
      case 0x2:
        r.form = F::kToPos;
        r.target = static_cast<int32_t>(Value(c, 1));
        break;
      case 0x3:
        r.form = F::kToPosTime;
        r.target = static_cast<int32_t>(Value(c, 1));
        r.curve_time = static_cast<uint32_t>(Value(c, 2));
        break;
      case 0x4:
        r.form = F::kOffsetScales;
        r.offset = static_cast<int32_t>(Value(c, 1));
        r.time_scale = static_cast<uint16_t>(Value(c, 2));
        r.amplitude_scale = static_cast<int16_t>(Value(c, 3));
        break;
      default:
        r.form = F::kOffsetTimeAmplitude;
        r.offset = static_cast<int32_t>(Value(c, 1));
        r.curve_time = static_cast<uint32_t>(Value(c, 2));
        r.amplitude_scale = static_cast<int16_t>(Value(c, 3));
        break;
    }
    return r;
  }
  // Everything else of §5 (curves, streaming, command table, Sin VA, Bestehorn, VAJI, cams,
  // force control, ...): D-28 style, accepted and echoed, logged as not simulated.
  return action::Unsupported{};
}

}  // namespace drivegw::sim::linmot
