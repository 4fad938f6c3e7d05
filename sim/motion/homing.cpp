// Homing procedure (linmot-mc.md D-39, D-06) generalised for switch and mechanical-stop searches.
#include "sim/motion/homing.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::motion {
namespace {

absl::Status CheckLimits(const char* field, const Limits& l) {
  for (auto [name, value] :
       {std::pair{"max_velocity", l.max_velocity}, std::pair{"acceleration", l.acceleration},
        std::pair{"deceleration", l.deceleration}}) {
    if (!std::isfinite(value) || value <= 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("homing.", field, ".", name, ": ", value, " must be finite and > 0"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckFinite(const char* field, double value) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("homing.", field, ": ", value, " is not finite"));
}

}  // namespace

absl::StatusOr<Homing> Homing::Create(HomingConfig config) {
  if (auto s = CheckLimits("limits", config.limits); !s.ok()) return s;
  if (config.initial_limits.has_value()) {
    if (auto s = CheckLimits("initial_limits", *config.initial_limits); !s.ok()) return s;
  }
  if (auto s = CheckFinite("feature_position_mm", config.feature_position_mm); !s.ok()) return s;
  if (auto s = CheckFinite("home_position_mm", config.home_position_mm); !s.ok()) return s;
  if (config.initial_position_mm.has_value()) {
    if (auto s = CheckFinite("initial_position_mm", *config.initial_position_mm); !s.ok()) {
      return s;
    }
  }
  if (config.direction != 1 && config.direction != -1) {
    return absl::InvalidArgumentError(
        absl::StrCat("homing.direction: ", config.direction, " must be +1 or -1"));
  }
  if (std::isnan(config.max_search_distance_mm) || config.max_search_distance_mm <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "homing.max_search_distance_mm: ", config.max_search_distance_mm, " must be > 0"));
  }
  if (std::isnan(config.timeout_s) || config.timeout_s <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("homing.timeout_s: ", config.timeout_s, " must be > 0"));
  }
  return Homing(std::move(config));
}

absl::Status Homing::Start(Axis& axis) {
  status_ = absl::OkStatus();
  elapsed_s_ = 0;
  switch_found_ = false;
  search_start_physical_mm_ = axis.physical_position();
  if (config_.method == HomingMethod::kMoveToFeature) {
    // D-39: a VA move (simulator parameters) to the configured home target, from the demand
    // state so a running motion continues without a jump.
    const double target = config_.feature_position_mm + axis.reference_offset();
    if (auto s = axis.MoveTo(target, config_.limits); !s.ok()) return s;
  } else {
    const double beyond =
        (axis.physical_position() - config_.feature_position_mm) * config_.direction;
    if (beyond >= 0) {
      // Already on the switch: its edge is still latched at the feature position (a real
      // drive backs off and re-approaches; the resulting reference is the same), so just stop.
      switch_found_ = true;
      if (auto s = axis.Stop(config_.limits.deceleration); !s.ok()) return s;
    } else if (auto s = axis.Jog(config_.direction * config_.limits.max_velocity, config_.limits,
                                 std::nullopt);
               !s.ok()) {
      return s;
    }
  }
  phase_ = HomingPhase::kSearching;
  return absl::OkStatus();
}

void Homing::Advance(Axis& axis, double dt) {
  axis.Advance(dt);
  if (phase_ == HomingPhase::kIdle || phase_ == HomingPhase::kDone ||
      phase_ == HomingPhase::kAborted) {
    return;
  }
  if (dt > 0) elapsed_s_ += dt;
  if (elapsed_s_ > config_.timeout_s) {
    Fail(axis, absl::DeadlineExceededError(
                   absl::StrCat("homing: not finished within timeout_s=", config_.timeout_s)));
    return;
  }
  switch (phase_) {
    case HomingPhase::kSearching: {
      if (config_.method == HomingMethod::kSwitch && !switch_found_) {
        const double physical = axis.physical_position();
        if ((physical - config_.feature_position_mm) * config_.direction >= 0) {
          switch_found_ = true;
          // Limits were validated in Create, so the stop cannot be refused.
          (void)axis.Stop(config_.limits.deceleration);
        } else if (std::abs(physical - search_start_physical_mm_) >
                   config_.max_search_distance_mm) {
          Fail(axis, absl::NotFoundError(
                         absl::StrCat("homing.switch: not found within max_search_distance_mm=",
                                      config_.max_search_distance_mm)));
          return;
        }
      }
      const bool search_over = config_.method == HomingMethod::kMoveToFeature || switch_found_;
      if (search_over && !axis.motion_active()) phase_ = HomingPhase::kSettingReference;
      return;
    }
    case HomingPhase::kSettingReference: {
      // The feature (switch edge, home target, mechanical stop) becomes home_position_mm:
      // reported = physical + home − feature (stober-motion.md §4.3, trinamic §5.7 step 10).
      axis.SetPosition(axis.physical_position() + config_.home_position_mm -
                       config_.feature_position_mm);
      if (!config_.initial_position_mm.has_value()) {
        phase_ = HomingPhase::kDone;
        return;
      }
      if (auto s = axis.MoveTo(*config_.initial_position_mm,
                               config_.initial_limits.value_or(config_.limits));
          !s.ok()) {
        Fail(axis, absl::InternalError(absl::StrCat("homing: initial move: ", s.message())));
        return;
      }
      phase_ = HomingPhase::kGoingToInitialPosition;
      return;
    }
    case HomingPhase::kGoingToInitialPosition:
      if (!axis.motion_active()) phase_ = HomingPhase::kDone;
      return;
    case HomingPhase::kIdle:
    case HomingPhase::kDone:
    case HomingPhase::kAborted:
      return;
  }
}

void Homing::Abort(Axis& axis, double deceleration) {
  if (phase_ == HomingPhase::kIdle || phase_ == HomingPhase::kDone ||
      phase_ == HomingPhase::kAborted) {
    return;
  }
  // linmot-mc.md D-06: releasing the bit stops with the quick-stop deceleration; not homed.
  if (!axis.Stop(deceleration).ok()) axis.Halt();
  phase_ = HomingPhase::kAborted;
  status_ = absl::CancelledError("homing: aborted");
}

void Homing::Fail(Axis& axis, absl::Status status) {
  (void)axis.Stop(config_.limits.deceleration);
  phase_ = HomingPhase::kAborted;
  status_ = std::move(status);
}

}  // namespace drivegw::sim::motion
