// MotionCore: buffered (subsequent) motion blocks selected by Command Mode I409 and the End
// velocity I429 of the positioning commands (stober-motion.md §2.5 L228-245, §2.7, §3.2 Target
// L364-373). The reference leaves the encoding and the chaining open (G-09); the choices are
// docs/decisions/1161 (End velocity), 1162 (Command Mode, one-deep buffer), 1163 (status).
#include <cmath>
#include <utility>

#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober {
namespace {

// Commands whose Done row says "buffered: only at the end of the subsequent block" (§2.7 table,
// L292; the per-command tables L390, L581, L792, L960, L1092, L1577, L1965): they can be a
// subsequent block. MC_Home, the cyclic commands and TorqueControl always start at once.
bool Bufferable(Command c) {
  switch (c) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive:
    case Command::kMoveVelocity:
    case Command::kStop:
    case Command::kMoveSpeed:
    case Command::kHalt:
      return true;
    default:
      return false;
  }
}

}  // namespace

MotionCore::BlockInputs MotionCore::ReadInputs(Command command) const {
  BlockInputs in;
  in.command = command;
  in.position = Get("I403");
  in.velocity = Get("I404");
  in.acceleration = Get("I405");
  in.deceleration = Get("I406");
  in.jerk = Get("I407");
  in.end_velocity = Get("I429");
  in.direction = Get("I411");
  in.brake_at_end = Get("I410");
  in.motion_id = Get("I400");
  return in;
}

// Only the motion-core inputs themselves (no source write-through): the start routines read
// them, and TakeOverBuffered puts the live values back afterwards.
void MotionCore::WriteInputs(const BlockInputs& in) {
  Set("I403", in.position);
  Set("I404", in.velocity);
  Set("I405", in.acceleration);
  Set("I406", in.deceleration);
  Set("I407", in.jerk);
  Set("I429", in.end_velocity);
  Set("I411", in.direction);
  Set("I410", in.brake_at_end);
  Set("I400", in.motion_id);
}

// Decision 1162: I409 = 1 "start at the end of the running block" buffers a bufferable command
// behind a running block that can have a successor; otherwise (I409 = 0, nothing running, a
// command that never ends) the command starts at once and cancels the running one (and a
// buffered one).
void MotionCore::OnExecuteEdge(Command command) {
  if (Get("I409") == 1 && Bufferable(command) && AcceptsSuccessor()) {
    BufferBlock(command);
    return;
  }
  StartCommand(command);
}

// The running block has not ended yet and its end is defined: positioning until its profile
// ends at (or passes) the target, MoveVelocity/MoveSpeed until the set velocity is reached,
// MC_Halt until standstill. MC_Stop blocks every start (L1059); Home, cyclic and torque
// commands have no end to append to (L1404, L1699, L1828).
bool MotionCore::AcceptsSuccessor() const {
  if (!command_active_ || quick_stopping_ || limit_stop_) return false;
  if (plc_ == PlcState::kStopping || plc_ == PlcState::kErrorStop) return false;
  switch (command_) {
    case Command::kMoveAbsolute:
    case Command::kMoveRelative:
    case Command::kMoveAdditive:
      return !done_latched_ && drive_ == Drive::kProfile &&
             (stop_held_by_override_ || passing_ || profile_.Active(t_));
    case Command::kMoveVelocity:
    case Command::kMoveSpeed:
      return drive_ == Drive::kProfile && t_ < ramp_end_ - motion::Profile::kEndTolerance;
    case Command::kHalt:
      return Moving();
    default:
      return false;
  }
}

// §2.7 (L387, L391): at every command start I91/I90/I92 are 0 for at least one cycle; §2.5
// (L390): Done only at the end of the subsequent block — the status set belongs to the chain
// from this edge on (decision 1163). The running block keeps its motion, I89 and motion ID I82;
// the inputs are latched now (§2.2 L183). A second buffered start replaces the first (one deep).
void MotionCore::BufferBlock(Command command) {
  command_started_ = true;
  start_cycle_ = cycle_;
  error_ = false;
  cause_ = Cause::kNone;
  error_text_.clear();
  done_ = false;
  done_latched_ = false;
  buffered_ = ReadInputs(command);
}

// The running block ends at profile time `end_time` inside this cycle (Integrate): the buffered
// block takes over, or a pass without one turns back to the target. The rest of the cycle runs
// on the new profile, so the set values stay continuous.
void MotionCore::EndOfBlock(double end_time) {
  const double remainder = t_ - end_time;
  if (buffered_) {
    TakeOverBuffered(end_time);
  } else {
    PassWithoutSuccessor(end_time);
  }
  if (drive_ == Drive::kProfile) {
    t_ += remainder;
    set_ = profile_.At(t_);
  }
}

// §2.5: the subsequent block starts at the end of the running one, from its end state (at rest
// on the target, or passing it at the End velocity, L368). It is a command start in its own
// right: denial rules, target ("actual position at command start", L413), I82 and I89 are those
// of this cycle (decision 1162); a denial from motion stops by quick stop (L310).
void MotionCore::TakeOverBuffered(double end_time) {
  t_ = end_time;
  set_ = profile_.At(end_time);
  if (options_.following_time_constant_ms <= 0) {
    actual_position_ = set_.position;  // ideal following: the actual state at the block's end
    actual_velocity_ = set_.velocity;
  }
  const BlockInputs next = *buffered_;
  buffered_.reset();
  // The start routines read the inputs; give them the latched ones for this start only — the
  // master may already have written the next command's values.
  const BlockInputs live = ReadInputs(next.command);
  WriteInputs(next);
  StartCommand(next.command);
  WriteInputs(live);
}

// Decision 1161 (G-09): the target is passed at the End velocity and no subsequent block is
// buffered: the block goes on as one with End velocity 0 — it brakes with its deceleration and
// jerk and returns to the target (an intermediate stop, L304-306), Done there as usual.
void MotionCore::PassWithoutSuccessor(double end_time) {
  t_ = end_time;
  set_ = profile_.At(end_time);
  passing_ = false;
  end_velocity_ = 0;
  PlanPositioning();
}

}  // namespace drivegw::sim::stober
