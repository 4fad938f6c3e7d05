// Process-wide registry handing out one CanopenMaster per CAN bus (keyed by the bus spec string,
// transport::CanSpecString), so every CANopen drive on a bus shares one channel, one receive
// thread and one SYNC producer — the shape of the DeviceNet SessionPool (decision 1111).
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"
#include "adapters/canopen/master.h"
#include "adapters/core/drive_config.h"

namespace drivegw::canopen {

class CanopenMasterPool {
 public:
  static CanopenMasterPool& Instance();

  // The live master of `bus`, or a new one opened with `options`. A master lives as long as a
  // drive holds it; the first drive's options hold for everyone on the bus (a later drive's
  // options are ignored, decision 1111).
  absl::StatusOr<std::shared_ptr<CanopenMaster>> Acquire(const CanBusConfig& bus,
                                                         const MasterOptions& options = {});

 private:
  std::mutex mu_;
  std::map<std::string, std::weak_ptr<CanopenMaster>> masters_;
};

}  // namespace drivegw::canopen
