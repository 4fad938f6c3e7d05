// CreateTrinamicDrive: every check of DriveConfig.trinamic names the field and its limit; the
// configured parameters are validated in order against a shadow that starts at the PACK's
// defaults (§5.12), so cross-field rules (amax <= vstart × 64, ...) see the earlier entries.
#include "adapters/trinamic/factory.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/drive.h"
#include "adapters/trinamic/parameters.h"

namespace drivegw::trinamic {
namespace {

absl::Status Bad(const DriveConfig& c, const std::string& field, const std::string& why) {
  return absl::InvalidArgumentError(
      absl::StrCat("drive '", c.name, "'.trinamic.", field, ": ", why));
}

}  // namespace

absl::StatusOr<std::unique_ptr<Drive>> CreateTrinamicDrive(const DriveConfig& config,
                                                           const Clock& clock) {
  if (!config.trinamic) {
    return absl::InvalidArgumentError(
        absl::StrCat("drive '", config.name, "': family 'trinamic' needs a trinamic section"));
  }
  const TrinamicConfig& t = *config.trinamic;
  if (t.serial.has_value() == t.can.has_value()) {
    return Bad(config, "serial/can", "exactly one of serial and can must be set (G-28)");
  }
  if (t.serial) {
    if (t.serial->device.empty()) return Bad(config, "serial.device", "must not be empty");
    if (auto s = transport::ValidateBaud(t.serial->baud); !s.ok()) {
      return Bad(config, "serial.baud", std::string(s.message()));
    }
    if (t.serial->rs485 && t.serial->turnaround.count() < 0) {
      return Bad(config, "serial.turnaround", "must not be negative");
    }
  }
  if (t.address == 0) {
    return Bad(config, "address", "0 is not a unit address (1..255, G-05, CT-50)");
  }
  if (t.axes != 4 && t.axes != 6) {
    return Bad(config, "axes", absl::StrCat(t.axes, " is neither 6 (SIXpack) nor 4 (QUADpack)"));
  }
  if (t.axis >= t.axes) {
    return Bad(config, "axis",
               absl::StrCat(std::to_string(t.axis), " exceeds ", t.axes - 1, " (",
                            t.axes == 6 ? "SIXpack" : "QUADpack", " motors 0..", t.axes - 1, ")"));
  }
  if (!(t.microsteps_per_unit > 0) || !std::isfinite(t.microsteps_per_unit)) {
    return Bad(config, "microsteps_per_unit",
               absl::StrCat(t.microsteps_per_unit, " must be a positive number"));
  }
  if (auto s = ValidateResponseAddress(t.response_address); !s.ok()) {
    return Bad(config, "response_address", std::string(s.message()));
  }
  if (t.response_address == t.address) {
    return Bad(config, "response_address",
               absl::StrCat(std::to_string(t.response_address),
                            " equals the controller address (CT-50, §2.4)"));
  }
  if (t.poll_period.count() <= 0) return Bad(config, "poll_period", "must be > 0 ms");
  if (t.reply_timeout.count() <= 0) return Bad(config, "reply_timeout", "must be > 0 ms");
  if (t.offline_after_misses < 1) return Bad(config, "offline_after_misses", "must be >= 1");
  // Decision 1431: drives[i].health over the family defaults (offline_after_misses, 100 ms..5 s).
  HealthConfig health;
  health.down_after_failures = t.offline_after_misses;
  health.backoff_min = t.retry_min;
  health.backoff_max = t.retry_max;
  health.up_after = t.up_after;
  health = ResolveHealthConfig(config.health, health);
  if (auto s = ValidateHealthConfig(health, absl::StrCat("drive '", config.name, "'.health."));
      !s.ok()) {
    return s;
  }
  DriveConfig resolved = config;
  resolved.trinamic->offline_after_misses = health.down_after_failures;
  resolved.trinamic->retry_min = health.backoff_min;
  resolved.trinamic->retry_max = health.backoff_max;
  resolved.trinamic->up_after = health.up_after;
  // The whole axis range must be int32 microsteps (L60, L693).
  for (const auto& [field, mm] : {std::pair<const char*, double>{"min_mm", config.axis.min_mm},
                                  std::pair<const char*, double>{"max_mm", config.axis.max_mm}}) {
    const double steps = mm * t.microsteps_per_unit;
    if (!std::isfinite(steps) || steps < std::numeric_limits<int32_t>::min() ||
        steps > std::numeric_limits<int32_t>::max()) {
      return absl::InvalidArgumentError(
          absl::StrCat("drive '", config.name, "'.axis.", field, ": ", mm, " mm = ", steps,
                       " microsteps at trinamic.microsteps_per_unit ", t.microsteps_per_unit,
                       " exceeds the int32 position range (L60)"));
    }
  }
  ParameterShadow shadow(t.axis, t.axes);
  const int baud = t.serial ? t.serial->baud : 19200;
  for (size_t i = 0; i < t.parameters.size(); ++i) {
    const auto& [name, value] = t.parameters[i];
    const std::string field = absl::StrCat("parameters[", i, "] '", name, "'");
    auto def = FindParameter(name);
    if (!def.ok()) return Bad(config, field, std::string(def.status().message()));
    if (auto s = shadow.Validate((*def)->id, value, baud); !s.ok()) {
      return Bad(config, field, std::string(s.message()));
    }
    shadow.Set((*def)->id, value);
  }
  return std::unique_ptr<Drive>(std::make_unique<TrinamicDrive>(resolved, clock, shadow));
}

}  // namespace drivegw::trinamic
