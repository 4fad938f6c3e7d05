// The LinMot DeviceNet family's parameter catalogue for the API (issue 6, decision 009): the
// Get/Set command pairs of linmot-devicenet.md §8.9 that LinMotDnDrive::WriteParameter takes.
#pragma once

#include <memory>

#include "adapters/core/parameter_catalogue.h"

namespace drivegw::linmot::devicenet {

// One definition per pair: id = the Set command ID (the drive reads through its Get half, id - 1,
// decision 985), name "0x51"; Find also takes the Get ID ("0x50"), decimal, the snake key
// ("set_filter_max_speed") and the command name. Ranges per decision 906; 16-bit, volatile: no
// stored values (D-29).
std::shared_ptr<const ParameterCatalogue> MakeLinMotDevicenetCatalogue();

}  // namespace drivegw::linmot::devicenet
