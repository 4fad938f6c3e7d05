// The LinMot (LinUDP) family's parameter catalogue for the API (issue 6, decision 009): the UPIDs
// of the MC SW that the references document (linmot-mc.md §0.4, §9.2; linmot-linudp.md §4.2,
// 6.8). LinUDP reaches them through its RTC channel (Read/Write RAM/ROM value by UPID).
#pragma once

#include <memory>

#include "adapters/core/parameter_catalogue.h"

namespace drivegw::linmot::linudp {

// Name = id text "0x14BE"; id = UPID as LinMotUdpDrive::Read/WriteParameter take it. The address
// space is open: every UPID 0x0000..0xFFFF is Find-able (undocumented ones as a raw 32-bit
// definition), because drives carry far more UPIDs than the manuals name (MC22 L3990).
std::shared_ptr<const ParameterCatalogue> MakeLinMotCatalogue();

}  // namespace drivegw::linmot::linudp
