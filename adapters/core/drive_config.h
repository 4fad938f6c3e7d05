// Configuration of one drive as the composition root hands it to a family factory. Parsed and
// validated by server/config; families read only their own section.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "adapters/core/health.h"

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
  uint16_t port = 49360;              // drive port
  uint16_t master_port = 41136;       // local port the gateway binds
  std::string bind_host = "0.0.0.0";  // local address of the master socket
  std::chrono::milliseconds cycle{5};
  std::chrono::milliseconds reply_timeout{50};
  int lost_after_timeouts = 5;
  // Scheduling of the I/O thread of this drive's master socket, shared by every drive with the
  // same bind_host:master_port (docs/config.md; decision 1311): 0 = the process' own policy,
  // 1..99 = SCHED_FIFO at that priority (needs CAP_SYS_NICE); empty io_cpus = any CPU.
  int io_priority = 0;
  std::vector<int> io_cpus;
};

// One classic CAN bus (docs/config.md "can"; docs/decisions/801-can-channel.md). Opened by
// transport::OpenCanChannel.
struct CanBusConfig {
  enum class Kind { kSocketCan, kUdpMulticast };
  Kind kind = Kind::kUdpMulticast;     // the bus that works without kernel CAN
  std::string interface = "can0";      // kSocketCan: network interface name
  std::string group = "239.74.163.2";  // kUdpMulticast: IPv4 multicast group (python-can default)
  uint16_t port = 43113;               // kUdpMulticast: UDP port (python-can default)
  // kUdpMulticast: bit rate each node paces its own frames at (bit/s: 125000, 250000, 500000,
  // 1000000); 0 = unpaced (docs/decisions/805-udp-bus-bit-timing.md).
  uint32_t bitrate = 0;
  std::string trace_file;  // candump -l log of every frame in and out; empty: off
};

// RS-232 / RS-485 line of a serial family (trinamic-sixpack.md §2.1; opened as
// transport::SerialConfig, raw 8N1).
struct SerialLineConfig {
  std::string device;  // /dev/ttyUSB0, or a pty symlink (drivegw-sim trinamic --pty PATH)
  int baud = 19200;    // the PACK's default (L273)
  bool rs485 = false;  // half duplex: wait `turnaround` around every reply (§2.5)
  std::chrono::microseconds turnaround{6000};  // the controller's switchover delay ($40, L833)
};

// One axis of a Trinamic SIXpack/QUADpack controller (trinamic-sixpack.md; docs/config.md
// "trinamic"). Axes with the same transport and address share one serialised session.
struct TrinamicConfig {
  std::optional<SerialLineConfig> serial;  // exactly one of serial / can
  std::optional<CanBusConfig> can;
  uint8_t address = 1;              // controller unit address 1..255 (rotary switches, G-05)
  uint8_t axis = 0;                 // motor number: 0..5 SIXpack, 0..3 QUADpack (G-17)
  int axes = 6;                     // 6 = SIXpack, 4 = QUADpack
  double microsteps_per_unit = 0;   // microsteps per mm (per degree on a rotary axis); > 0
  uint8_t response_address = 0xF0;  // RA of every query (§2.4, decision 1052)
  std::chrono::milliseconds poll_period{20};     // position/activity polling of this axis
  std::chrono::milliseconds reply_timeout{100};  // one query
  int offline_after_misses = 3;                  // consecutive misses -> OFFLINE (decision 1054)
  // Probe back-off of an OFFLINE controller, doubling (decision 1431: drives[i].health.backoff_*,
  // folded in by the factory; axes on one controller must agree).
  std::chrono::milliseconds retry_min{100};
  std::chrono::milliseconds retry_max{5000};
  // health.up_after_ms folded in by the factory like retry_* (decision 1432).
  std::chrono::milliseconds up_after{kDefaultUpAfter};
  // Values written at activation and re-sent after every detected controller reset (G-24):
  // "$14.vmax" -> 300 (opcode and field names of the instruction table, codec.cpp).
  std::vector<std::pair<std::string, int64_t>> parameters;
};

// CANopen node timing (CiA 301) of a CANopen family (STOBER; docs/config.md "canopen").
struct CanOpenConfig {
  std::chrono::milliseconds heartbeat{100};          // producer time written to the drive's 1017h
  std::chrono::milliseconds heartbeat_timeout{350};  // consumer: missing longer -> OFFLINE
  std::chrono::milliseconds sync_period{2};          // SYNC producer period (cyclic set points)
  std::chrono::milliseconds sdo_timeout{1000};       // per SDO frame exchange (decision 1103)
  // Repeats of an idempotent SDO transfer (uploads, configuration writes) that got no response
  // within sdo_timeout, and of an NMT start without an OPERATIONAL heartbeat (decision 1481).
  int sdo_retries = 3;
  // RPDO transmission type (CiA 301 1400h sub 2): 255 event-driven (applied on reception),
  // 0..240 synchronous (applied at the next SYNC; the SYNC producer then runs; decision 1119).
  uint8_t rpdo_transmission_type = 255;
  // The gateway's own CANopen node ID on this bus (decision 1483): it produces its heartbeat
  // (700h + id) every `heartbeat`, and each drive consumes it in 1016h:01 with the consumer time
  // `heartbeat_timeout`, reacting per 6007h (quick stop) when the gateway dies. 0: no master
  // heartbeat and no drive-side watchdog (1016h:01 is cleared).
  uint8_t master_node_id = 127;
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
  std::optional<TrinamicConfig> trinamic;
  std::optional<uint8_t> node_id;  // CANopen node ID 1..127 (family stober)
  CanOpenConfig canopen;           // CANopen timing (family stober)
  // drives[i].health (decision 1431): consecutive failures to DOWN and the probe back-off of a
  // DOWN drive; absent keys keep the family's own default.
  HealthOverrides health;
};

}  // namespace drivegw
