// MC motion command interpreter: the count rule (§4.3), the state rule (D-36), unknown IDs
// (D-20) and the mapping of each supported command to an action for the device (§5).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>

#include "adapters/linmot/mc/motion_command.h"
#include "sim/linmot/parameters.h"
#include "sim/motion/axis.h"

namespace drivegw::sim::linmot {

// How a VAI command computes its target (linmot-mc.md §5.0 "target computation").
enum class TargetRule {
  kAbsolute,          // Go To Pos
  kIncrementDemand,   // target = demand position + increment (011)
  kIncrementTarget,   // target = former target + increment (012)
  kIncrementActual,   // target = actual position + increment (015, 016)
  kCmdTabVar1,        // target = 1E72h (0D4, 0D6)
  kCmdTabVar2,        // target = 1E73h (0D5, 0D7)
  kCapturedIncrement  // target = 1E62h + increment (0D0)
};

// When a VAI command starts (§4.5 event handler).
enum class Fire {
  kNow,
  kAfterActualCommand,  // 018 family: when set-point generation has finished (one-shot, D-12)
  kRisingTrigger,       // 01A/01B family: on every rising trigger edge until 008x
  kFallingTrigger,      // 01C/01D family
};

// Values in wire units after 16-bit scaling (D-14) and parameter look-ups (Predef, 1721h):
// positions 0.1 um, velocities 1E-6 m/s, accelerations 1E-5 m/s^2.
struct VaiMove {
  TargetRule rule = TargetRule::kAbsolute;
  sim::motion::StartFrom start = sim::motion::StartFrom::kDemand;
  Fire fire = Fire::kNow;
  int64_t position = 0;  // target or increment (unused for CT var targets)
  int64_t velocity = 0;
  int64_t acceleration = 0;
  int64_t deceleration = 0;
};

namespace action {
struct Nop {};
// New count, not executed: states 0-5 and 14 (D-36) or an OFF3 quick stop in progress.
struct Ignored {};
struct Move {
  VaiMove move;
};
struct Stop {
  int64_t deceleration = 0;
};
struct Infinite {
  int direction = 1;
  int64_t velocity = 0;
  int64_t acceleration = 0;
  int64_t deceleration = 0;
};
// 01E/01F: when the demand crosses `position` in `direction`, the VAI limits are replaced.
struct ChangeOnTransition {
  int direction = 1;
  int64_t position = 0;
  int64_t velocity = 0;
  int64_t acceleration = 0;
  int64_t deceleration = 0;
};
struct WriteControlWord {
  uint16_t control_word = 0;
};
struct WriteLiveParameter {
  uint16_t upid = 0;
  uint32_t raw = 0;
};
struct SelectControllerSet {
  uint16_t set = 0;
};
struct ClearEvent {};
struct MasterHoming {
  int32_t home_position = 0;
};
struct ResetIController {};
// §5.5 040h-045h (linmot-mc.md L515-L535, D-29 L1009): a stored time curve. Which start
// parameters come from the command and which from 14C9h-14CBh or the demand position is the
// device's job (decision 606); here only the raw command values.
struct RunCurve {
  enum class Form {
    kDefault,             // 040: offset, amplitude, time scale from 14C9h/14CAh/14CBh
    kDefaultFromDemand,   // 041: offset := demand position, scales from 14CAh/14CBh
    kToPos,               // 042: offset := demand, amplitude to reach target, time from 14CBh
    kToPosTime,           // 043: as 042 with curve_time
    kOffsetScales,        // 044: offset, time_scale, amplitude_scale given
    kOffsetTimeAmplitude  // 045: offset, curve_time, amplitude_scale given
  };
  Form form = Form::kDefault;
  uint16_t curve_id = 0;
  int32_t target = 0;           // 042/043, 0.1 um
  uint32_t curve_time = 0;      // 043/045, 10 us
  int32_t offset = 0;           // 044/045, 0.1 um
  uint16_t time_scale = 0;      // 044, 0.01 %
  int16_t amplitude_scale = 0;  // 044/045, 0.1 %
};
struct Reset {};
// The drive raises this §10 error (0081h unknown / unavailable ID, 0086h wrong state).
struct Raise {
  uint16_t code = 0;
};
// A known command the simulator does not model (D-28 style): count echoed, logged.
struct Unsupported {};
}  // namespace action

using Action = std::variant<action::Nop, action::Ignored, action::Move, action::Stop,
                            action::Infinite, action::ChangeOnTransition, action::WriteControlWord,
                            action::WriteLiveParameter, action::SelectControllerSet,
                            action::ClearEvent, action::MasterHoming, action::ResetIController,
                            action::RunCurve, action::Reset, action::Raise, action::Unsupported>;

struct Interpretation {
  mc::Header header;
  const mc::CommandSpec* spec = nullptr;  // null for an unknown ID
  Action action;
  // "010 VAI Go To Pos" style label for logs.
  std::string Describe() const;
};

class Interpreter {
 public:
  Interpreter(mc::Product product, bool force_control_key)
      : product_(product), force_control_key_(force_control_key) {}

  // §4.3 rule 4 / A-08: the remembered count is 0 after power-up and after Reset.
  void PowerUp() { count_ = 0; }
  uint8_t count() const { return count_; }

  // nullopt when the count nibble equals the remembered one (§4.3 rule 1: nothing happens).
  // Otherwise the count is remembered whatever follows (D-36) and the action says what to do
  // in `main_state`. `accepting` = false while an OFF3 quick stop runs.
  std::optional<Interpretation> Interpret(std::span<const uint8_t> block, uint8_t main_state,
                                          bool accepting, const Parameters& params);

 private:
  Action Decide(const mc::DecodedMotionCommand& cmd, const Parameters& params) const;

  mc::Product product_;
  bool force_control_key_;
  uint8_t count_ = 0;
};

}  // namespace drivegw::sim::linmot
