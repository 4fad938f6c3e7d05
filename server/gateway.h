// The composition root: configuration -> storage, drives (and the embedded demo simulators),
// the service core, gRPC and REST servers. main.cpp and the end-to-end tests both use it.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "server/config/config.h"
#include "server/core/drive_service.h"

namespace drivegw::sim::linmot {
class LinMotServer;
}
namespace drivegw::sim::linmot_devicenet {
class LinMotDnServer;
}
namespace drivegw::sim::trinamic {
class TrinamicServer;
}
namespace drivegw::sim::stober {
class AxisServer;
}

namespace drivegw::server {

// The gRPC message limit, received and sent, on the network port and on the REST front end's
// in-process channel (decision 1492; gRPC's implicit default is 4 MiB received, unlimited sent).
// Sized for the largest legitimate request, a curve set of 100 LinMot curves (one per curve ID,
// linmot-mc.md §7 L997) of 16383 points (linmot-linudp.md L310) at up to 10 bytes per point
// (a negative int32 varint): 16,383,000 bytes, plus names and descriptions. A larger message is
// refused RESOURCE_EXHAUSTED "Received message larger than max (… vs. 16777216)".
inline constexpr int kGrpcMaxMessageBytes = 16 << 20;

struct GatewayOptions {
  config::GatewayConfig config;
  // Demo mode: the first simulated drive's UDP port (consecutive ports for the others) and
  // the master port both sides use. 0 = ephemeral ports, for tests running in parallel.
  uint16_t demo_first_port = 49360;
  uint16_t demo_master_port = 41136;
  // Demo mode: the user-space CAN bus (UDP multicast, python-can compatible) the simulated
  // DeviceNet drive and the gateway share. Tests pass a port of their own so runs in parallel
  // never share a bus.
  std::string demo_can_group = "239.74.163.2";
  uint16_t demo_can_port = 43113;
  // Demo mode: the user-space CAN bus (same group) of the simulated STOBER axis, a bus of its
  // own because CANopen and DeviceNet never share one (decisions 407, 409). 0 = demo_can_port + 1,
  // so a test that picks its own DeviceNet bus also gets its own CANopen bus.
  uint16_t demo_canopen_port = 0;
  std::string static_dir;  // web assets served at / (empty: none)
  // REST serves ListDrives, GetDrive and GetCommand directly from the core (decision 1331);
  // false: through the in-process gRPC call like every other method (benchmarks and tests
  // compare the two).
  bool rest_direct_reads = true;
};

class Gateway {
 public:
  static absl::StatusOr<std::unique_ptr<Gateway>> Start(GatewayOptions options,
                                                        const Clock& clock = SteadyClock::Instance());
  ~Gateway();
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  uint16_t grpc_port() const;
  uint16_t http_port() const;
  DriveServiceCore& core();
  // The embedded simulator behind a demo drive (nullptr outside demo mode), for fault
  // injection in tests and demos.
  sim::linmot::LinMotServer* demo_simulator(const std::string& drive) const;
  sim::linmot_devicenet::LinMotDnServer* demo_devicenet_simulator(const std::string& drive) const;
  // The simulated SIXpack (address 1) behind the demo drives feeder-x and feeder-y, on a pty
  // linked at `<data_dir>/trinamic-demo.pty` (decision 406); nullptr outside demo mode.
  sim::trinamic::TrinamicServer* demo_trinamic_simulator() const;
  // The simulated STOBER axis (CANopen node 3) behind the demo drive s1 on the demo CANopen bus
  // (decision 409); nullptr outside demo mode.
  sim::stober::AxisServer* demo_stober_simulator() const;

  // Stops servers, drives and simulators; idempotent. The destructor calls it.
  void Stop();
  // Graceful shutdown (SIGTERM; decision 022): /readyz and gRPC health turn NOT_SERVING, no new
  // calls are accepted, moving drives get a controlled StopMotion (the axis's acceleration limit
  // as deceleration) and are waited for, then Stop() and the audit log's WAL is checkpointed.
  // Takes about `bound` at most unless a drive call blocks beyond its own time-outs. True when
  // every moving drive stood in time.
  bool Shutdown(std::chrono::milliseconds bound);

  struct Impl;

 private:
  // Readiness and gRPC health to NOT_SERVING; idempotent.
  void BeginShutdown();
  explicit Gateway(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Splits "host:port" (port 0 allowed); errors name `field`.
absl::StatusOr<std::pair<std::string, uint16_t>> SplitHostPort(const std::string& field, const std::string& value);

}  // namespace drivegw::server
