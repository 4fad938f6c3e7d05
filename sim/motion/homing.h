// Simulated homing over an Axis: search, set the reference, optionally go to the initial position.
#pragma once

#include <limits>
#include <optional>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "sim/motion/axis.h"
#include "sim/motion/profile.h"

namespace drivegw::sim::motion {

// Phases, observable by the family (LinMot sub states, trinamic action codes 20..29, STOBER I89).
enum class HomingPhase {
  kIdle,
  kSearching,               // moving towards the reference feature
  kSettingReference,        // stopped; the reference is applied on the next Advance
  kGoingToInitialPosition,  // linmot-mc.md §2.2 state 11 / stober-motion.md §4.3 I43
  kDone,                    // homed
  kAborted,                 // Abort() or a search/time limit; status() says why (D-06: not homed)
};

enum class HomingMethod {
  // linmot-mc.md D-39: a VA move to the feature position, which is then the reference. Also
  // models a mechanical stop (trinamic-sixpack.md §5.7 MechRef, stober-motion.md §4.2 P-S).
  kMoveToFeature,
  // Constant-velocity search in `direction` until the actual position crosses a simulated
  // switch at the feature position, then a stop with limits.deceleration. The edge is latched
  // exactly (hardware capture), so the reference does not depend on the tick
  // (trinamic-sixpack.md §5.7, stober-motion.md §8.7).
  kSwitch,
};

struct HomingConfig {
  HomingMethod method = HomingMethod::kMoveToFeature;
  // Search motion (D-39: simulator parameters); kSwitch searches at limits.max_velocity.
  Limits limits;
  // Where the home target / switch edge / mechanical stop is, in the physical frame.
  double feature_position_mm = 0;
  // Reported position assigned to the feature (LinMot Home Position 13C7h, STOBER I34).
  double home_position_mm = 0;
  // kSwitch only: +1 or −1 (trinamic NullLeft, STOBER initial movement).
  int direction = -1;
  // kSwitch only: give up (NotFound) after this search travel; infinity = never.
  double max_search_distance_mm = std::numeric_limits<double>::infinity();
  // Whole procedure time limit (DeadlineExceeded); infinity = none.
  double timeout_s = std::numeric_limits<double>::infinity();
  // Reported-frame position to go to after referencing (LinMot state 11, STOBER I43).
  std::optional<double> initial_position_mm;
  // Limits for the initial-position move; defaults to `limits`.
  std::optional<Limits> initial_limits;
};

// The homing procedure. Drive it with Advance(axis, dt) instead of axis.Advance(dt) while it is
// in a moving phase; in kIdle/kDone/kAborted Advance only advances the axis.
class Homing {
 public:
  // InvalidArgument for zero/negative/non-finite limits, direction not ±1, negative distances.
  static absl::StatusOr<Homing> Create(HomingConfig config);

  // Starts (or restarts) the search from the axis' demand state.
  absl::Status Start(Axis& axis);
  // Advances the axis by `dt` seconds and the procedure by one step.
  void Advance(Axis& axis, double dt);
  // Stops the axis with `deceleration` (D-06: quick stop) and enters kAborted (Cancelled).
  void Abort(Axis& axis, double deceleration);

  HomingPhase phase() const { return phase_; }
  // kDone reached since the last Start (LinMot Homed bit, STOBER I86).
  bool homed() const { return phase_ == HomingPhase::kDone; }
  // OK unless kAborted: Cancelled (Abort), NotFound (switch), DeadlineExceeded (timeout).
  const absl::Status& status() const { return status_; }
  const HomingConfig& config() const { return config_; }

 private:
  explicit Homing(HomingConfig config) : config_(std::move(config)) {}
  void Fail(Axis& axis, absl::Status status);

  HomingConfig config_;
  HomingPhase phase_ = HomingPhase::kIdle;
  absl::Status status_;
  double elapsed_s_ = 0;
  double search_start_physical_mm_ = 0;
  bool switch_found_ = false;
};

}  // namespace drivegw::sim::motion
