// Factory of the Trinamic SIXpack/QUADpack family: checks DriveConfig.trinamic naming the field,
// then builds the axis drive on its controller's shared session (trinamic-sixpack.md).
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/parameter_catalogue.h"

namespace drivegw::trinamic {

inline constexpr char kFamilyName[] = "trinamic";

// InvalidArgument "drive 'feeder-x'.trinamic.axis: 6 exceeds 5 (SIXpack motors 0..5)" etc.
absl::StatusOr<std::unique_ptr<Drive>> CreateTrinamicDrive(const DriveConfig& config,
                                                           const Clock& clock);

// The family's parameter catalogue (issue 6, decision 009), one instance per process.
std::shared_ptr<const drivegw::ParameterCatalogue> TrinamicParameterCatalogue();

}  // namespace drivegw::trinamic
