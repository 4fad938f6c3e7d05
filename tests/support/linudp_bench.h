// The LinMot LinUDP bench many tests share: a simulated drive on loopback (sim/linmot) and the
// drive configuration that talks to it. Tests change only what they are about (a time-out, the
// loss tolerance) on the returned values, so each one states its own deviation.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <thread>

#include "adapters/core/drive_config.h"
#include "adapters/transport/endpoint.h"
#include "sim/linmot/options.h"

namespace drivegw::test_support {

// The simulator answering on an ephemeral loopback port, replying to the gateway's ephemeral
// master port, with a short power-up hardware test so activation is quick.
inline sim::linmot::SimOptions LinUdpSimOptions() {
  sim::linmot::SimOptions o;
  o.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
  o.master_port = 0;  // answer the gateway's ephemeral port
  o.hw_test_time = std::chrono::milliseconds(50);
  return o;
}

// Drive "x1" on the simulator at `sim_port`: a 0..150 mm axis (1000 mm/s, 20000 mm/s²), a 2 ms
// cycle, 30 ms reply time-out, OFFLINE after 3 consecutive time-outs.
inline DriveConfig LinUdpDriveConfig(uint16_t sim_port) {
  DriveConfig c;
  c.name = "x1";
  c.family = "linmot";
  c.axis.min_mm = 0;
  c.axis.max_mm = 150;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 20000;
  LinUdpConfig l;
  l.host = "127.0.0.1";
  l.port = sim_port;
  l.bind_host = "127.0.0.1";
  l.master_port = 0;
  l.cycle = std::chrono::milliseconds(2);
  l.reply_timeout = std::chrono::milliseconds(30);
  l.lost_after_timeouts = 3;
  c.linudp = l;
  return c;
}

// Polls `pred` every 2 ms until it holds (true) or `wait` has passed (false): for conditions on
// the simulator's own record, which publishes no status to wait on.
inline bool WaitFor(const std::function<bool()>& pred, std::chrono::steady_clock::duration wait) {
  const auto deadline = std::chrono::steady_clock::now() + wait;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

}  // namespace drivegw::test_support
