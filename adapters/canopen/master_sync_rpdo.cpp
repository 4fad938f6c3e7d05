// CanopenMaster: pacing of synchronous RPDOs against this master's own SYNC (decision 1118).
// CiA 301 v4.2.0 §7.2.2.1 / Figure 14: a node buffers a synchronous RPDO (transmission type
// 0..240) and actuates it at the next SYNC; a second frame of the same RPDO before that SYNC
// replaces the first, whose values the node never acts on. An Execute edge (high, then low)
// sent within one SYNC period would vanish. So while the producer runs, each RPDO of a node
// leaves at most once per SYNC cycle, and later frames wait, in the order they were sent.
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/master.h"
#include "adapters/core/log.h"

namespace drivegw::canopen {

absl::Status CanopenMaster::SendSyncRpdoLocked(uint8_t node, uint16_t number,
                                               const transport::CanFrame& frame,
                                               const std::string& what, bool& deferred) {
  SyncRpdoNode& n = sync_rpdo_[node];
  // Held frames go first (send order per node: set values before the edge that uses them).
  if (!n.held.empty() || n.sent.contains(number)) {
    if (n.held.size() >= kMaxHeldSyncRpdos) {
      return absl::ResourceExhaustedError(
          absl::StrCat(what, ": ", kMaxHeldSyncRpdos,
                       " synchronous RPDO frames of the node already wait for a SYNC"));
    }
    n.held.push_back({number, frame});
    deferred = true;
    return absl::OkStatus();
  }
  if (absl::Status s = SendFrame(frame); !s.ok()) {
    return absl::UnavailableError(absl::StrCat(what, ": ", s.message()));
  }
  n.sent.insert(number);
  return absl::OkStatus();
}

std::pair<uint64_t, uint64_t> CanopenMaster::FlushSyncRpdosLocked() {
  uint64_t sent = 0;
  uint64_t dropped = 0;
  for (auto& [node, n] : sync_rpdo_) {
    n.sent.clear();
    while (!n.held.empty() && !n.sent.contains(n.held.front().number)) {
      const HeldRpdo h = std::move(n.held.front());
      n.held.pop_front();
      if (absl::Status s = SendFrame(h.frame); !s.ok()) {
        // The bus refused it (down, bus-off): like a direct SendRpdo failing, the value is lost;
        // the drive's status supervision sees the consequence.
        ++dropped;
        continue;
      }
      n.sent.insert(h.number);
      ++sent;
    }
  }
  return {sent, dropped};
}

uint64_t CanopenMaster::EndSyncRpdosLocked() {
  uint64_t dropped = 0;
  for (auto& [node, n] : sync_rpdo_) dropped += n.held.size();
  sync_rpdo_.clear();
  sync_pacing_ = false;
  if (dropped > 0) {
    log::Warn("canopen_sync_rpdos_dropped",
              log::Fields().Add("bus", bus_name_).Add("frames", static_cast<int64_t>(dropped)));
  }
  return dropped;
}

}  // namespace drivegw::canopen
