// Configuration of one drive as the composition root hands it to a family factory. Parsed and
// validated by server/config; families read only their own section.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace drivegw {

enum class AxisKind { kLinear, kRotary };

struct AxisConfig {
  AxisKind kind = AxisKind::kLinear;
  double min_mm = 0;
  double max_mm = 100;
  double max_velocity_mm_s = 1000;
  double max_acceleration_mm_s2 = 10000;
};

// LinUDP transport (linmot-linudp.md §1, A-01, A-10).
struct LinUdpConfig {
  std::string host = "127.0.0.1";
  uint16_t port = 49360;         // drive port
  uint16_t master_port = 41136;  // local port the gateway binds
  std::string bind_host = "0.0.0.0";  // local address of the master socket
  std::chrono::milliseconds cycle{5};
  std::chrono::milliseconds reply_timeout{50};
  int lost_after_timeouts = 5;
};

// One classic CAN bus (docs/config.md "can"; docs/decisions/801-can-channel.md). Opened by
// transport::OpenCanChannel.
struct CanBusConfig {
  enum class Kind { kSocketCan, kUdpMulticast };
  Kind kind = Kind::kUdpMulticast;     // the bus that works without kernel CAN
  std::string interface = "can0";      // kSocketCan: network interface name
  std::string group = "239.74.163.2";  // kUdpMulticast: IPv4 multicast group (python-can default)
  uint16_t port = 43113;               // kUdpMulticast: UDP port (python-can default)
  std::string trace_file;              // candump -l log of every frame in and out; empty: off
};

struct TimeoutConfig {
  std::chrono::milliseconds request{2000};  // Enable/Disable/Acknowledge/parameter access
  std::chrono::milliseconds accept{100};    // motion command acceptance (count echo), D-11
  std::chrono::milliseconds homing{30000};
};

struct DriveConfig {
  std::string name;    // "x1"
  std::string family;  // "linmot"
  AxisConfig axis;
  TimeoutConfig timeouts;
  std::optional<LinUdpConfig> linudp;
  std::optional<CanBusConfig> can;  // CAN families (linmot-devicenet, later trinamic, canopen)
  std::optional<uint8_t> mac_id;    // DeviceNet MAC ID 0..63
};

}  // namespace drivegw
