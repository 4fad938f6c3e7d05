// One CanopenMaster per bus spec string (decision 1111).
#include "adapters/canopen/master_pool.h"

#include "adapters/transport/can_channel.h"

namespace drivegw::canopen {

CanopenMasterPool& CanopenMasterPool::Instance() {
  static CanopenMasterPool* pool = new CanopenMasterPool();  // never destroyed: masters may
  return *pool;                                              // outlive main's statics
}

absl::StatusOr<std::shared_ptr<CanopenMaster>> CanopenMasterPool::Acquire(
    const CanBusConfig& bus, const MasterOptions& options) {
  const std::string key = transport::CanSpecString(bus);
  std::lock_guard lock(mu_);
  if (auto it = masters_.find(key); it != masters_.end()) {
    if (std::shared_ptr<CanopenMaster> live = it->second.lock()) return live;
    masters_.erase(it);
  }
  auto opened = CanopenMaster::Open(bus, options);
  if (!opened.ok()) return opened.status();
  masters_[key] = *opened;
  return *opened;
}

}  // namespace drivegw::canopen
