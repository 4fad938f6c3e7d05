// The STOBER family's parameter catalogue for the API (issue 6, decision 009), built from the
// wire binding of adapters/stober/object_map.h.
#pragma once

#include <memory>

#include "adapters/core/parameter_catalogue.h"

namespace drivegw::stober {

// Every bound object: name "I10" / "A515" (a CiA 402 alias at a second address is named by its
// address, "0x606C:00"), id = index << 8 | sub as StoberDrive::Read/WriteParameter take it.
// Values are whole user units, as the drive carries them (it rounds Decode's user value).
std::shared_ptr<const ParameterCatalogue> MakeStoberCatalogue();

}  // namespace drivegw::stober
