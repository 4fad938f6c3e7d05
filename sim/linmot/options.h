// Configuration of one simulated LinMot drive: network side (LinUDP) and physics side (MC SW).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/transport/endpoint.h"

namespace drivegw::sim::linmot {

// The wire-level LinMot namespaces, as seen from inside the simulator's own namespace.
namespace mc = ::drivegw::linmot::mc;
namespace linudp = ::drivegw::linmot::linudp;

// linmot-linudp.md fact 1.9 / A-15: which senders the drive answers.
enum class MasterFilter {
  kNoFilter,           // default: answer any sender (subject to the A-01 port rule)
  kSingleMaster,       // latch the IP of the first accepted telegram, ignore every other IP
  kSingleMasterFixIp,  // answer only `master_ip`
};

struct SimOptions {
  // ---- identity and network (LinUDP, linmot-linudp.md §1, A-01) ----
  std::string name = "linmot";
  // Where the drive listens; port 0 = ephemeral (read back with LinMotServer::port()).
  transport::Endpoint bind{transport::Endpoint::kLoopback, linudp::kDrivePort};
  // datagrams from another source port are dropped (counted); replies go to
  // <source ip>:<master_port>. 0 = answer any source port, replying to the source port (tests).
  uint16_t master_port = linudp::kMasterPort;
  MasterFilter master_filter = MasterFilter::kNoFilter;
  uint32_t master_ip = 0;  // host byte order; kSingleMasterFixIp only
  // replies are zero-filled to this UDP payload size (14 observed; 64 = the manual).
  size_t min_reply_payload = linudp::kMinReplyPayload;

  // ---- simulated time (D-23) ----
  Duration tick = std::chrono::milliseconds(1);  // fixed physics step, 0.25 ms ... 10 ms

  // ---- product (D-20: command availability per §5 columns) ----
  mc::Product product = mc::Product::kC1250;
  bool force_control_key = false;

  // ---- mechanics (sim/motion Axis, physical frame = reported frame at power-up) ----
  double stroke_min_mm = 0;           // mechanical end stops; also the default of 146Eh
  double stroke_max_mm = 150;         // ... and of 146Fh
  double max_velocity_mm_s = 4000;    // motor capability: commands faster than this raise 000Bh
  double initial_position_mm = 10;    // slider position at power-up
  double home_position_mm = 0;        // D-39: where homing moves to (becomes 13C7h, reported frame)
  double homing_velocity_mm_s = 100;  // D-39 simulator parameters (UPIDs F001h/F002h)
  double homing_acceleration_mm_s2 = 1000;  //
  double lag_time_constant_s = 0;           // D-10: 0 = actual is demand delayed by one tick
  double in_target_window_mm = 0.01;        // D-10 default 100 x 0.1 um (UPID F000h)
  bool requires_homing = true;              // D-41: incremental sensor, Homed = 0 after power-up
  double moving_mass_kg = 0.5;  // demand current = m * a / force constant (§6.8 option)
  double force_constant_n_per_a = 20;

  // ---- timing of drive procedures ----
  Duration hw_test_time = std::chrono::milliseconds(300);  // state 5 (MC22 L546)
  Duration boot_time =
      std::chrono::seconds(2);  // A-11 restart 0x30 and Reset 00F0h: no answers meanwhile
  Duration flash_save_time =
      std::chrono::seconds(1);  // 0x80 reports 0x02 this long while MC is stopped
  // A-09 test option: every RTC command first reports 0x02 (busy) for this many telegrams.
  int rtc_busy_telegrams = 0;
};

// InvalidArgument naming the first bad field ("sim_options.tick: 0 ms is outside [0.25, 10] ms").
absl::Status ValidateOptions(const SimOptions& options);

}  // namespace drivegw::sim::linmot
