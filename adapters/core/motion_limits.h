// The checks every drive family applies to a motion command before anything goes on the wire:
// a profile limit (velocity, acceleration) is positive and within the axis limit, a position (or
// the target a distance leads to) lies inside the axis range. One rule for all families (decision
// 1089); each family only adds its reference to the message where it has one.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "adapters/core/drive_config.h"

namespace drivegw {

// InvalidArgument "<field>: <value> must be positive<positive_note>" for a value <= 0 or not
// finite (the gateway never sends a zero limit); OutOfRange "... exceeds axis limit <limit>
// (<axis_field>)" above `axis_limit`. `positive_note` cites a family's manual, e.g.
// " (linmot-mc.md D-42)".
absl::Status CheckProfileLimit(const std::string& field, double value, double axis_limit,
                               const char* axis_field, const char* positive_note = "");

// The profile of a move named `kind` ("move_absolute"): "<kind>.velocity_mm_s" against
// axis.max_velocity_mm_s, then "<kind>.acceleration_mm_s2" and "<kind>.deceleration_mm_s2"
// against axis.max_acceleration_mm_s2 (CheckProfileLimit each). `d` is the deceleration as the
// drive uses it (a request's 0 already replaced by the acceleration, command.h).
absl::Status CheckMoveProfile(const std::string& kind, double v, double a, double d,
                              const AxisConfig& axis, const char* positive_note = "");

// InvalidArgument for a `value` that is not finite; OutOfRange when `target` (the position the
// command takes the axis to: `value` itself for an absolute move) lies outside
// [axis.min_mm, axis.max_mm].
absl::Status CheckAxisPosition(const std::string& field, double value, double target,
                               const AxisConfig& axis);

}  // namespace drivegw
