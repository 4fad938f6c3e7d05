// Core value types -> API v1 messages.
#include "server/core/convert.h"

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"

namespace drivegw::server {
namespace {
google::protobuf::Timestamp ToTimestamp(WallTime t) {
  return google::protobuf::util::TimeUtil::NanosecondsToTimestamp(
      std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count());
}
}  // namespace

std::string DriveResourceName(const std::string& drive) { return absl::StrCat("drives/", drive); }
std::string CommandResourceName(const std::string& drive, uint64_t id) {
  return absl::StrCat("drives/", drive, "/commands/", id);
}

v1::DriveState ToProto(DriveState s) {
  switch (s) {
    case DriveState::kOffline:
      return v1::OFFLINE;
    case DriveState::kDisabled:
      return v1::DISABLED;
    case DriveState::kReady:
      return v1::READY;
    case DriveState::kEnabled:
      return v1::ENABLED;
    case DriveState::kMoving:
      return v1::MOVING;
    case DriveState::kHoming:
      return v1::HOMING;
    case DriveState::kFault:
      return v1::FAULT;
  }
  return v1::DRIVE_STATE_UNSPECIFIED;
}

v1::CommandState ToProto(CommandState s) {
  switch (s) {
    case CommandState::kBusy:
      return v1::BUSY;
    case CommandState::kActive:
      return v1::ACTIVE;
    case CommandState::kDone:
      return v1::DONE;
    case CommandState::kAborted:
      return v1::ABORTED;
    case CommandState::kError:
      return v1::ERROR;
  }
  return v1::COMMAND_STATE_UNSPECIFIED;
}

v1::CommandHandle ToProto(const std::string& drive, const CommandInfo& c) {
  v1::CommandHandle h;
  h.set_name(CommandResourceName(drive, c.id));
  h.set_kind(c.kind);
  h.set_state(ToProto(c.state));
  h.set_message(c.message);
  *h.mutable_create_time() = ToTimestamp(c.created);
  if (c.ended) *h.mutable_end_time() = ToTimestamp(*c.ended);
  if (c.progress) h.mutable_progress()->set_value(*c.progress);
  return h;
}

v1::DriveStatus ToProto(const std::string& drive, const DriveStatus& s) {
  v1::DriveStatus p;
  p.set_name(DriveResourceName(drive));
  p.set_state(ToProto(s.state));
  auto* n = p.mutable_native_state();
  n->set_main_state(s.native.main_state);
  n->set_sub_state(s.native.sub_state);
  n->set_text(s.native.text);
  n->set_status_word(s.native.status_word);
  n->set_warn_word(s.native.warn_word);
  p.set_position_mm(s.position_mm);
  p.set_velocity_mm_s(s.velocity_mm_s);
  p.set_demand_position_mm(s.demand_position_mm);
  p.set_homed(s.homed);
  p.set_in_target(s.in_target);
  p.set_motion_active(s.motion_active);
  for (const auto& w : s.warnings) p.add_warnings(w);
  if (s.fault.code != 0 || !s.fault.text.empty()) {
    p.mutable_fault()->set_code(s.fault.code);
    p.mutable_fault()->set_text(s.fault.text);
    p.mutable_fault()->set_fatal(s.fault.fatal);
  }
  if (s.last_command) *p.mutable_last_command() = ToProto(drive, *s.last_command);
  *p.mutable_time() = ToTimestamp(s.time);
  p.set_sequence(s.sequence);
  if (s.health) *p.mutable_health() = ToProto(*s.health);
  return p;
}

v1::HealthState ToProto(HealthState s) {
  switch (s) {
    case HealthState::kUp:
      return v1::UP;
    case HealthState::kDemoted:
      return v1::DEMOTED;
    case HealthState::kDown:
      return v1::DOWN;
  }
  return v1::HEALTH_STATE_UNSPECIFIED;
}

v1::DriveHealth ToProto(const HealthInfo& h) {
  v1::DriveHealth p;
  p.set_state(ToProto(h.state));
  *p.mutable_since() = ToTimestamp(h.since);
  p.set_consecutive_failures(h.consecutive_failures);
  p.set_reason(h.reason);
  return p;
}

v1::LinkHealth ToProto(const LinkHealth& h) {
  v1::LinkHealth p;
  p.set_requests(h.requests);
  p.set_replies(h.replies);
  p.set_missed(h.missed);
  if (h.last_round_trip_ms) p.mutable_last_round_trip_ms()->set_value(*h.last_round_trip_ms);
  return p;
}

v1::DriveStatus StatusToProto(const Drive& d, const DriveStatus& s) {
  v1::DriveStatus p = ToProto(d.config().name, s);
  *p.mutable_link() = ToProto(d.link_health());
  return p;
}

v1::Axis ToProto(const AxisConfig& a) {
  v1::Axis p;
  p.set_kind(a.kind == AxisKind::kRotary ? v1::ROTARY : v1::LINEAR);
  p.set_min_mm(a.min_mm);
  p.set_max_mm(a.max_mm);
  p.set_max_velocity_mm_s(a.max_velocity_mm_s);
  p.set_max_acceleration_mm_s2(a.max_acceleration_mm_s2);
  return p;
}

}  // namespace drivegw::server
