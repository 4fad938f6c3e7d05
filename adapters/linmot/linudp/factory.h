// Factory of the LinMot-over-LinUDP drive family: checks the config, builds a LinMotUdpDrive.
// The composition root (server/) registers it in the DriveRegistry under family "linmot".
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/parameter_catalogue.h"

namespace drivegw::linmot::linudp {

// Family name under which the composition root registers CreateLinMotUdpDrive.
inline constexpr char kFamilyName[] = "linmot";

// The family's parameter catalogue (issue 6, decision 009), one instance per process.
std::shared_ptr<const ParameterCatalogue> LinMotParameterCatalogue();

// InvalidArgument naming the field when `config.linudp` is missing or a LinUDP value cannot
// work (e.g. "drive 'x1'.linudp.cycle: 0 ms is below 1 ms"); the drive starts UNCONFIGURED
// (no socket until Activate). `clock` must outlive the drive.
// The drive's health config (decision 1431): drives[i].health over the family defaults
// (down_after_failures = linudp.lost_after_timeouts, back-off 0 = probe every cycle).
HealthConfig LinUdpHealthConfig(const DriveConfig& config);

absl::StatusOr<std::unique_ptr<Drive>> CreateLinMotUdpDrive(const DriveConfig& config,
                                                            const Clock& clock);

}  // namespace drivegw::linmot::linudp
