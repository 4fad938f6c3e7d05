// The STOBER drive the adapter tests configure: name, bus, node ID, a ±200 mm axis at 1000 mm/s
// and 10000 mm/s², heartbeat 50 ms. Each test sets its time-outs on top.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>

#include "adapters/core/drive_config.h"
#include "adapters/stober/factory.h"

namespace drivegw::stober {

inline void SetTestAxis(DriveConfig& c, std::string name, const CanBusConfig& bus, uint8_t node) {
  c.name = std::move(name);
  c.family = kFamilyName;
  c.can = bus;
  c.node_id = node;
  c.axis.min_mm = -200;
  c.axis.max_mm = 200;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 10000;
  c.canopen.heartbeat = std::chrono::milliseconds(50);
}

}  // namespace drivegw::stober
