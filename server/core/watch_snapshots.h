// WatchDrives' shared snapshots (issue 10, P5): the proto of a drive's status snapshot and its
// content key are built once per snapshot for every stream that watches the drive, instead of
// once per stream (1,000 streams of one drive at 100 Hz were 100,000 conversions a second).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "adapters/core/drive.h"
#include "drivegw/v1/drive.pb.h"

namespace drivegw::server {

class WatchSnapshots {
 public:
  struct Snapshot {
    std::shared_ptr<const v1::DriveStatus> proto;
    // The proto without time, sequence and link: the fields that change on every publish (the
    // link counters every bus cycle) do not make a snapshot new (decision 507);
    // streams compare the pointer first, the bytes only when it differs.
    std::shared_ptr<const std::string> key;
  };

  // The snapshot of `status` (just read from `drive`): the cached one when another stream already
  // built it for the same sequence not longer than `max_age` ago (the link counters it carries
  // are then that fresh), else `build()`'s, cached unless a newer sequence is cached already.
  Snapshot Get(const Drive& drive, const DriveStatus& status,
               const std::function<v1::DriveStatus()>& build,
               std::chrono::steady_clock::duration max_age);

 private:
  struct Entry {
    uint64_t sequence = 0;
    std::chrono::steady_clock::time_point built;
    Snapshot snapshot;
  };
  std::mutex mu_;
  std::unordered_map<const Drive*, Entry> entries_;
};

}  // namespace drivegw::server
