// Validation of SimOptions: every bad field is named with its value and the accepted range.
#include "sim/linmot/options.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace drivegw::sim::linmot {
namespace {

absl::Status Bad(const char* field, double value, const std::string& rule) {
  return absl::InvalidArgumentError(absl::StrCat("sim_options.", field, ": ", value, " ", rule));
}

}  // namespace

absl::Status ValidateOptions(const SimOptions& o) {
  const double tick_ms = std::chrono::duration<double, std::milli>(o.tick).count();
  // D-23: 1 ms default, configurable down to 0.25 ms.
  if (!(tick_ms >= 0.25 && tick_ms <= 10)) return Bad("tick_ms", tick_ms, "is outside [0.25, 10]");
  if (!std::isfinite(o.stroke_min_mm) || !std::isfinite(o.stroke_max_mm) ||
      o.stroke_min_mm >= o.stroke_max_mm) {
    return Bad("stroke_max_mm", o.stroke_max_mm,
               absl::StrCat("must be finite and above stroke_min_mm ", o.stroke_min_mm));
  }
  auto inside = [&](const char* field, double v) -> absl::Status {
    if (!std::isfinite(v) || v < o.stroke_min_mm || v > o.stroke_max_mm) {
      return Bad(
          field, v,
          absl::StrCat("is outside the stroke [", o.stroke_min_mm, ", ", o.stroke_max_mm, "]"));
    }
    return absl::OkStatus();
  };
  if (auto s = inside("initial_position_mm", o.initial_position_mm); !s.ok()) return s;
  if (auto s = inside("home_position_mm", o.home_position_mm); !s.ok()) return s;
  auto positive = [](const char* field, double v) -> absl::Status {
    if (!std::isfinite(v) || v <= 0) return Bad(field, v, "must be > 0");
    return absl::OkStatus();
  };
  if (auto s = positive("max_velocity_mm_s", o.max_velocity_mm_s); !s.ok()) return s;
  if (auto s = positive("homing_velocity_mm_s", o.homing_velocity_mm_s); !s.ok()) return s;
  if (auto s = positive("homing_acceleration_mm_s2", o.homing_acceleration_mm_s2); !s.ok()) {
    return s;
  }
  if (auto s = positive("force_constant_n_per_a", o.force_constant_n_per_a); !s.ok()) return s;
  if (!std::isfinite(o.moving_mass_kg) || o.moving_mass_kg < 0) {
    return Bad("moving_mass_kg", o.moving_mass_kg, "must be >= 0");
  }
  if (!std::isfinite(o.lag_time_constant_s) || o.lag_time_constant_s < 0) {
    return Bad("lag_time_constant_s", o.lag_time_constant_s, "must be >= 0");
  }
  if (!std::isfinite(o.in_target_window_mm) || o.in_target_window_mm < 0) {
    return Bad("in_target_window_mm", o.in_target_window_mm, "must be >= 0");
  }
  if (o.hw_test_time < Duration{0} || o.boot_time < Duration{0} ||
      o.flash_save_time < Duration{0}) {
    return absl::InvalidArgumentError(
        "sim_options: hw_test_time, boot_time and flash_save_time "
        "must be >= 0");
  }
  if (o.rtc_busy_telegrams < 0 || o.rtc_busy_telegrams > 1000) {
    return Bad("rtc_busy_telegrams", o.rtc_busy_telegrams, "is outside [0, 1000]");
  }
  if (o.min_reply_payload > 1472) {
    return Bad("min_reply_payload", static_cast<double>(o.min_reply_payload),
               "exceeds one Ethernet frame (1472)");
  }
  if (o.master_filter == MasterFilter::kSingleMasterFixIp && o.master_ip == 0) {
    return absl::InvalidArgumentError(
        "sim_options.master_ip: 0.0.0.0 with master_filter single-master-fix-ip");
  }
  return absl::OkStatus();
}

}  // namespace drivegw::sim::linmot
