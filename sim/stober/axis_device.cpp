// The simulated STOBER axis on CANopen: object binding, cycle clock, TPDO requests, EMCY
// (decisions 1176-1181; object map decisions 1171-1175).
#include "sim/stober/axis_device.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/emcy.h"
#include "adapters/canopen/sdo.h"

namespace drivegw::sim::stober {
namespace {

namespace co = drivegw::canopen;
namespace so = drivegw::stober;
using canopen::DataType;
using canopen::SlaveNode;

DataType ToDataType(so::WireType type) {
  switch (type) {
    case so::WireType::kU8:
      return DataType::kU8;
    case so::WireType::kI8:
      return DataType::kI8;
    case so::WireType::kU16:
      return DataType::kU16;
    case so::WireType::kI16:
      return DataType::kI16;
    case so::WireType::kU32:
      return DataType::kU32;
    case so::WireType::kI32:
      return DataType::kI32;
  }
  return DataType::kU8;
}

// A model value outside the wire range is served saturated (decision 1177): a status read never
// fails, and the limit is an honest "at least this much".
int64_t SaturatedRaw(const so::ObjectBinding& b, double value) {
  if (std::isnan(value)) return 0;
  const double scaled = std::round(value / b.scale);
  const auto lo = static_cast<double>(b.boolean ? 0 : so::WireTypeMin(b.type));
  const auto hi = static_cast<double>(b.boolean ? 1 : so::WireTypeMax(b.type));
  return static_cast<int64_t>(std::clamp(scaled, lo, hi));
}

std::string Label(const so::ObjectBinding& b) {
  return absl::StrCat(ToString(b.param), " (", std::string(b.name), ")");
}

}  // namespace

AxisDevice::AxisDevice(AxisDeviceOptions options) : options_(std::move(options)) {
  auto core = MakeCore(options_);
  // Validate() refuses options whose power-on writes fail; a device built from unvalidated ones
  // falls back to the catalogue defaults rather than aborting.
  core_ = core.ok() ? *std::move(core) : std::make_unique<MotionCore>(options_.core);
}

absl::StatusOr<std::unique_ptr<MotionCore>> AxisDevice::MakeCore(const AxisDeviceOptions& options) {
  auto core = std::make_unique<MotionCore>(options.core);
  auto write = [&](const char* id, double value) -> absl::Status {
    absl::Status s = core->Write(P(id), value);
    if (!s.ok()) return absl::InvalidArgumentError(s.message());
    return absl::OkStatus();
  };
  if (options.cycle_ms) {
    if (absl::Status s = write("A150", *options.cycle_ms); !s.ok()) return s;
  }
  if (options.extrapolation_ms) {
    if (absl::Status s = write("I423", *options.extrapolation_ms); !s.ok()) return s;
  }
  if (options.endless) {
    if (absl::Status s = write("I01", options.revolution); !s.ok()) return s;
    if (absl::Status s = write("I00", 1); !s.ok()) return s;
  }
  return core;
}

absl::Status AxisDevice::Validate(const AxisDeviceOptions& options) {
  return MakeCore(options).status();
}

void AxisDevice::Restart() {
  auto core = MakeCore(options_);
  core_ = core.ok() ? *std::move(core) : std::make_unique<MotionCore>(options_.core);
  carry_ = Duration::zero();
  error_ = positive_limit_ = negative_limit_ = emcy_active_ = false;
  last_flags_ = 0;
  last_status_word_ = 0;
  last_plc_ = 0;
  sampled_execute_ = execute_seen_low_ = false;
  // The fault-injection switches are the test's, not the drive's: they survive a reset.
}

absl::Status AxisDevice::AddObject(SlaveNode& node, const so::ObjectBinding& b) {
  const ParamInfo* info = FindParam(b.param);
  if (info == nullptr) {
    return absl::InternalError(
        absl::StrCat("object map entry ", Label(b), " is not in the simulated catalogue"));
  }
  canopen::ObjectDef def =
      canopen::Integer(b.address.index, b.address.sub_index, std::string(b.name),
                       ToDataType(b.type),
                       b.read_only ? canopen::Access::kRo : canopen::Access::kRw,
                       SaturatedRaw(b, info->default_value))
          .Mappable();
  if (b.boolean) def.Range(0, 1);
  canopen::ObjectDictionary& od = node.dictionary();
  if (absl::Status s = od.Add(def); !s.ok()) return s;
  const so::ObjectBinding binding = b;
  absl::Status s = od.OnReadInt(b.address.index, b.address.sub_index,
                                [this, binding]() -> absl::StatusOr<int64_t> {
                                  absl::StatusOr<double> v = core_->Read(binding.param);
                                  if (!v.ok()) return v.status();
                                  return SaturatedRaw(binding, *v);
                                });
  if (!s.ok() || b.read_only) return s;
  // Writes: the catalogue's limits give 0609 0031h/0032h naming the limit, other refusals of
  // the core 0609 0030h (decision 1177); read-only objects are refused by the dictionary with
  // 0601 0002h before any hook runs.
  return od.OnWriteInt(
      b.address.index, b.address.sub_index, [this, binding, info](int64_t raw) -> absl::Status {
        const double value = so::FromRaw(binding, raw);
        if (value > info->max) {
          return co::SdoAbortStatus(
              co::SdoAbortCode::kValueTooHigh,
              absl::StrCat(Label(binding), ": ", value, " above maximum ", info->max));
        }
        if (value < info->min) {
          return co::SdoAbortStatus(
              co::SdoAbortCode::kValueTooLow,
              absl::StrCat(Label(binding), ": ", value, " below minimum ", info->min));
        }
        absl::Status w = core_->Write(binding.param, value);
        if (w.ok()) return w;
        return co::SdoAbortStatus(w.code() == absl::StatusCode::kFailedPrecondition
                                      ? co::SdoAbortCode::kReadOnly
                                      : co::SdoAbortCode::kValueRange,
                                  std::string(w.message()));
      });
}

absl::Status AxisDevice::Configure(SlaveNode& node) {
  for (const so::ObjectBinding& b : so::ObjectMap()) {
    if (absl::Status s = AddObject(node, b); !s.ok()) return s;
  }
  canopen::ObjectDictionary& od = node.dictionary();
  absl::Status s =
      od.Add(canopen::Integer(so::kStatusFlagsIndex, so::kStatusFlagsSub, "motion status flags",
                              DataType::kU32, canopen::Access::kRo)
                 .Mappable());
  if (!s.ok()) return s;
  s = od.OnReadInt(so::kStatusFlagsIndex, so::kStatusFlagsSub,
                   [this]() -> absl::StatusOr<int64_t> { return StatusFlags(); });
  if (!s.ok()) return s;
  // CiA 402 6007h abort connection option code, default 1 (fault) as the profile gives it;
  // 0..3 accepted, the manufacturer-specific negative codes refused (decision 1483).
  s = od.Add(canopen::Integer(so::kAbortConnectionOption, 0, "abort connection option code",
                              DataType::kI16, canopen::Access::kRw, so::kAbortFault));
  if (!s.ok()) return s;
  s = od.OnWriteInt(so::kAbortConnectionOption, 0, [](int64_t v) -> absl::Status {
    if (v < so::kAbortNoAction || v > so::kAbortQuickStop) {
      return co::SdoAbortStatus(co::SdoAbortCode::kValueRange,
                                absl::StrCat("6007h abort connection option ", v,
                                             ": only 0..3 (no action, fault, disable voltage, "
                                             "quick stop)"));
    }
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  // The power-on PDOs are the gateway's default layout, so a demo works without configuration
  // (decision 1176); the gateway re-configures them anyway after every boot-up.
  for (const so::PdoLayout& l : so::DefaultPdoLayout()) {
    const co::PdoMapping mapping = l.Mapping();
    s = node.ConfigureDefaultPdo(l.kind, l.number, l.comm, mapping);
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

uint32_t AxisDevice::StatusFlags() const {
  uint32_t flags = 0;
  for (const so::StatusFlagBit& f : so::StatusFlagBits()) {
    const double v = core_->Read(f.param).value_or(0);
    if (f.two_bit) {
      flags |= (static_cast<uint32_t>(v) << so::status_bit::kCommandStateShift) & f.bit;
    } else if (v != 0) {
      flags |= f.bit;
    }
  }
  return flags;
}

void AxisDevice::Tick(SlaveNode& node, Duration dt) {
  carry_ += dt;
  while (true) {
    // A150 may change between cycles (an SDO write); it is read each cycle (§8.1).
    const double cycle_ms = core_->Read(P("A150")).value_or(1);
    const Duration cycle = FromSeconds(std::max(cycle_ms, 0.125) / 1000.0);
    if (carry_ < cycle) break;
    carry_ -= cycle;
    SampleExecute();
    core_->Advance(1);
    AfterCycle(node);
  }
}

void AxisDevice::OnRpdoWritten(SlaveNode& node, uint16_t number) {
  (void)node;
  (void)number;
  // Any RPDO may carry I402 or the control word's Execute bit (both feed I402); the value after
  // the whole frame is what the input image held (decision 1182). SDO writes are not latched.
  if (core_->Read(P("I402")).value_or(0) == 0) execute_seen_low_ = true;
}

void AxisDevice::SampleExecute() {
  const bool execute = core_->Read(P("I402")).value_or(0) != 0;
  const bool low_between = !sampled_execute_ || execute_seen_low_;
  if (execute && low_between && (ignore_execute_ || drop_next_edge_)) {
    // Fault injection: the edge is lost; the core keeps seeing Execute low until the bus
    // writes it again, as if the frame carrying the edge had never arrived.
    (void)core_->Write(P("I402"), 0);
    drop_next_edge_ = false;
    ++dropped_edges_;
    sampled_execute_ = false;
    execute_seen_low_ = false;
    return;
  }
  if (execute_seen_low_) core_->LatchExecuteLow();
  execute_seen_low_ = false;
  sampled_execute_ = execute;
}

void AxisDevice::AfterCycle(SlaveNode& node) {
  const uint32_t flags = StatusFlags();
  const auto status_word = static_cast<uint16_t>(core_->Read(P("A516")).value_or(0));
  const int plc = static_cast<int>(core_->Read(P("I89")).value_or(0));
  const int cause = static_cast<int>(core_->Read(P("I90")).value_or(0));
  // Every change of the status TPDO goes out at the cycle it happens, not only the state at the
  // end of a longer Tick: the I92 = 0 cycle of a restart stays visible (decision 1179).
  if (flags != last_flags_ || status_word != last_status_word_ || plc != last_plc_) {
    node.RequestTpdo(1);
  }
  last_flags_ = flags;
  last_status_word_ = status_word;
  last_plc_ = plc;

  // EMCY on the rising edge of each fault condition; "error reset" when all are gone.
  const bool error = (flags & so::status_bit::kError) != 0;
  const bool positive = (flags & so::status_bit::kPositiveLimitSwitch) != 0;
  const bool negative = (flags & so::status_bit::kNegativeLimitSwitch) != 0;
  const PowerState power = core_->power_state();
  const bool fault = power == PowerState::kFault || power == PowerState::kFaultReactionActive;
  if (positive && !positive_limit_) {
    node.RaiseEmcy(kEmcyLimitSwitch, kErrorRegisterProfile, {1, 0, 0, 0, 0});
    emcy_active_ = true;
  }
  if (negative && !negative_limit_) {
    node.RaiseEmcy(kEmcyLimitSwitch, kErrorRegisterProfile, {2, 0, 0, 0, 0});
    emcy_active_ = true;
  }
  if (error && !error_) {
    node.RaiseEmcy(static_cast<uint16_t>(kEmcyMotionCoreBase + (cause & 0xFF)),
                   kErrorRegisterManufacturer,
                   {static_cast<uint8_t>(cause), static_cast<uint8_t>(plc), 0, 0, 0});
    emcy_active_ = true;
  }
  error_ = error;
  positive_limit_ = positive;
  negative_limit_ = negative;
  if (emcy_active_ && !error && !positive && !negative && !fault) {
    node.ClearErrors();
    emcy_active_ = false;
  }
}

void AxisDevice::OnResetApplication(SlaveNode& node) {
  (void)node;
  Restart();  // power-on state of the drive (CiA 301 reset application, decision 1180)
}

void AxisDevice::OnCommunicationError(SlaveNode& node, uint16_t emcy_code, uint8_t producer) {
  // CiA 402 6007h: the drive's own reaction to a lost connection, here a heartbeat consumer
  // time-out (1016h) or a recovered bus-off, on top of CiA 301's EMCY and 1029h (decision 1483).
  const int64_t option =
      node.dictionary().GetInt(so::kAbortConnectionOption, 0).value_or(so::kAbortFault);
  const std::string reason =
      emcy_code == co::emcy_code::kLifeGuardHeartbeat
          ? absl::StrCat("heartbeat of node ", producer, " lost (1016h consumer time-out)")
          : absl::StrCat("communication error EMCY ", absl::Hex(emcy_code, absl::kZeroPad4));
  core_->AbortConnection(static_cast<int>(option), emcy_code, reason);
  if (option != so::kAbortNoAction && on_abort_) on_abort_(core_->events().back());
}

void AxisDevice::InjectFollowingError(SlaveNode& node) {
  core_->InjectFault();
  node.RaiseEmcy(kEmcyFollowingError, kErrorRegisterProfile, {});
  emcy_active_ = true;
}

void AxisDevice::ForceLimitSwitch(bool positive, std::optional<bool> active) {
  core_->ForceLimitSwitch(positive, active);
}

}  // namespace drivegw::sim::stober
