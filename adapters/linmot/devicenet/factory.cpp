// Factory of the LinMot DeviceNet drive family: config checks naming the field, then the drive.
#include "adapters/linmot/devicenet/factory.h"

#include "absl/strings/str_cat.h"
#include "adapters/core/drive_config_check.h"
#include "adapters/core/status.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::linmot::devicenet {

absl::StatusOr<std::unique_ptr<Drive>> CreateLinMotDnDrive(const DriveConfig& config,
                                                           const Clock& clock) {
  const std::string where = absl::StrCat("drive '", config.name, "'");
  if (!config.can) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".can: missing (family '", config.family,
                     "' needs the CAN bus: {socketcan: {interface: can0}} or {udp: {...}})"));
  }
  const CanBusConfig& can = *config.can;
  if (can.kind == CanBusConfig::Kind::kSocketCan) {
    if (can.interface.empty() || can.interface.size() > 15 ||
        can.interface.find_first_of(" :/") != std::string::npos) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".can.socketcan.interface: '", can.interface,
                       "' is not 1..15 characters without ' ', ':' or '/'"));
    }
  } else if (auto spec = transport::ParseCanSpec(transport::CanSpecString(can)); !spec.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".can.udp: ", spec.status().message()));
  }
  if (!config.mac_id) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".mac_id: missing (the drive's DeviceNet MAC ID 0..63)"));
  }
  const DnDriveOptions defaults;
  if (*config.mac_id > kMaxMacId) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".mac_id: ", *config.mac_id, " exceeds ", kMaxMacId));
  }
  if (*config.mac_id == defaults.session.master_mac) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".mac_id: ", *config.mac_id, " is the gateway's own MAC ID on ",
                     transport::CanSpecString(can), " (decision 981)"));
  }
  DGW_RETURN_IF_ERROR(CheckTimeoutsAndAxis(config, where));
  // §8.4: set-points are ±32256 increments of 1/51.2 mm (±630 mm).
  constexpr double kStroke = 32256 / kPositionIncrementsPerMm;
  if (config.axis.min_mm < -kStroke || config.axis.max_mm > kStroke) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ".axis: [", config.axis.min_mm, ", ", config.axis.max_mm,
        "] exceeds the DeviceNet position range [-630, 630] mm (linmot-devicenet.md §8.4)"));
  }
  return std::unique_ptr<Drive>(new LinMotDnDrive(config, clock));
}

}  // namespace drivegw::linmot::devicenet
