// DriveServiceCore: validation, unit mapping, drive calls and audit, shared by gRPC and REST.
#include "server/core/drive_service.h"

#include <chrono>
#include <optional>
#include <span>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "adapters/core/status.h"
#include "server/core/audit.h"
#include "server/core/convert.h"
#include "server/core/cyclic_validation.h"
#include "server/core/errors.h"
#include "server/core/validation.h"
#include "storage/audit_log.h"

namespace drivegw::server {
namespace {
// "MoveAbsolute" -> "move_absolute" for the DOWN refusal (the API's method names in snake case).
std::string SnakeCase(std::string_view action) {
  std::string out;
  for (char ch : action) {
    if (ch >= 'A' && ch <= 'Z') {
      if (!out.empty()) out.push_back('_');
      out.push_back(static_cast<char>(ch - 'A' + 'a'));
    } else {
      out.push_back(ch);
    }
  }
  return out;
}
}  // namespace

absl::Status RefuseIfDown(const Drive& d, std::string_view action) {
  // Decision 1431: a DOWN drive is refused at once, naming it and since when, instead of every
  // call waiting out its own time-out on a link known to be dead. Only while ACTIVE: an inactive
  // drive gets the lifecycle error of its family.
  if (d.lifecycle() != Lifecycle::kActive) return absl::OkStatus();
  const std::optional<HealthInfo> h = d.GetStatus().health;
  if (!h || h->state != HealthState::kDown) return absl::OkStatus();
  return DownError(d.config().name, *h, SnakeCase(action));
}

DriveServiceCore::DriveServiceCore(std::vector<std::shared_ptr<Drive>> drives,
                                   storage::AuditLog* audit, const LeaseManager* leases)
    : drives_(std::move(drives)),
      audit_(audit),
      leases_(leases),
      snapshots_(std::make_unique<WatchSnapshots>()) {
  configured_.reserve(drives_.size());
  for (const auto& d : drives_) {
    configured_.push_back({d.get(), DriveResourceName(d->config().name)});
  }
  // After the vector is complete: the map points into it.
  for (const Configured& c : configured_) by_name_[c.drive->config().name] = &c;
}

absl::StatusOr<Drive*> DriveServiceCore::Find(const std::string& field,
                                              const std::string& name) const {
  absl::StatusOr<const Configured*> c = FindConfigured(field, name);
  if (!c.ok()) return c.status();
  return (*c)->drive;
}

absl::StatusOr<const DriveServiceCore::Configured*> DriveServiceCore::FindConfigured(
    const std::string& field, const std::string& name) const {
  if (name.empty()) return FieldError(field, "is required (\"drives/{drive}\")");
  absl::string_view id = name;
  if (absl::StartsWith(id, "drives/")) id.remove_prefix(7);
  if (id.empty() || absl::StrContains(id, '/')) {
    return FieldError(field, absl::StrCat("'", name, "' is not a drive name (\"drives/{drive}\")"));
  }
  auto it = by_name_.find(std::string_view(id.data(), id.size()));
  if (it == by_name_.end()) {
    return absl::NotFoundError(absl::StrCat(field, ": drives/", id, " is not configured"));
  }
  return it->second;
}

void DriveServiceCore::Audit(const CallContext& c, const std::string& drive,
                             const std::string& action, const google::protobuf::Message& request,
                             const absl::Status& result) {
  WriteAudit(audit_, c, drive, action, ToAuditJson(request), result);
}

template <typename Req>
absl::StatusOr<v1::CommandHandle> DriveServiceCore::RunCommand(
    const char* action, const Req& r, const CallContext& c,
    const std::function<absl::StatusOr<CommandInfo>(Drive&)>& op) {
  absl::StatusOr<Drive*> drive = Find("name", r.name());
  absl::StatusOr<v1::CommandHandle> out;
  std::string drive_name = drive.ok() ? (*drive)->config().name : r.name();
  // Stop stays open to everybody while a drive is leased: stopping an axis is never refused
  // (decision 019).
  absl::Status leased =
      std::string_view(action) == "Stop" ? absl::OkStatus() : CheckLease(leases_, drive_name, c);
  if (!drive.ok()) {
    out = drive.status();
  } else if (!leased.ok()) {
    out = leased;
  } else if (absl::Status down = std::string_view(action) == "Stop" ? absl::OkStatus()
                                                                    : RefuseIfDown(**drive, action);
             !down.ok()) {
    // Stop still goes to the family: stopping is never refused by the gateway (decision 019).
    out = down;
  } else {
    absl::StatusOr<CommandInfo> info = op(**drive);
    if (info.ok()) {
      out = ToProto(drive_name, *info);
    } else {
      out = info.status();
    }
  }
  Audit(c, drive_name, action, r, out.status());
  return out;
}

absl::StatusOr<v1::ListDrivesResponse> DriveServiceCore::ListDrives(const v1::ListDrivesRequest& r,
                                                                    const CallContext& c) {
  v1::ListDrivesResponse resp;
  DGW_RETURN_IF_ERROR(ListDrives(r, c, &resp));
  return resp;
}

absl::Status DriveServiceCore::ListDrives(const v1::ListDrivesRequest&, const CallContext&,
                                          v1::ListDrivesResponse* out) {
  for (const Configured& d : configured_) FillDrive(d, out->add_drives());
  return absl::OkStatus();
}

absl::StatusOr<v1::Drive> DriveServiceCore::GetDrive(const v1::GetDriveRequest& r,
                                                     const CallContext& c) {
  v1::Drive out;
  DGW_RETURN_IF_ERROR(GetDrive(r, c, &out));
  return out;
}

absl::Status DriveServiceCore::GetDrive(const v1::GetDriveRequest& r, const CallContext&,
                                        v1::Drive* out) {
  absl::StatusOr<const Configured*> drive = FindConfigured("name", r.name());
  if (!drive.ok()) return drive.status();
  FillDrive(**drive, out);
  return absl::OkStatus();
}

void DriveServiceCore::FillDrive(const Configured& c, v1::Drive* out) const {
  // Every field from the drive at this call (the status snapshot, link counters, endpoint): only
  // the resource name, derived from the const config, is kept (decision 1363).
  const Drive& d = *c.drive;
  out->set_name(c.resource_name);
  out->set_family(d.config().family);
  out->set_endpoint(d.endpoint());
  FillAxis(d.config().axis, out->mutable_axis());
  FillStatus(d, c.resource_name, d.GetStatus(), out->mutable_status());
}

absl::StatusOr<v1::CommandHandle> DriveServiceCore::Enable(const v1::EnableRequest& r,
                                                           const CallContext& c) {
  return RunCommand("Enable", r, c, [](Drive& d) { return d.Enable(); });
}
absl::StatusOr<v1::CommandHandle> DriveServiceCore::Disable(const v1::DisableRequest& r,
                                                            const CallContext& c) {
  return RunCommand("Disable", r, c, [](Drive& d) { return d.Disable(); });
}
absl::StatusOr<v1::CommandHandle> DriveServiceCore::Home(const v1::HomeRequest& r,
                                                         const CallContext& c) {
  return RunCommand("Home", r, c, [](Drive& d) { return d.Home(); });
}
absl::StatusOr<v1::CommandHandle> DriveServiceCore::AcknowledgeFault(
    const v1::AcknowledgeFaultRequest& r, const CallContext& c) {
  return RunCommand("AcknowledgeFault", r, c, [](Drive& d) { return d.AcknowledgeFault(); });
}

absl::StatusOr<v1::CommandHandle> DriveServiceCore::MoveAbsolute(const v1::MoveAbsoluteRequest& r,
                                                                 const CallContext& c) {
  return RunCommand("MoveAbsolute", r, c, [&](Drive& d) -> absl::StatusOr<CommandInfo> {
    auto cmd = ValidateMoveAbsolute(r, d.config().axis);
    if (!cmd.ok()) return cmd.status();
    return d.Move(*cmd);
  });
}
void DriveServiceCore::MoveAbsoluteAsync(const v1::MoveAbsoluteRequest& r, const CallContext& c,
                                         Executor& blocking, HandleCompletion done) {
  // The same steps and order as RunCommand("MoveAbsolute", ...): a refusal before the drive is
  // audited like there, only on a `blocking` thread (the caller may be gRPC's callback thread).
  absl::StatusOr<Drive*> drive = Find("name", r.name());
  std::string drive_name = drive.ok() ? (*drive)->config().name : r.name();
  absl::Status refused;
  std::optional<MotionCommand> cmd;
  if (!drive.ok()) {
    refused = drive.status();
  } else if (absl::Status leased = CheckLease(leases_, drive_name, c); !leased.ok()) {
    refused = leased;
  } else if (absl::Status down = RefuseIfDown(**drive, "MoveAbsolute"); !down.ok()) {
    refused = down;
  } else if (auto valid = ValidateMoveAbsolute(r, (*drive)->config().axis); !valid.ok()) {
    refused = valid.status();
  } else {
    cmd = *std::move(valid);
  }
  // What every outcome does last: the durable audit entry, then the reply (decision 017).
  auto finish = [this, r, c, drive_name,
                 done = std::move(done)](absl::StatusOr<CommandInfo> info) mutable {
    absl::StatusOr<v1::CommandHandle> out =
        info.ok() ? absl::StatusOr<v1::CommandHandle>(ToProto(drive_name, *info)) : info.status();
    Audit(c, drive_name, "MoveAbsolute", r, out.status());
    done(std::move(out));
  };
  if (!cmd) {
    blocking.Post([finish = std::move(finish), refused]() mutable { finish(refused); });
    return;
  }
  (*drive)->MoveAsync(*cmd, blocking, std::move(finish));
}

absl::StatusOr<v1::CommandHandle> DriveServiceCore::MoveRelative(const v1::MoveRelativeRequest& r,
                                                                 const CallContext& c) {
  return RunCommand("MoveRelative", r, c, [&](Drive& d) -> absl::StatusOr<CommandInfo> {
    auto cmd = ValidateMoveRelative(r, d.config().axis, d.GetStatus().demand_position_mm);
    if (!cmd.ok()) return cmd.status();
    return d.Move(*cmd);
  });
}
absl::StatusOr<v1::CommandHandle> DriveServiceCore::MoveVelocity(const v1::MoveVelocityRequest& r,
                                                                 const CallContext& c) {
  return RunCommand("MoveVelocity", r, c, [&](Drive& d) -> absl::StatusOr<CommandInfo> {
    auto cmd = ValidateMoveVelocity(r, d.config().axis);
    if (!cmd.ok()) return cmd.status();
    return d.Move(*cmd);
  });
}

absl::StatusOr<v1::MoveCoordinatedResponse> DriveServiceCore::MoveCoordinated(
    const v1::MoveCoordinatedRequest& r, const CallContext& c) {
  // The audit names every drive, resolved where possible ("x1,x2").
  std::vector<std::string> audit_names;
  for (const auto& t : r.targets()) {
    auto d = Find("name", t.name());
    audit_names.push_back(d.ok() ? (*d)->config().name : t.name());
  }
  absl::StatusOr<v1::MoveCoordinatedResponse> out =
      [&]() -> absl::StatusOr<v1::MoveCoordinatedResponse> {
    if (auto s = ValidateCoordinatedTargetCount(r); !s.ok()) return s;
    std::vector<Drive*> group;
    std::vector<AxisConfig> axes;
    for (int i = 0; i < r.targets_size(); ++i) {
      const std::string field = absl::StrCat("move_coordinated.targets[", i, "].name");
      auto d = Find(field, r.targets(i).name());
      if (!d.ok()) return d.status();
      const DriveConfig& cfg = (*d)->config();
      for (size_t j = 0; j < group.size(); ++j) {
        if (group[j] == *d) {
          return FieldError(field, absl::StrCat(DriveResourceName(cfg.name), " is already targets[",
                                                j, "]; each drive takes part once"));
        }
      }
      // One controller implies one family; the family itself checks the controller.
      if (!group.empty() && cfg.family != group[0]->config().family) {
        return FieldError(
            field, absl::StrCat(DriveResourceName(cfg.name), " is a ", cfg.family,
                                " drive, targets[0] (", DriveResourceName(group[0]->config().name),
                                ") a ", group[0]->config().family,
                                " drive; a coordinated move runs on one controller"));
      }
      if (auto s = CheckLease(leases_, cfg.name, c); !s.ok()) return s;
      group.push_back(*d);
      axes.push_back(cfg.axis);
    }
    auto move = ValidateMoveCoordinated(r, axes);
    if (!move.ok()) return move.status();
    for (Drive* d : group) {
      if (auto down = RefuseIfDown(*d, "MoveCoordinated"); !down.ok()) return down;
    }
    auto infos = group[0]->MoveCoordinated(*move, std::span<Drive* const>(group));
    if (!infos.ok()) return infos.status();
    if (infos->size() != group.size()) {
      return absl::InternalError(absl::StrCat("drive '", group[0]->config().name, "' returned ",
                                              infos->size(), " command handles for a group of ",
                                              group.size()));
    }
    v1::MoveCoordinatedResponse resp;
    for (size_t i = 0; i < group.size(); ++i)
      *resp.add_commands() = ToProto(group[i]->config().name, (*infos)[i]);
    return resp;
  }();
  Audit(c, absl::StrJoin(audit_names, ","), "MoveCoordinated", r, out.status());
  return out;
}

absl::StatusOr<v1::CommandHandle> DriveServiceCore::Stop(const v1::StopRequest& r,
                                                         const CallContext& c) {
  return RunCommand("Stop", r, c, [&](Drive& d) -> absl::StatusOr<CommandInfo> {
    auto cmd = ValidateStop(r, d.config().axis);
    if (!cmd.ok()) return cmd.status();
    return d.Move(*cmd);
  });
}

absl::StatusOr<v1::CommandHandle> DriveServiceCore::GetCommand(const v1::GetCommandRequest& r,
                                                               const CallContext&) {
  // "drives/x1/commands/17"
  std::vector<std::string> parts = absl::StrSplit(r.name(), '/');
  uint64_t id = 0;
  if (parts.size() != 4 || parts[0] != "drives" || parts[2] != "commands" ||
      !absl::SimpleAtoi(parts[3], &id)) {
    return FieldError("name",
                      absl::StrCat("'", r.name(), "' is not \"drives/{drive}/commands/{id}\""));
  }
  auto drive = Find("name", parts[1]);
  if (!drive.ok()) return drive.status();
  auto info = (*drive)->GetCommand(id);
  if (!info)
    return absl::NotFoundError(absl::StrCat("name: ", r.name(), " is unknown or no longer kept"));
  return ToProto((*drive)->config().name, *info);
}

absl::StatusOr<v1::Parameter> DriveServiceCore::ReadParameter(const v1::ReadParameterRequest& r,
                                                              const CallContext&) {
  auto drive = Find("name", r.name());
  if (!drive.ok()) return drive.status();
  if (auto s = ValidateParameterId("read_parameter", (*drive)->config().family, r.parameter_id());
      !s.ok())
    return s;
  if (auto down = RefuseIfDown(**drive, "ReadParameter"); !down.ok()) return down;
  auto v = (*drive)->ReadParameter(ParameterRef{r.parameter_id(), r.rom()});
  if (!v.ok()) return v.status();
  v1::Parameter p;
  p.set_name(DriveResourceName((*drive)->config().name));
  p.set_parameter_id(r.parameter_id());
  p.set_value(*v);
  p.set_rom(r.rom());
  return p;
}

absl::StatusOr<v1::Parameter> DriveServiceCore::WriteParameter(const v1::WriteParameterRequest& r,
                                                               const CallContext& c) {
  auto drive = Find("name", r.name());
  absl::StatusOr<v1::Parameter> out;
  std::string drive_name = drive.ok() ? (*drive)->config().name : r.name();
  if (!drive.ok()) {
    out = drive.status();
  } else if (auto s = ValidateParameterId("write_parameter", (*drive)->config().family,
                                          r.parameter_id());
             !s.ok()) {
    out = s;
  } else if (auto leased = CheckLease(leases_, drive_name, c); !leased.ok()) {
    out = leased;
  } else if (auto down = RefuseIfDown(**drive, "WriteParameter"); !down.ok()) {
    out = down;
  } else if (auto w = (*drive)->WriteParameter(ParameterRef{r.parameter_id(), r.rom()}, r.value());
             !w.ok()) {
    out = w;
  } else {
    v1::Parameter p;
    p.set_name(DriveResourceName(drive_name));
    p.set_parameter_id(r.parameter_id());
    p.set_value(r.value());
    p.set_rom(r.rom());
    out = p;
  }
  Audit(c, drive_name, "WriteParameter", r, out.status());
  return out;
}

absl::StatusOr<v1::NativeCommandResponse> DriveServiceCore::SendNativeCommand(
    const v1::SendNativeCommandRequest& r, const CallContext& c) {
  auto drive = Find("name", r.name());
  absl::StatusOr<v1::NativeCommandResponse> out;
  std::string drive_name = drive.ok() ? (*drive)->config().name : r.name();
  if (!drive.ok()) {
    out = drive.status();
  } else if (auto fam = ValidateNativeFamily(r, (*drive)->config().family); !fam.ok()) {
    out = fam;
  } else if (auto leased = CheckLease(leases_, drive_name, c); !leased.ok()) {
    out = leased;
  } else if (auto tr = ValidateNativeTransport(r, (*drive)->config()); !tr.ok()) {
    out = tr;
  } else if (auto req = ValidateNative(r); !req.ok()) {
    out = req.status();
  } else if (auto reply = (*drive)->SendNative(*req); !reply.ok()) {
    out = reply.status();
  } else {
    v1::NativeCommandResponse resp;
    resp.set_name(DriveResourceName(drive_name));
    if (reply->command_id != 0) {
      if (auto info = (*drive)->GetCommand(reply->command_id))
        *resp.mutable_command() = ToProto(drive_name, *info);
    }
    resp.set_rtc_status(reply->status);
    resp.set_word2(reply->word2);
    resp.set_word3(reply->word3);
    resp.set_word4(reply->word4);
    resp.set_reply(std::string(reply->data.begin(), reply->data.end()));
    out = resp;
  }
  Audit(c, drive_name, "SendNativeCommand", r, out.status());
  return out;
}

absl::StatusOr<std::unique_ptr<CyclicSetpointStream>> DriveServiceCore::StartCyclicSetpoints(
    const v1::CyclicSetpointRequest& first, const CallContext& c) {
  auto drive = Find("name", first.name());
  const std::string drive_name = drive.ok() ? (*drive)->config().name : first.name();
  absl::StatusOr<std::unique_ptr<CyclicSetpointStream>> out =
      [&]() -> absl::StatusOr<std::unique_ptr<CyclicSetpointStream>> {
    if (!drive.ok()) return drive.status();
    auto mode = ValidateCyclicMode(first.mode());
    if (!mode.ok()) return mode.status();
    // A bad first set point never starts the command.
    if (first.has_setpoint()) {
      auto sp = ValidateCyclicSetpoint(first.setpoint(), *mode, (*drive)->config().axis, 0);
      if (!sp.ok()) return sp.status();
    }
    if (shutting_down_.load()) return absl::UnavailableError("the gateway is shutting down");
    if (auto s = CheckLease(leases_, drive_name, c); !s.ok()) return s;
    // A cyclic command moves the axis like a move does (decision 1491): refused while DOWN.
    if (auto down = RefuseIfDown(**drive, "StreamCyclicSetpoints"); !down.ok()) return down;
    auto started = (*drive)->StartCyclic(*mode);
    if (!started.ok()) return started.status();
    if (*started == nullptr) {
      return absl::InternalError(absl::StrCat("drive '", drive_name, "' started no cyclic stream"));
    }
    return std::make_unique<CyclicSetpointStream>(**drive, *mode, *std::move(started), first, c,
                                                  audit_, shutting_down_);
  }();
  if (!out.ok()) {
    WriteAudit(audit_, c, drive_name, kCyclicAuditAction, CyclicAuditJson(first, nullptr),
               out.status());
    return out;
  }
  if (first.has_setpoint()) {
    // Refused by the drive: close the command first, then report (End audits).
    if (auto s = (*out)->PushSetpoint(first.setpoint()); !s.ok()) return (*out)->End(s).status();
  }
  return out;
}

}  // namespace drivegw::server
