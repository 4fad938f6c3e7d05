// Validation of motion and expert requests against axis limits.
#include "server/core/validation.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

std::string Num(double v) { return absl::StrCat(v); }

// finite, > 0 (or >= 0 when zero_ok), <= limit.
absl::Status CheckMagnitude(const std::string& field, double v, double limit, const char* limit_name,
                            bool zero_ok) {
  if (!std::isfinite(v)) return FieldError(field, absl::StrCat(Num(v), " is not a finite number"));
  if (v < 0 || (!zero_ok && v == 0)) {
    return FieldError(field, absl::StrCat(Num(v), zero_ok ? " must not be negative" : " must be greater than 0"));
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
  if (auto s = CheckMagnitude(req + ".velocity_mm_s", v, axis.max_velocity_mm_s, "max_velocity_mm_s", false); !s.ok())
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

}  // namespace

absl::StatusOr<MotionCommand> ValidateMoveAbsolute(const v1::MoveAbsoluteRequest& r, const AxisConfig& axis) {
  if (auto s = CheckPosition("move_absolute.position_mm", r.position_mm(), axis); !s.ok()) return s;
  auto d = CheckDynamics("move_absolute", r.velocity_mm_s(), r.acceleration_mm_s2(), r.deceleration_mm_s2(), axis);
  if (!d.ok()) return d.status();
  return MoveAbsolute{r.position_mm(), r.velocity_mm_s(), r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateMoveRelative(const v1::MoveRelativeRequest& r, const AxisConfig& axis,
                                                   double demand_position_mm) {
  const double dist = r.distance_mm();
  if (!std::isfinite(dist)) return FieldError("move_relative.distance_mm", absl::StrCat(Num(dist), " is not a finite number"));
  const double target = demand_position_mm + dist;
  if (target < axis.min_mm || target > axis.max_mm) {
    return FieldError("move_relative.distance_mm",
                      absl::StrCat(Num(dist), " from ", Num(demand_position_mm), " mm ends at ", Num(target),
                                   " mm, outside the axis range [", Num(axis.min_mm), ", ", Num(axis.max_mm), "]"),
                      absl::StatusCode::kOutOfRange);
  }
  auto d = CheckDynamics("move_relative", r.velocity_mm_s(), r.acceleration_mm_s2(), r.deceleration_mm_s2(), axis);
  if (!d.ok()) return d.status();
  return MoveRelative{dist, r.velocity_mm_s(), r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateMoveVelocity(const v1::MoveVelocityRequest& r, const AxisConfig& axis) {
  const double v = r.velocity_mm_s();
  if (!std::isfinite(v)) return FieldError("move_velocity.velocity_mm_s", absl::StrCat(Num(v), " is not a finite number"));
  if (v == 0) return FieldError("move_velocity.velocity_mm_s", "0 has no direction; use Stop");
  auto d = CheckDynamics("move_velocity", std::fabs(v), r.acceleration_mm_s2(), r.deceleration_mm_s2(), axis);
  if (!d.ok()) {
    // Report the signed field value, not its magnitude.
    return d.status();
  }
  return MoveVelocity{v, r.acceleration_mm_s2(), *d};
}

absl::StatusOr<MotionCommand> ValidateStop(const v1::StopRequest& r, const AxisConfig& axis) {
  if (auto s = CheckMagnitude("stop.deceleration_mm_s2", r.deceleration_mm_s2(), axis.max_acceleration_mm_s2,
                              "max_acceleration_mm_s2", true);
      !s.ok())
    return s;
  return StopMotion{r.deceleration_mm_s2() == 0 ? axis.max_acceleration_mm_s2 : r.deceleration_mm_s2()};
}

absl::StatusOr<NativeRequest> ValidateNative(const v1::SendNativeCommandRequest& r) {
  switch (r.command_case()) {
    case v1::SendNativeCommandRequest::kLinmotMotion: {
      const auto& m = r.linmot_motion();
      if (m.master_id() > 0xFF) return FieldError("linmot_motion.master_id", absl::StrCat(m.master_id(), " exceeds 255"));
      if (m.sub_id() > 0xF) return FieldError("linmot_motion.sub_id", absl::StrCat(m.sub_id(), " exceeds 15"));
      if (m.parameters().size() > 30) {
        return FieldError("linmot_motion.parameters", absl::StrCat(m.parameters().size(), " bytes exceed 30"));
      }
      LinMotMcRequest out;
      out.master_id = static_cast<uint8_t>(m.master_id());
      out.sub_id = static_cast<uint8_t>(m.sub_id());
      out.parameters.assign(m.parameters().begin(), m.parameters().end());
      return out;
    }
    case v1::SendNativeCommandRequest::kLinmotRtc: {
      const auto& c = r.linmot_rtc();
      if (c.command_id() > 0xFF) return FieldError("linmot_rtc.command_id", absl::StrCat(c.command_id(), " exceeds 255"));
      const uint32_t words[] = {c.word2(), c.word3(), c.word4()};
      const char* names[] = {"linmot_rtc.word2", "linmot_rtc.word3", "linmot_rtc.word4"};
      for (int i = 0; i < 3; ++i) {
        if (words[i] > 0xFFFF) return FieldError(names[i], absl::StrCat(words[i], " exceeds 65535"));
      }
      return LinMotRtcRequest{static_cast<uint8_t>(c.command_id()), static_cast<uint16_t>(c.word2()),
                              static_cast<uint16_t>(c.word3()), static_cast<uint16_t>(c.word4())};
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
    case v1::SendNativeCommandRequest::COMMAND_NOT_SET:
      break;
  }
  return FieldError("command", "one of linmot_motion, linmot_rtc, linmot_devicenet is required");
}

absl::Status ValidateNativeFamily(const v1::SendNativeCommandRequest& r, const std::string& family) {
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
    case v1::SendNativeCommandRequest::COMMAND_NOT_SET:
      return absl::OkStatus();  // ValidateNative names the missing field
  }
  if (family != wanted) {
    return FieldError(field, absl::StrCat("is a ", wanted, " command; drive family is ", family));
  }
  return absl::OkStatus();
}

absl::Status ValidateParameterId(const char* request, const std::string& family, uint32_t parameter_id) {
  // LinMot addresses parameters by 16-bit UPID (linmot-mc.md §9.1).
  if (family.rfind("linmot", 0) == 0 && parameter_id > 0xFFFF) {
    return FieldError(absl::StrCat(request, ".parameter_id"),
                      absl::StrCat(parameter_id, " exceeds 65535 (LinMot UPIDs are 16 bit)"));
  }
  return absl::OkStatus();
}

}  // namespace drivegw::server
