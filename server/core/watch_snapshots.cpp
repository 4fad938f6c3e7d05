// WatchSnapshots: one proto and content key per drive snapshot, shared by every watch stream.
#include "server/core/watch_snapshots.h"

#include <utility>

namespace drivegw::server {

WatchSnapshots::Snapshot WatchSnapshots::Get(const Drive& drive, const DriveStatus& status,
                                             const std::function<v1::DriveStatus()>& build,
                                             std::chrono::steady_clock::duration max_age) {
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mu_);
    auto it = entries_.find(&drive);
    if (it != entries_.end() && it->second.sequence == status.sequence &&
        now - it->second.built <= max_age) {
      return it->second.snapshot;
    }
  }
  // Built outside the lock: streams of other drives do not wait for this one's conversion.
  auto proto = std::make_shared<v1::DriveStatus>(build());
  v1::DriveStatus content = *proto;
  content.clear_time();
  content.clear_sequence();
  content.clear_link();
  Snapshot snapshot{std::move(proto),
                    std::make_shared<const std::string>(content.SerializeAsString())};
  std::lock_guard lock(mu_);
  Entry& e = entries_[&drive];
  if (status.sequence >= e.sequence) e = Entry{status.sequence, now, snapshot};
  return snapshot;
}

}  // namespace drivegw::server
