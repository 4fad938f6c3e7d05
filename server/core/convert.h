// Core value types -> API v1 messages. Each ToProto returns a new message; each Fill* writes the
// same fields into an empty message the caller owns (a response on an arena, decision 1363).
#pragma once

#include <string>

#include "adapters/core/drive.h"
#include "drivegw/v1/drive.pb.h"

namespace drivegw::server {

std::string DriveResourceName(const std::string& drive);  // "drives/x1"
std::string CommandResourceName(const std::string& drive, uint64_t id);
v1::DriveState ToProto(DriveState s);
v1::CommandState ToProto(CommandState s);
v1::CommandHandle ToProto(const std::string& drive, const CommandInfo& c);
void FillCommand(const std::string& drive, const CommandInfo& c, v1::CommandHandle* out);
v1::DriveStatus ToProto(const std::string& drive, const DriveStatus& s);
// `resource_name` is DriveResourceName(drive), passed in so a reader that keeps it does not
// format it per call.
void FillStatus(const std::string& drive, const std::string& resource_name, const DriveStatus& s,
                v1::DriveStatus* out);
v1::LinkHealth ToProto(const LinkHealth& h);
void FillLink(const LinkHealth& h, v1::LinkHealth* out);
v1::HealthState ToProto(HealthState s);
v1::DriveHealth ToProto(const HealthInfo& h);
void FillHealth(const HealthInfo& h, v1::DriveHealth* out);
// The status snapshot with the drive's current link health (issue 8).
v1::DriveStatus StatusToProto(const Drive& d, const DriveStatus& s);
void FillStatus(const Drive& d, const std::string& resource_name, const DriveStatus& s,
                v1::DriveStatus* out);
v1::Axis ToProto(const AxisConfig& a);
void FillAxis(const AxisConfig& a, v1::Axis* out);

}  // namespace drivegw::server
