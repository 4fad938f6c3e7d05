// Validation of motion and expert requests against axis limits.
#include "server/core/validation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "server/core/errors.h"
#include "server/core/validation_stober.h"

namespace drivegw::server {
namespace {

std::string Num(double v) { return absl::StrCat(v); }

// finite, > 0 (or >= 0 when zero_ok), <= limit.
absl::Status CheckMagnitude(const std::string& field, double v, double limit,
                            const char* limit_name, bool zero_ok) {
  if (!std::isfinite(v)) return FieldError(field, absl::StrCat(Num(v), " is not a finite number"));
  if (v < 0 || (!zero_ok && v == 0)) {
    return FieldError(
        field, absl::StrCat(Num(v), zero_ok ? " must not be negative" : " must be greater than 0"));
  }
  if (v > limit) {
    return FieldError(field, absl::StrCat(Num(v), " exceeds axis ", limit_name, " ", Num(limit)),
                      absl::StatusCode::kOutOfRange);
  }
  return absl::OkStatus();
}

absl::Status CheckPosition(const std::string& field, double v, const AxisConfig& axis) {
  if (!std::isfinite(v)) return FieldError(field, absl::StrCat(Num(v), " is not a finite number"));
  if (v < axis.min_mm) {
    return FieldError(field, absl::StrCat(Num(v), " is below axis min_mm ", Num(axis.min_mm)),
                      absl::StatusCode::kOutOfRange);
  }
  if (v > axis.max_mm) {
    return FieldError(field, absl::StrCat(Num(v), " exceeds axis max_mm ", Num(axis.max_mm)),
                      absl::StatusCode::kOutOfRange);
  }
  return absl::OkStatus();
}

// Velocity, acceleration and deceleration of a move; returns the deceleration to use.
absl::StatusOr<double> CheckDynamics(const std::string& req, double v, double a, double d,
                                     const AxisConfig& axis) {
  if (auto s = CheckMagnitude(req + ".velocity_mm_s", v, axis.max_velocity_mm_s,
                              "max_velocity_mm_s", false);
      !s.ok())
    return s;
  if (auto s = CheckMagnitude(req + ".acceleration_mm_s2", a, axis.max_acceleration_mm_s2,
                              "max_acceleration_mm_s2", false);
      !s.ok())
    return s;
  if (auto s = CheckMagnitude(req + ".deceleration_mm_s2", d, axis.max_acceleration_mm_s2,
                              "max_acceleration_mm_s2", true);
      !s.ok())
    return s;
  return d == 0 ? a : d;
}

// finite, > 0, and within the lowest `limit` of the group; the error names that target, so the
// caller learns the bound that actually applies.
absl::Status CheckGroupLimit(const v1::MoveCoordinatedRequest& r, const std::string& field,
                             double v, const std::vector<AxisConfig>& axes,
                             double AxisConfig::*limit, const char* limit_name) {
  if (auto s = CheckMagnitude(field, v, std::numeric_limits<double>::infinity(), limit_name, false);
      !s.ok())
    return s;
  size_t lowest = 0;
  for (size_t i = 1; i < axes.size(); ++i) {
    if (axes[i].*limit < axes[lowest].*limit) lowest = i;
  }
  if (v > axes[lowest].*limit) {
    return FieldError(
        field,
        absl::StrCat(Num(v), " exceeds ", limit_name, " ", Num(axes[lowest].*limit), " of targets[",
                     lowest, "] (", r.targets(static_cast<int>(lowest)).name(),
                     "), the lowest of the group"),
        absl::StatusCode::kOutOfRange);
  }
  return absl::OkStatus();
}

// "$F2": opcodes as the manual writes them.
std::string OpcodeText(uint32_t opcode) {
  constexpr char kHex[] = "0123456789ABCDEF";
  return {'$', kHex[(opcode >> 4) & 0xF], kHex[opcode & 0xF]};
}

absl::StatusOr<NativeRequest> ValidateTrinamic(const v1::TrinamicCommand& c) {
  if (c.opcode() > 0xFF)
    return FieldError("trinamic.opcode", absl::StrCat(c.opcode(), " exceeds 255"));
  // Service functions "are not intended for the user and when used improperly the unit can be
  // damaged permanently" (trinamic-sixpack.md §4.1 gateway policy, L918).
  if (c.opcode() >= 0xF2 && c.opcode() <= 0xF7) {
    return FieldError(
        "trinamic.opcode",
        absl::StrCat(c.opcode(), " (", OpcodeText(c.opcode()),
                     ") is a service function ($F2..$F7); the gateway never sends them "
                     "(trinamic-sixpack.md §4.1, L918)"));
  }
  // All nine bytes of a word are always sent (§2.3, L375); the gateway adds only the address.
  if (c.params().size() != 7) {
    return FieldError("trinamic.params", absl::StrCat(c.params().size(),
                                                      " bytes; exactly 7 are required (P0..P6, "
                                                      "trinamic-sixpack.md §2.3)"));
  }
  TrinamicRequest out;
  out.opcode = static_cast<uint8_t>(c.opcode());
  std::copy(c.params().begin(), c.params().end(), out.params.begin());
  return out;
}

absl::StatusOr<NativeRequest> ValidateTrinamicTunnel(const v1::TrinamicTunnel& t) {
  // One CAN frame carries 1..8 data bytes out of the RS-232 port (trinamic-sixpack.md §3.5, L315).
  if (t.data().empty()) {
    return FieldError("trinamic_tunnel.data",
                      "is empty; 1..8 bytes (one CAN frame, trinamic-sixpack.md §3.5)");
  }
  if (t.data().size() > 8) {
    return FieldError("trinamic_tunnel.data", absl::StrCat(t.data().size(),
                                                           " bytes exceed 8 (one CAN frame, "
                                                           "trinamic-sixpack.md §3.5)"));
  }
  return TrinamicTunnelRequest{std::vector<uint8_t>(t.data().begin(), t.data().end())};
}

}  // namespace

absl::StatusOr<MotionCommand> ValidateMoveAbsolute(const v1::MoveAbsoluteRequest& r,
                                                   const AxisConfig& axis) {
  if (auto s = CheckPosition("move_absolute.position_mm", r.position_mm(), axis); !s.ok()) return s;
  auto d = CheckDynamics("move_absolute", r.velocity_mm_s(), r.acceleration_mm_s2(),
                         r.deceleration_mm_s2(), axis);
  if (!d.ok()) return d.status();
  return MoveAbsolute{r.position_mm(), r.velocity_mm_s(), r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateMoveRelative(const v1::MoveRelativeRequest& r,
                                                   const AxisConfig& axis,
                                                   double demand_position_mm) {
  const double dist = r.distance_mm();
  if (!std::isfinite(dist))
    return FieldError("move_relative.distance_mm",
                      absl::StrCat(Num(dist), " is not a finite number"));
  const double target = demand_position_mm + dist;
  if (target < axis.min_mm || target > axis.max_mm) {
    return FieldError("move_relative.distance_mm",
                      absl::StrCat(Num(dist), " from ", Num(demand_position_mm), " mm ends at ",
                                   Num(target), " mm, outside the axis range [", Num(axis.min_mm),
                                   ", ", Num(axis.max_mm), "]"),
                      absl::StatusCode::kOutOfRange);
  }
  auto d = CheckDynamics("move_relative", r.velocity_mm_s(), r.acceleration_mm_s2(),
                         r.deceleration_mm_s2(), axis);
  if (!d.ok()) return d.status();
  return MoveRelative{dist, r.velocity_mm_s(), r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateMoveVelocity(const v1::MoveVelocityRequest& r,
                                                   const AxisConfig& axis) {
  const double v = r.velocity_mm_s();
  if (!std::isfinite(v))
    return FieldError("move_velocity.velocity_mm_s",
                      absl::StrCat(Num(v), " is not a finite number"));
  if (v == 0) return FieldError("move_velocity.velocity_mm_s", "0 has no direction; use Stop");
  auto d = CheckDynamics("move_velocity", std::fabs(v), r.acceleration_mm_s2(),
                         r.deceleration_mm_s2(), axis);
  if (!d.ok()) {
    // Report the signed field value, not its magnitude.
    return d.status();
  }
  return MoveVelocity{v, r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateStop(const v1::StopRequest& r, const AxisConfig& axis) {
  if (auto s = CheckMagnitude("stop.deceleration_mm_s2", r.deceleration_mm_s2(),
                              axis.max_acceleration_mm_s2, "max_acceleration_mm_s2", true);
      !s.ok())
    return s;
  return StopMotion{r.deceleration_mm_s2() == 0 ? axis.max_acceleration_mm_s2
                                                : r.deceleration_mm_s2()};
}

absl::StatusOr<NativeRequest> ValidateNative(const v1::SendNativeCommandRequest& r) {
  switch (r.command_case()) {
    case v1::SendNativeCommandRequest::kLinmotMotion: {
      const auto& m = r.linmot_motion();
      if (m.master_id() > 0xFF)
        return FieldError("linmot_motion.master_id", absl::StrCat(m.master_id(), " exceeds 255"));
      if (m.sub_id() > 0xF)
        return FieldError("linmot_motion.sub_id", absl::StrCat(m.sub_id(), " exceeds 15"));
      if (m.parameters().size() > 30) {
        return FieldError("linmot_motion.parameters",
                          absl::StrCat(m.parameters().size(), " bytes exceed 30"));
      }
      LinMotMcRequest out;
      out.master_id = static_cast<uint8_t>(m.master_id());
      out.sub_id = static_cast<uint8_t>(m.sub_id());
      out.parameters.assign(m.parameters().begin(), m.parameters().end());
      return out;
    }
    case v1::SendNativeCommandRequest::kLinmotRtc: {
      const auto& c = r.linmot_rtc();
      if (c.command_id() > 0xFF)
        return FieldError("linmot_rtc.command_id", absl::StrCat(c.command_id(), " exceeds 255"));
      const uint32_t words[] = {c.word2(), c.word3(), c.word4()};
      const char* names[] = {"linmot_rtc.word2", "linmot_rtc.word3", "linmot_rtc.word4"};
      for (int i = 0; i < 3; ++i) {
        if (words[i] > 0xFFFF)
          return FieldError(names[i], absl::StrCat(words[i], " exceeds 65535"));
      }
      return LinMotRtcRequest{static_cast<uint8_t>(c.command_id()),
                              static_cast<uint16_t>(c.word2()), static_cast<uint16_t>(c.word3()),
                              static_cast<uint16_t>(c.word4())};
    }
    case v1::SendNativeCommandRequest::kLinmotDevicenet: {
      const auto& c = r.linmot_devicenet();
      if (c.command() > 0xFFFF) {
        return FieldError("linmot_devicenet.command", absl::StrCat(c.command(), " exceeds 65535"));
      }
      if (c.value() < -32768 || c.value() > 65535) {
        return FieldError("linmot_devicenet.value",
                          absl::StrCat(c.value(), " is outside [-32768, 65535] (one 16-bit word)"));
      }
      return LinMotDnRequest{static_cast<uint16_t>(c.command()), c.value()};
    }
    case v1::SendNativeCommandRequest::kTrinamic:
      return ValidateTrinamic(r.trinamic());
    case v1::SendNativeCommandRequest::kTrinamicTunnel:
      return ValidateTrinamicTunnel(r.trinamic_tunnel());
    case v1::SendNativeCommandRequest::kStober:
      return ValidateStober(r.stober());
    case v1::SendNativeCommandRequest::kCanopenSdo:
      return ValidateCanOpenSdo(r.canopen_sdo());
    case v1::SendNativeCommandRequest::COMMAND_NOT_SET:
      break;
  }
  return FieldError("command",
                    "one of linmot_motion, linmot_rtc, linmot_devicenet, trinamic, "
                    "trinamic_tunnel, stober, canopen_sdo is required");
}

absl::Status ValidateNativeFamily(const v1::SendNativeCommandRequest& r,
                                  const std::string& family) {
  std::string field;
  std::string wanted;
  switch (r.command_case()) {
    case v1::SendNativeCommandRequest::kLinmotMotion:
      field = "linmot_motion";
      wanted = "linmot";
      break;
    case v1::SendNativeCommandRequest::kLinmotRtc:
      field = "linmot_rtc";
      wanted = "linmot";
      break;
    case v1::SendNativeCommandRequest::kLinmotDevicenet:
      field = "linmot_devicenet";
      wanted = "linmot-devicenet";
      break;
    case v1::SendNativeCommandRequest::kTrinamic:
      field = "trinamic";
      wanted = "trinamic";
      break;
    case v1::SendNativeCommandRequest::kTrinamicTunnel:
      field = "trinamic_tunnel";
      wanted = "trinamic";
      break;
    case v1::SendNativeCommandRequest::kStober:
      field = "stober";
      wanted = "stober";
      break;
    case v1::SendNativeCommandRequest::kCanopenSdo:
      // Raw SDO is CiA 301, not STOBER-specific; STOBER is the one CANopen family so far.
      field = "canopen_sdo";
      wanted = "stober";
      break;
    case v1::SendNativeCommandRequest::COMMAND_NOT_SET:
      return absl::OkStatus();  // ValidateNative names the missing field
  }
  if (family != wanted) {
    return FieldError(field, absl::StrCat("is a ", wanted, " command; drive family is ", family));
  }
  return absl::OkStatus();
}

absl::Status ValidateNativeTransport(const v1::SendNativeCommandRequest& r,
                                     const DriveConfig& config) {
  // The tunnel is the CAN identifier (A << 3) + 1 (trinamic-sixpack.md §3.5, L315); on a serial
  // line the RS-232 port is the command port itself. A drive without a trinamic section (a test
  // double) leaves the check to its family.
  if (r.command_case() == v1::SendNativeCommandRequest::kTrinamicTunnel && config.trinamic &&
      !config.trinamic->can) {
    return FieldError("trinamic_tunnel",
                      absl::StrCat("needs a drive on a CAN bus (trinamic-sixpack.md §3.5); drive '",
                                   config.name, "' is on a serial line"),
                      absl::StatusCode::kFailedPrecondition);
  }
  return absl::OkStatus();
}

absl::Status ValidateParameterId(const char* request, const std::string& family,
                                 uint32_t parameter_id) {
  const std::string field = absl::StrCat(request, ".parameter_id");
  // LinMot addresses parameters by 16-bit UPID (linmot-mc.md §9.1).
  if (family.rfind("linmot", 0) == 0 && parameter_id > 0xFFFF) {
    return FieldError(field,
                      absl::StrCat(parameter_id, " exceeds 65535 (LinMot UPIDs are 16 bit)"));
  }
  // Trinamic: opcode << 8 | index of the field's first byte among P0..P6 (0x1403 = $14.vmax);
  // whether a field starts there is the family's catalogue (adapters/trinamic/parameters.h).
  if (family == "trinamic") {
    if (parameter_id > 0xFFFF) {
      return FieldError(
          field,
          absl::StrCat(parameter_id, " exceeds 65535 (Trinamic ids are opcode << 8 | P-index)"));
    }
    if ((parameter_id & 0xFF) > 6) {
      return FieldError(field,
                        absl::StrCat(parameter_id, ": P-index ", parameter_id & 0xFF,
                                     " exceeds 6 (parameters P0..P6, trinamic-sixpack.md §2.3)"));
    }
  }
  // STOBER: CANopen index << 8 | subindex (I92 → 305Ch → 0x305C00, stober-motion.md §7.2).
  if (family == "stober" && parameter_id > 0xFFFFFF) {
    return FieldError(field, absl::StrCat(parameter_id,
                                          " exceeds 16777215 (STOBER ids are CANopen index << 8 "
                                          "| subindex, 24 bit)"));
  }
  return absl::OkStatus();
}

absl::Status ValidateCoordinatedTargetCount(const v1::MoveCoordinatedRequest& r) {
  if (r.targets_size() < 2) {
    return FieldError(
        "move_coordinated.targets",
        absl::StrCat(r.targets_size(), " targets; a coordinated move needs at least 2 drives"));
  }
  return absl::OkStatus();
}

absl::StatusOr<CoordinatedMove> ValidateMoveCoordinated(const v1::MoveCoordinatedRequest& r,
                                                        const std::vector<AxisConfig>& axes) {
  if (auto s = ValidateCoordinatedTargetCount(r); !s.ok()) return s;
  if (axes.size() != static_cast<size_t>(r.targets_size())) {
    return absl::InternalError(absl::StrCat("ValidateMoveCoordinated: ", axes.size(), " axes for ",
                                            r.targets_size(), " targets"));
  }
  CoordinatedMove out;
  for (int i = 0; i < r.targets_size(); ++i) {
    const double p = r.targets(i).position_mm();
    if (auto s = CheckPosition(absl::StrCat("move_coordinated.targets[", i, "].position_mm"), p,
                               axes[i]);
        !s.ok())
      return s;
    out.positions_mm.push_back(p);
  }
  if (auto s = CheckGroupLimit(r, "move_coordinated.velocity_mm_s", r.velocity_mm_s(), axes,
                               &AxisConfig::max_velocity_mm_s, "max_velocity_mm_s");
      !s.ok())
    return s;
  if (auto s = CheckGroupLimit(r, "move_coordinated.acceleration_mm_s2", r.acceleration_mm_s2(),
                               axes, &AxisConfig::max_acceleration_mm_s2, "max_acceleration_mm_s2");
      !s.ok())
    return s;
  out.velocity_mm_s = r.velocity_mm_s();
  out.acceleration_mm_s2 = r.acceleration_mm_s2();
  return out;
}

}  // namespace drivegw::server
