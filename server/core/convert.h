// Core value types -> API v1 messages.
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
v1::DriveStatus ToProto(const std::string& drive, const DriveStatus& s);
v1::LinkHealth ToProto(const LinkHealth& h);
v1::HealthState ToProto(HealthState s);
v1::DriveHealth ToProto(const HealthInfo& h);
// The status snapshot with the drive's current link health (issue 8).
v1::DriveStatus StatusToProto(const Drive& d, const DriveStatus& s);
v1::Axis ToProto(const AxisConfig& a);

}  // namespace drivegw::server
