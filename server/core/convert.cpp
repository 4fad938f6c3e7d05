// Core value types -> API v1 messages.
#include "server/core/convert.h"

#include "absl/strings/str_cat.h"

namespace drivegw::server {
namespace {
// In place (no temporary message, so an arena-allocated parent does not copy it): the same
// normalisation as TimeUtil::NanosecondsToTimestamp (nanos in [0, 1e9), seconds floored).
void SetTimestamp(WallTime t, google::protobuf::Timestamp* ts) {
  constexpr int64_t kNanosPerSecond = 1'000'000'000;
  const int64_t ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  int64_t seconds = ns / kNanosPerSecond;
  int64_t nanos = ns % kNanosPerSecond;
  if (nanos < 0) {
    nanos += kNanosPerSecond;
    seconds -= 1;
  }
  ts->set_seconds(seconds);
  ts->set_nanos(static_cast<int32_t>(nanos));
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
  FillCommand(drive, c, &h);
  return h;
}

void FillCommand(const std::string& drive, const CommandInfo& c, v1::CommandHandle* h) {
  h->set_name(CommandResourceName(drive, c.id));
  h->set_kind(c.kind);
  h->set_state(ToProto(c.state));
  h->set_message(c.message);
  SetTimestamp(c.created, h->mutable_create_time());
  if (c.ended) SetTimestamp(*c.ended, h->mutable_end_time());
  if (c.progress) h->mutable_progress()->set_value(*c.progress);
}

v1::DriveStatus ToProto(const std::string& drive, const DriveStatus& s) {
  v1::DriveStatus p;
  FillStatus(drive, DriveResourceName(drive), s, &p);
  return p;
}

void FillStatus(const std::string& drive, const std::string& resource_name, const DriveStatus& s,
                v1::DriveStatus* out) {
  v1::DriveStatus& p = *out;
  p.set_name(resource_name);
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
  if (s.last_command) FillCommand(drive, *s.last_command, p.mutable_last_command());
  SetTimestamp(s.time, p.mutable_time());
  p.set_sequence(s.sequence);
  if (s.health) FillHealth(*s.health, p.mutable_health());
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
  FillHealth(h, &p);
  return p;
}

void FillHealth(const HealthInfo& h, v1::DriveHealth* p) {
  p->set_state(ToProto(h.state));
  SetTimestamp(h.since, p->mutable_since());
  p->set_consecutive_failures(h.consecutive_failures);
  p->set_reason(h.reason);
}

v1::LinkHealth ToProto(const LinkHealth& h) {
  v1::LinkHealth p;
  FillLink(h, &p);
  return p;
}

void FillLink(const LinkHealth& h, v1::LinkHealth* p) {
  p->set_requests(h.requests);
  p->set_replies(h.replies);
  p->set_missed(h.missed);
  if (h.last_round_trip_ms) p->mutable_last_round_trip_ms()->set_value(*h.last_round_trip_ms);
}

v1::DriveStatus StatusToProto(const Drive& d, const DriveStatus& s) {
  v1::DriveStatus p;
  FillStatus(d, DriveResourceName(d.config().name), s, &p);
  return p;
}

void FillStatus(const Drive& d, const std::string& resource_name, const DriveStatus& s,
                v1::DriveStatus* out) {
  FillStatus(d.config().name, resource_name, s, out);
  FillLink(d.link_health(), out->mutable_link());
}

v1::Axis ToProto(const AxisConfig& a) {
  v1::Axis p;
  FillAxis(a, &p);
  return p;
}

void FillAxis(const AxisConfig& a, v1::Axis* p) {
  p->set_kind(a.kind == AxisKind::kRotary ? v1::ROTARY : v1::LINEAR);
  p->set_min_mm(a.min_mm);
  p->set_max_mm(a.max_mm);
  p->set_max_velocity_mm_s(a.max_velocity_mm_s);
  p->set_max_acceleration_mm_s2(a.max_acceleration_mm_s2);
}

}  // namespace drivegw::server
