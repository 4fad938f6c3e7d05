// Configuration of one simulated LinMot DeviceNet drive (firmware 1.3): DeviceNet branch,
// controller and motors, curves, identity, decision switches and simulated time
// (linmot-devicenet.md §12.1).
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "adapters/linmot/devicenet/commands.h"

namespace drivegw::sim::linmot_devicenet {

// The wire-level DeviceNet namespace as seen from the simulator.
namespace dn = ::drivegw::linmot::devicenet;

// §6.1 dn.macid.source (seed lines 189-202).
enum class MacIdSource : uint8_t { kSwitches, kParameter };
// §3.2 dn.baud; informational on the user-space bus (every node shares one "bit rate").
enum class BaudRate : uint16_t { k125 = 125, k250 = 250, k500 = 500 };
// §6.1 "Additional configuration": a motor's Run Mode (seed line 105).
enum class RunMode : uint8_t { kSerial, kMasterEncoder, kContinuousCurve, kOther };
enum class MotorType : uint8_t { kLinMot, kStepper, kSolenoid };
// Controller series: current ranges of 0x30-0x33 (seed line 1618).
enum class ControllerSeries : uint8_t { k100, k1000 };
enum class EncoderMode : uint8_t { kAbz, kSsi };
// D-15: what the drive does when its I/O connection times out or is lost.
enum class IoLossReaction : uint8_t {
  kReleaseRun,  // default: control word treated as 0x0000 (RUN request released)
  kKeep,        // keep the last control word (the drive runs on)
};
// D-16: how the drive leaves bus-off.
enum class BusOffRecovery : uint8_t {
  kHold,         // default (BOI = 0): stays off until RecoverBusOff() or a power cycle
  kAutoRecover,  // after DnSimOptions::bus_off_recover_after (also when BOI is set to 1)
};

const char* RunModeName(RunMode m);      // "serial", "master-encoder", ...
const char* MotorTypeName(MotorType t);  // "linmot", "stepper", "solenoid"

// One motor (axis) A..D. Positions in mm; 1 position increment = 1/51.2 mm (§0.5).
struct MotorOptions {
  bool master = true;  // master drive: gets Direct slots, accepts motor commands (0x8111 else)
  RunMode run_mode = RunMode::kSerial;
  MotorType type = MotorType::kLinMot;
  double stroke_min_mm = -10;  // mechanical stroke (sim/motion Axis)
  double stroke_max_mm = 200;
  double initial_position_mm = 0;   // slider position at power-up
  double max_velocity_mm_s = 2000;  // motor capability; the filter limit 0x50 is the command one
  double init_position_mm = 0;      // where the INIT (homing) move ends (reported frame)
  double init_velocity_mm_s = 100;  // INIT search speed
  double init_acceleration_mm_s2 = 1000;
  uint8_t direct_out_1 = 0;  // §6.2 code, D-30: Actual Pos
  uint8_t direct_out_2 = 1;  // D-30: Demand Pos
};

// A motion curve 0..63 (§12.1 curve table). Values in position increments (§0.5); the curve is
// run as a VA move from its start to its end point (decision 953).
struct CurveOptions {
  uint8_t number = 0;
  int16_t start = 0;  // start point; must be 0 for the incremental starts 0x22/0x23 (0x8131)
  int16_t end = 0;
  double velocity_mm_s = 500;  // at Curve Speed 100 %
  double acceleration_mm_s2 = 5000;
};

// Identity object values (§5.11, D-12): project placeholders until real values are known.
struct IdentityOptions {
  uint16_t vendor_id = 0x0000;
  uint16_t device_type = 0x0000;  // "generic" (seed line 111)
  uint16_t product_code = 0x0001;
  uint8_t revision_major = 1;
  uint8_t revision_minor = 3;
  uint32_t serial_number = 0x4C4D0000;  // + MAC ID at start, so --count drives differ
  std::string product_name = "LinMot DN sim";
};

struct DnSimOptions {
  std::string name = "linmot-dn";

  // ---- the bus (issue 3: --can udp:GROUP:PORT | socketcan:IFACE) ----
  CanBusConfig can;

  // ---- DeviceNet branch, §6.1 (D-30 test profile where the seed gives no default) ----
  bool dn_enable = true;                             // dn.enable; false: never transmits (§10.2)
  BaudRate baud = BaudRate::k125;                    // dn.baud
  MacIdSource mac_source = MacIdSource::kParameter;  // dn.macid.source
  uint8_t mac_id = 5;                                // dn.macid.value, 0..63
  uint8_t mac_switches = 0x05;                       // two hex rotary switches, high nibble first
  bool io_polled = true;                             // dn.io.setup
  bool io_cos = false;
  dn::ModuleSet poll_modules = dn::DefaultLayoutP().modules;                  // D-3 candidate P
  dn::ModuleSet cos_modules{false, false, false, true, false, false, false};  // Status Out
  dn::ByteOrder byte_order = dn::ByteOrder::kLittleEndian;                    // D-1

  // ---- controller (§6.1 "Additional configuration") ----
  size_t motor_count = 1;  // 1..4; motors A.. in order
  std::array<MotorOptions, 4> motors{};
  ControllerSeries series = ControllerSeries::k1000;
  bool master_encoder_module = false;            // 0x60-0x6B (0x8120 without)
  EncoderMode encoder_mode = EncoderMode::kAbz;  // SSI: 0x8121 for 0x61/0x67
  bool digital_io_module = false;                // 0x64/0x65 also with this module
  uint16_t sw_assigned_outputs = 0x1C00;  // 0x0D: Warn/Error/Pos error out follow their function
  std::vector<CurveOptions> curves = DefaultCurves();
  bool initialised = false;  // motors already initialised at power-up (INIT Done = 1, §13.1 F1)

  IdentityOptions identity;

  // ---- decision switches (§14; every default is the reference's proposal) ----
  bool x_commands_edge_triggered = false;      // D-4 alternative: Set/Action only on a word change
  int response_latency_cycles = 0;             // D-5: Addressed Out lags by n consumed messages
  bool coded_errors_decimal = false;           // D-2 alternative: 0x0A reports 8108 as decimal 8108
  bool undocumented_commands_error = false;    // D-19 alternative: 0x68/0x6D/0x74-0x77 -> 0x8108
  bool identity_readable = true;               // D-12
  bool connection_attributes_readable = true;  // D-13
  bool ownership_ends_with_explicit = false;   // D-13 alternative
  uint16_t epr_resolution_ms = 10;             // D-13: granted EPR rounded up to this
  bool ucmm = true;                            // D-11: accept UCMM Open as well
  IoLossReaction io_loss_reaction = IoLossReaction::kReleaseRun;  // D-15
  bool run_requires_io_connection = true;                   // D-15 / §12.5 (dn.enable = Enable)
  BusOffRecovery bus_off_recovery = BusOffRecovery::kHold;  // D-16
  Duration bus_off_recover_after = std::chrono::seconds(1);
  Duration duplicate_check_wait = std::chrono::seconds(1);  // §5.7: per request [SPEC-M]
  Duration response_delay{0};  // D-33: poll responses leave this long after the poll

  // ---- simulated time and mechanics ----
  Duration tick = std::chrono::milliseconds(1);  // fixed physics step, 0.25 ... 10 ms
  double lag_time_constant_s = 0;  // actual follows demand (sim/motion D-10): 0 = one tick
  double moving_mass_kg = 0.5;     // Direct Out "Current" = m * a / force constant
  double force_constant_n_per_a = 20;

  static std::vector<CurveOptions> DefaultCurves();
};

// InvalidArgument naming the first bad field: "dn_sim_options.mac_id: 64 exceeds 63",
// "dn_sim_options.mac_switches: 0x6A exceeds 0x3F (D-26)".
absl::Status ValidateOptions(const DnSimOptions& options);

// The MAC ID the drive uses: the parameter or the hexadecimal switches (§3.1, seed line 3301).
uint8_t ResolvedMacId(const DnSimOptions& options);
// Image layouts of the polled and CoS connections (§7.7): modules, master drives, byte order.
dn::IoLayout PollLayout(const DnSimOptions& options);
dn::IoLayout CosLayout(const DnSimOptions& options);
// Bit 0 = A .. bit 3 = D for the configured master drives.
uint8_t MasterDriveMask(const DnSimOptions& options);

// §0.5: 1 position increment = 19.53125 µm.
inline constexpr double kMmPerIncrement = 1.0 / 51.2;
// §0.5 filter units: speed 190.735 µm/s, acceleration 238.419 mm/s².
inline constexpr double kMmSPerSpeedIncrement = 0.190735;
inline constexpr double kMmS2PerAccIncrement = 238.419;
// §0.5 current unit 23.438 mA.
inline constexpr double kAmpPerCurrentIncrement = 0.023438;

}  // namespace drivegw::sim::linmot_devicenet
