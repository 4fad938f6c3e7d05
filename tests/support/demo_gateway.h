// Test support: options for a real Gateway running its embedded demo on ports of its own — HTTP
// and gRPC on ephemeral ports, ephemeral simulator ports and two random user-space CAN buses —
// so gateway tests run in parallel under ctest. One copy for the e2e, ops, auth and web tests.
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "server/gateway.h"

namespace drivegw::test_support {

inline server::GatewayOptions DemoGatewayOptions(const std::string& data_dir) {
  std::random_device rd;
  const auto can_port = static_cast<uint16_t>(20000 + rd() % 20000);
  server::GatewayOptions o;
  o.config.listen.grpc = "127.0.0.1:0";
  o.config.listen.http = "127.0.0.1:0";
  o.config.data_dir = data_dir;
  o.config.demo = true;
  o.demo_first_port = 0;       // ephemeral simulator ports
  o.demo_master_port = 0;      // ephemeral master port; the simulators answer any source port
  o.demo_can_port = can_port;  // buses of this test's own (parallel ctest)
  o.demo_canopen_port = static_cast<uint16_t>(can_port + 1);
  return o;
}

}  // namespace drivegw::test_support
