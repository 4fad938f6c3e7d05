// Factory of the LinMot DeviceNet drive family: checks the config, builds a LinMotDnDrive.
// The composition root (server/) registers it in the DriveRegistry under "linmot-devicenet".
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/parameter_catalogue.h"

namespace drivegw::linmot::devicenet {

// Family name under which the composition root registers CreateLinMotDnDrive.
inline constexpr char kFamilyName[] = "linmot-devicenet";

// The family's parameter catalogue (issue 6, decision 009), one instance per process.
std::shared_ptr<const ParameterCatalogue> LinMotDevicenetParameterCatalogue();

// InvalidArgument naming the field when `config.can` or `config.mac_id` is missing or cannot
// work (e.g. "drive 'x1'.mac_id: 0 is the gateway's own MAC ID (decision 981)"); the drive starts
// UNCONFIGURED (no bus until Activate). `clock` must outlive the drive.
absl::StatusOr<std::unique_ptr<Drive>> CreateLinMotDnDrive(const DriveConfig& config,
                                                           const Clock& clock);

}  // namespace drivegw::linmot::devicenet
