// Read-only pictures of a simulated LinMot DeviceNet drive for tests, the demo and the CLI
// (linmot-devicenet.md §12.7): application state, DeviceNet connections, counters, frames.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/codec.h"
#include "sim/linmot_devicenet/options.h"

namespace drivegw::sim::linmot_devicenet {

// D-10 minimal main state model; status low bits 1-4 (§7.4).
enum class ControllerState : uint8_t {
  kDisable,  // power-up, not initialised (DISABLE State)
  kInit,     // INIT request: motors initialising (INIT State)
  kStopped,  // initialised, not running (no state bit besides INIT Done)
  kRun,      // RUN State
  kError,    // ERROR State: an error or coded error is pending
};
const char* ControllerStateName(ControllerState s);  // "DISABLE", "INIT", "STOPPED", ...

struct MotorSnapshot {
  bool present = false;
  bool master = false;
  RunMode run_mode = RunMode::kSerial;
  double actual_mm = 0;  // reported frame, including an injected disturbance
  double demand_mm = 0;
  double demand_velocity_mm_s = 0;
  int32_t setpoint = 0;         // position set-point, increments (0x10)
  int32_t actual_position = 0;  // increments (0x18)
  int32_t demand_position = 0;
  bool motion_active = false;
  bool in_position = false;       // status low bit 12 + k
  bool curve_done = false;        // status low bit 8 + k (toggles at each curve end)
  bool command_toggle = false;    // status high bit 4k + 3
  bool following_error = false;   // status high bit 4k
  bool position_range = false;    // status high bit 4k + 1
  bool over_temperature = false;  // status high bit 4k + 2
  bool frozen = false;
  std::optional<uint8_t> running_curve;
  std::optional<uint8_t> armed_command;  // trigger-armed 0x12/0x14/0x21/0x23
  uint8_t direct_out_1 = 0;              // §6.2 codes
  uint8_t direct_out_2 = 0;
  uint64_t curves_completed = 0;
};

struct DeviceSnapshot {
  Duration sim_time{0};  // ticks x tick since power-up
  ControllerState state = ControllerState::kDisable;
  uint16_t control_word = 0;  // effective (after D-15)
  uint16_t status_low = 0;
  uint16_t status_high = 0;
  uint16_t system_warn = 0;   // 0x06 without motor
  uint16_t system_error = 0;  // 0x08 without motor
  uint16_t coded_error = 0;   // latched coded error, hexadecimal reading (D-2)
  uint16_t controller_io = 0;
  uint16_t extended_io = 0;
  bool init_done = false;
  bool io_connected = false;
  size_t motor_count = 0;
  std::array<MotorSnapshot, 4> motors{};
  uint64_t messages_consumed = 0;
  uint64_t commands_executed = 0;
  // Executed commands per §8.4 command ID: what a master made the drive do, read by the
  // recovery tests to prove no motion command or set point was re-sent (decision 1451).
  std::array<uint64_t, 256> executed_by_id{};
  uint64_t coded_errors_raised = 0;
  uint64_t toggle_commands_ignored = 0;  // T equal to the Command Toggle (D-4)
  uint64_t direct_gets_ignored = 0;      // D-20
  uint64_t controller_resets = 0;        // 0x0F and identity Reset
};

// §12.2 network start-up states.
enum class NetworkState : uint8_t {
  kDisabled,              // dn.enable = Disable: never transmits
  kDuplicateCheck,        // §5.7: two requests 1 s apart
  kOnline,                // answers allocation, explicit and I/O
  kCommunicationFaulted,  // duplicate MAC detected (0x8101); stays until power cycle
  kBusOff,                // §5.10: transmits nothing (0x8148)
};
const char* NetworkStateName(NetworkState s);  // "disabled", "duplicate-check", ...

// Connection object state, attribute 1 (§5.6).
enum class ConnectionState : uint8_t {
  kNonExistent = 0,
  kConfiguring = 1,
  kWaitingForId = 2,
  kEstablished = 3,
  kTimedOut = 4,
  kDeferredDelete = 5,
};
const char* ConnectionStateName(ConnectionState s);

struct ConnectionSnapshot {
  uint8_t instance = 0;  // 1 explicit, 2 poll, 4 CoS/cyclic
  ConnectionState state = ConnectionState::kNonExistent;
  uint16_t expected_packet_rate_ms = 0;
  uint8_t watchdog_timeout_action = 0;
  uint16_t production_inhibit_ms = 0;
  uint16_t produced_size = 0;
  uint16_t consumed_size = 0;
  uint64_t messages_received = 0;
  uint64_t messages_sent = 0;
  uint64_t watchdog_timeouts = 0;
};

struct StackCounters {
  uint64_t frames_received = 0;
  uint64_t frames_sent = 0;
  uint64_t not_for_us = 0;  // other nodes' traffic
  uint64_t malformed = 0;   // undecodable frames / explicit bodies: counted, dropped
  uint64_t ignored_offline = 0;
  uint64_t explicit_requests = 0;
  uint64_t error_responses = 0;
  uint64_t allocations = 0;
  uint64_t releases = 0;
  uint64_t second_master_rejected = 0;  // Allocate from another master (§5.5, line 142)
  uint64_t second_master_dropped = 0;   // explicit requests from a non-owner: dropped
  uint64_t no_connection_dropped = 0;   // I/O or explicit frames without an established conn
  uint64_t polls_received = 0;          // complete poll commands of the right size
  uint64_t poll_responses_sent = 0;
  uint64_t polls_wrong_size = 0;  // D-24
  uint64_t fragment_errors = 0;   // out of order / missing fragments: message discarded
  uint64_t polls_dropped_injected = 0;
  uint64_t cos_sent = 0;
  uint64_t cos_acks_received = 0;
  uint64_t cos_consumed = 0;
  uint64_t watchdog_timeouts = 0;
  uint64_t duplicate_mac_requests_sent = 0;
  uint64_t duplicate_mac_responses_sent = 0;
  uint64_t duplicate_mac_detected = 0;
  uint64_t network_restarts = 0;
  uint64_t bus_off_events = 0;
};

struct StackSnapshot {
  NetworkState network = NetworkState::kDisabled;
  uint8_t mac_id = 0;
  std::optional<uint8_t> owner;   // master MAC owning the predefined set
  uint8_t allocation_choice = 0;  // §5.5 bits currently allocated
  ConnectionSnapshot explicit_connection;
  ConnectionSnapshot poll_connection;
  ConnectionSnapshot cos_connection;
  // LinTalk's computed "Poll PrdCnSize/CsdCnSize" and "CoS PrdCnSize/CsdCnSize" (bytes, D-25),
  // fixed at start-up from the module selection (§7.7, seed lines 228-229, 275-276).
  uint16_t poll_produced_size = 0;
  uint16_t poll_consumed_size = 0;
  uint16_t cos_produced_size = 0;
  uint16_t cos_consumed_size = 0;
  bool boi = false;           // DeviceNet object attribute 3
  uint8_t bus_off_count = 0;  // attribute 4 (saturating)
  StackCounters counters;
};

// What the CAN side of the server saw.
struct ServerCounters {
  uint64_t frames_received = 0;
  uint64_t frames_sent = 0;
  uint64_t send_errors = 0;
  uint64_t receive_errors = 0;
  uint64_t malformed = 0;  // not a DeviceNet data frame (extended, RTR, error, > 8 bytes)
  uint64_t responses_delayed = 0;
};

struct DnSimSnapshot {
  DeviceSnapshot device;
  StackSnapshot stack;
  ServerCounters server;
};

// One frame in or out, on the injected clock (§12.7).
struct FrameRecord {
  TimePoint time{};
  bool transmitted = false;  // false: received
  dn::Frame frame;
};

}  // namespace drivegw::sim::linmot_devicenet
