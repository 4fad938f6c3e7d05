// DnSimOptions: defaults, validation naming the field, MAC ID resolution and image layouts
// (linmot-devicenet.md §6.1, §7.7, §12.1).
#include "sim/linmot_devicenet/options.h"

#include <cmath>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

absl::Status Bad(const std::string& field, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("dn_sim_options.", field, ": ", what));
}

bool Finite(double v) { return std::isfinite(v); }

}  // namespace

const char* RunModeName(RunMode m) {
  switch (m) {
    case RunMode::kSerial:
      return "serial";
    case RunMode::kMasterEncoder:
      return "master-encoder";
    case RunMode::kContinuousCurve:
      return "continuous-curve";
    case RunMode::kOther:
      return "other";
  }
  return "unknown";
}

const char* MotorTypeName(MotorType t) {
  switch (t) {
    case MotorType::kLinMot:
      return "linmot";
    case MotorType::kStepper:
      return "stepper";
    case MotorType::kSolenoid:
      return "solenoid";
  }
  return "unknown";
}

std::vector<CurveOptions> DnSimOptions::DefaultCurves() {
  // Test profile (§13.4 uses curves 3 and 4; curve 10 stays undefined for TC-29): curve 0 and 1
  // are the rise/fall pair 0 <-> 50 mm, 3 an absolute move to 50 mm, 4 an incremental +10 mm.
  return {
      CurveOptions{0, 0, 2560, 500, 5000},   CurveOptions{1, 2560, 0, 500, 5000},
      CurveOptions{3, 0, 2560, 500, 5000},   CurveOptions{4, 0, 512, 200, 2000},
      CurveOptions{5, 512, 1024, 200, 2000},  // start point != 0: 0x8131 when incremental
  };
}

absl::Status ValidateOptions(const DnSimOptions& o) {
  if (o.name.empty()) return Bad("name", "empty");
  if (o.mac_id > dn::kMaxMacId) {
    return Bad("mac_id", absl::StrCat(o.mac_id, " exceeds ", dn::kMaxMacId));
  }
  // D-26: switch values above 0x3F keep the drive offline; the simulator refuses them.
  if (o.mac_source == MacIdSource::kSwitches && o.mac_switches > dn::kMaxMacId) {
    return Bad("mac_switches", absl::StrFormat("0x%02X exceeds 0x3F (D-26)", o.mac_switches));
  }
  if (o.baud != BaudRate::k125 && o.baud != BaudRate::k250 && o.baud != BaudRate::k500) {
    return Bad("baud", absl::StrCat(static_cast<int>(o.baud), " is not 125, 250 or 500 kbit/s"));
  }
  if (!o.io_polled && !o.io_cos) return Bad("io_setup", "neither polled nor CoS/cyclic I/O");
  // §6.1 dn.io.cos.modules: Control/Addressed/Direct In only if Polled IO is not selected.
  if (o.io_polled && o.io_cos &&
      (o.cos_modules.control_in || o.cos_modules.addressed_in || o.cos_modules.direct_in)) {
    return Bad("cos_modules",
               "Control/Addressed/Direct In need Polled IO unselected (seed 261-272)");
  }
  if (o.motor_count < 1 || o.motor_count > 4) {
    return Bad("motor_count", absl::StrCat(o.motor_count, " is outside [1, 4]"));
  }
  for (size_t i = 0; i < o.motor_count; ++i) {
    const MotorOptions& m = o.motors[i];
    const std::string f = absl::StrCat("motors[", i, "].");
    if (!Finite(m.stroke_min_mm) || !Finite(m.stroke_max_mm) ||
        m.stroke_min_mm >= m.stroke_max_mm) {
      return Bad(f + "stroke_max_mm",
                 absl::StrCat(m.stroke_max_mm, " is not above stroke_min_mm ", m.stroke_min_mm));
    }
    if (!Finite(m.initial_position_mm) || m.initial_position_mm < m.stroke_min_mm ||
        m.initial_position_mm > m.stroke_max_mm) {
      return Bad(f + "initial_position_mm",
                 absl::StrCat(m.initial_position_mm, " is outside the stroke [", m.stroke_min_mm,
                              ", ", m.stroke_max_mm, "]"));
    }
    if (!Finite(m.init_position_mm) || m.init_position_mm < m.stroke_min_mm ||
        m.init_position_mm > m.stroke_max_mm) {
      return Bad(f + "init_position_mm",
                 absl::StrCat(m.init_position_mm, " is outside the stroke"));
    }
    if (!(m.max_velocity_mm_s > 0) || !Finite(m.max_velocity_mm_s)) {
      return Bad(f + "max_velocity_mm_s", absl::StrCat(m.max_velocity_mm_s, " must be > 0"));
    }
    if (!(m.init_velocity_mm_s > 0) || !(m.init_acceleration_mm_s2 > 0) ||
        !Finite(m.init_velocity_mm_s) || !Finite(m.init_acceleration_mm_s2)) {
      return Bad(f + "init_velocity_mm_s", "init velocity and acceleration must be > 0");
    }
    if (m.direct_out_1 > 7)
      return Bad(f + "direct_out_1", absl::StrCat(m.direct_out_1, " exceeds 7"));
    if (m.direct_out_2 > 7)
      return Bad(f + "direct_out_2", absl::StrCat(m.direct_out_2, " exceeds 7"));
  }
  if (MasterDriveMask(o) == 0) return Bad("motors", "no master drive");
  std::set<uint8_t> numbers;
  for (size_t i = 0; i < o.curves.size(); ++i) {
    const CurveOptions& c = o.curves[i];
    const std::string f = absl::StrCat("curves[", i, "].");
    if (c.number > 63) return Bad(f + "number", absl::StrCat(c.number, " exceeds 63"));
    if (!numbers.insert(c.number).second) {
      return Bad(f + "number", absl::StrCat(c.number, " defined twice"));
    }
    if (!(c.velocity_mm_s > 0) || !(c.acceleration_mm_s2 > 0) || !Finite(c.velocity_mm_s) ||
        !Finite(c.acceleration_mm_s2)) {
      return Bad(f + "velocity_mm_s", "velocity and acceleration must be > 0");
    }
  }
  if (o.identity.product_name.size() > 32) {
    return Bad("identity.product_name", "longer than 32 characters");
  }
  if (o.response_latency_cycles < 0 || o.response_latency_cycles > 16) {
    return Bad("response_latency_cycles",
               absl::StrCat(o.response_latency_cycles, " is outside [0, 16]"));
  }
  if (o.epr_resolution_ms == 0) return Bad("epr_resolution_ms", "0 (must be >= 1)");
  using std::chrono::microseconds;
  if (o.tick < microseconds(250) || o.tick > microseconds(10000)) {
    return Bad("tick_ms", absl::StrCat(std::chrono::duration<double, std::milli>(o.tick).count(),
                                       " ms is outside [0.25, 10] ms"));
  }
  if (o.duplicate_check_wait <= Duration{0}) return Bad("duplicate_check_wait", "must be > 0");
  if (o.response_delay < Duration{0}) return Bad("response_delay", "negative");
  if (o.bus_off_recover_after < Duration{0}) return Bad("bus_off_recover_after", "negative");
  if (!(o.lag_time_constant_s >= 0) || !Finite(o.lag_time_constant_s)) {
    return Bad("lag_time_constant_s", "must be >= 0");
  }
  if (!(o.moving_mass_kg >= 0) || !(o.force_constant_n_per_a > 0)) {
    return Bad("force_constant_n_per_a", "mass >= 0 and force constant > 0 needed");
  }
  return absl::OkStatus();
}

uint8_t ResolvedMacId(const DnSimOptions& o) {
  return o.mac_source == MacIdSource::kSwitches ? o.mac_switches : o.mac_id;
}

uint8_t MasterDriveMask(const DnSimOptions& o) {
  uint8_t mask = 0;
  for (size_t i = 0; i < o.motor_count && i < 4; ++i) {
    if (o.motors[i].master) mask |= static_cast<uint8_t>(1u << i);
  }
  return mask;
}

dn::IoLayout PollLayout(const DnSimOptions& o) {
  dn::IoLayout l;
  l.modules = o.poll_modules;
  l.master_drives = MasterDriveMask(o);
  l.byte_order = o.byte_order;
  return l;
}

dn::IoLayout CosLayout(const DnSimOptions& o) {
  dn::IoLayout l;
  l.modules = o.cos_modules;
  l.master_drives = MasterDriveMask(o);
  l.byte_order = o.byte_order;
  return l;
}

}  // namespace drivegw::sim::linmot_devicenet
