// The Trinamic family's parameter catalogue for the API (issue 6, decision 009): the existing
// adapters/trinamic/parameters.h table seen through the family-neutral ParameterCatalogue seam.
#pragma once

#include <memory>

#include "adapters/core/parameter_catalogue.h"

namespace drivegw::trinamic {

// Single-value checks only (field range, the codec field's multiple-of rule); the cross-field
// rules of CT-55 need the other values of the axis and stay with ParameterShadow::Validate,
// which TrinamicDrive::WriteParameter applies (decision 009).
std::shared_ptr<const drivegw::ParameterCatalogue> MakeTrinamicCatalogue();

}  // namespace drivegw::trinamic
