// Factory of the STOBER family: checks DriveConfig (can, node_id, canopen timing) naming the field,
// then builds the CiA 402 / motion-core drive on the bus's shared CANopen master
// (stober-motion.md).
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/parameter_catalogue.h"

namespace drivegw::stober {

inline constexpr char kFamilyName[] = "stober";

// InvalidArgument "drive 'axis-1'.node_id: 0 is not a CANopen node ID 1..127" etc.
// drives[i].health over the family defaults (decision 1431): DOWN after 1 failed configuration
// (the node is absent), re-configuration every 500 ms (decision 1194), i.e. no doubling.
HealthConfig StoberHealthConfig(const DriveConfig& config);

absl::StatusOr<std::unique_ptr<Drive>> CreateStoberDrive(const DriveConfig& config,
                                                         const Clock& clock);

// The family's parameter catalogue (issue 6, decision 009), one instance per process.
std::shared_ptr<const ParameterCatalogue> StoberParameterCatalogue();

}  // namespace drivegw::stober
