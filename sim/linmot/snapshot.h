// Read-only pictures of a simulated LinMot drive for tests, the demo dashboard and the CLI.
#pragma once

#include <cstdint>

#include "adapters/core/clock.h"

namespace drivegw::sim::linmot {

// The drive as a master would see it, plus simulator-only values (positions in both units).
struct DeviceSnapshot {
  Duration sim_time{0};  // simulated time since the process created the drive (ticks x tick)
  uint8_t main_state = 0;
  uint8_t sub_state = 0;
  uint16_t state_var = 0;
  uint16_t status_word = 0;
  uint16_t warn_word = 0;
  uint16_t control_word = 0;    // effective (last received) control word
  uint16_t error_code = 0;      // pending error (states 3, 4, 14), else 0
  int32_t actual_position = 0;  // 0.1 um
  int32_t demand_position = 0;  // 0.1 um
  double actual_position_mm = 0;
  double demand_position_mm = 0;
  double demand_velocity_mm_s = 0;
  int16_t current_ma = 0;
  bool homed = false;
  bool motion_active = false;
  bool in_target = false;
  bool booting = false;     // A-11/Reset: not answering
  bool mc_stopped = false;  // RTC 0x35 stopped the MC SW
  uint8_t mc_count = 0;     // remembered (last interpreted) motion command count
  uint8_t rtc_count = 0;    // RTC count reference
  uint64_t mc_commands_executed = 0;
  uint64_t mc_commands_rejected = 0;  // wrong state, unknown ID
  uint64_t rtc_commands = 0;
  uint64_t boots = 0;  // simulated reboots (restart 0x30, Reset 00F0h)
  uint32_t errors_occurred = 0;
};

// What the UDP side of a LinMotServer saw (linmot-linudp.md ).
struct ServerCounters {
  uint64_t datagrams_received = 0;
  uint64_t replies_sent = 0;
  uint64_t dropped_wrong_port = 0;     // source port != master port
  uint64_t dropped_filtered = 0;       // master filter
  uint64_t malformed = 0;              // too short for the flagged blocks
  uint64_t dropped_not_answering = 0;  // StopAnswering / booting
  uint64_t replies_dropped = 0;        // impairment
  uint64_t replies_duplicated = 0;     // impairment
  uint64_t replies_delayed = 0;        // impairment or SetReplyDelay
  uint64_t replies_reordered = 0;      // impairment: held back, sent after the next reply
  uint64_t replies_corrupted = 0;      // impairment: sent truncated (decision 1421)
  uint64_t requests_dropped = 0;       // request impairment
  uint64_t requests_duplicated = 0;    // request impairment: handled twice
  uint64_t requests_reordered = 0;     // request impairment: handled after the next one
  uint64_t requests_corrupted = 0;     // request impairment: handled truncated
  uint64_t send_errors = 0;
};

struct SimSnapshot {
  DeviceSnapshot device;
  ServerCounters server;
};

}  // namespace drivegw::sim::linmot
