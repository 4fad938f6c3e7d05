// CanopenMaster PDO runtime: configuration through the CiA 301 §7.2.2.4 SDO sequence
// (MappingWrites, decision 1107), the COB-IDs it leaves for TPDO routing and RPDO sending
// (decision 1113), and which RPDOs are synchronous (paced per SYNC, decision 1118).
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/master.h"
#include "adapters/canopen/status_util.h"
#include "adapters/core/log.h"

namespace drivegw::canopen {

absl::Status CanopenMaster::ConfigurePdo(uint8_t node, PdoKind kind, uint16_t number,
                                         const PdoCommParams& comm,
                                         std::span<const PdoMappingEntry> mapping,
                                         TimePoint deadline) {
  absl::StatusOr<std::vector<SdoWrite>> writes = MappingWrites(kind, number, node, comm, mapping);
  if (!writes.ok()) return writes.status();
  uint16_t cob = comm.cob_id;
  if (cob == 0) {
    absl::StatusOr<uint16_t> def = DefaultPdoCobId(kind, number, node);
    if (!def.ok()) return def.status();
    cob = *def;
  }
  const char* name = kind == PdoKind::kTpdo ? "tpdo" : "rpdo";
  for (size_t i = 0; i < writes->size(); ++i) {
    const SdoWrite& w = (*writes)[i];
    // Each write sets one value the sequence needs at that point; repeating it in place is
    // harmless (decision 1481).
    if (absl::Status s = Download(node, w.index, w.sub, w.data, deadline, SdoRetry::kIdempotent);
        !s.ok()) {
      // CiA 301 §7.2.2.4: the PDO stays invalid (bit 31 set by write 1) until the sequence ends.
      return AnnotateStatus(
          s, absl::StrFormat("canopen configure %s%d of node %d, write %d of %d "
                             "(0x%04X:%02X)",
                             name, number, node, i + 1, writes->size(), w.index, w.sub));
    }
  }
  std::lock_guard lock(mu_);
  const std::pair<uint8_t, uint16_t> key{node, number};
  if (kind == PdoKind::kTpdo) {
    if (auto old = tpdo_cob_.find(key); old != tpdo_cob_.end() && old->second != 0) {
      tpdo_by_cob_.erase(old->second);
    }
    tpdo_cob_[key] = comm.valid ? cob : 0;
    if (comm.valid) tpdo_by_cob_[cob] = key;
  } else {
    rpdo_cob_[key] = comm.valid ? cob : 0;
    // CiA 301 §7.5.2.35 sub 2: an RPDO of type 0..240 is actuated at the next SYNC.
    if (comm.valid && comm.transmission_type <= kTransmissionSyncEveryMax) {
      rpdo_synchronous_.insert(key);
    } else {
      rpdo_synchronous_.erase(key);
    }
  }
  log::Debug("canopen_pdo_configured", log::Fields()
                                           .Add("bus", bus_name_)
                                           .Add("node", static_cast<int>(node))
                                           .Add("pdo", absl::StrCat(name, number))
                                           .Add("cob_id", absl::StrFormat("0x%03X", cob))
                                           .Add("valid", comm.valid));
  return absl::OkStatus();
}

absl::Status CanopenMaster::SendRpdo(uint8_t node, uint16_t number,
                                     std::span<const uint8_t> payload) {
  const std::string what = absl::StrCat("canopen rpdo", number, " of node ", node);
  if (absl::Status s = ValidateNodeId(node, "rpdo.node_id"); !s.ok()) return s;
  if (number == 0 || number > kPdoMaxNumber) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": number ", number, " outside 1..", kPdoMaxNumber));
  }
  if (payload.size() > transport::kCanMaxDlc) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": ", payload.size(), " bytes exceed ", transport::kCanMaxDlc));
  }
  uint16_t cob = 0;
  bool synchronous = false;
  {
    std::lock_guard lock(mu_);
    synchronous = rpdo_synchronous_.contains({node, number});
    if (auto it = rpdo_cob_.find({node, number}); it != rpdo_cob_.end()) {
      if (it->second == 0) {
        return absl::FailedPreconditionError(absl::StrCat(what, ": configured invalid"));
      }
      cob = it->second;
    }
  }
  if (cob == 0) {
    absl::StatusOr<uint16_t> def = DefaultPdoCobId(PdoKind::kRpdo, number, node);
    if (!def.ok()) {
      return absl::FailedPreconditionError(
          absl::StrCat(what,
                       ": no COB-ID (only RPDO 1..4 have a predefined one; ConfigurePdo "
                       "first)"));
    }
    cob = *def;
  }
  const transport::CanFrame frame = transport::MakeCanFrame(cob, payload);
  bool deferred = false;
  absl::Status sent = absl::OkStatus();
  bool paced = false;
  if (synchronous) {
    std::lock_guard pacing(rpdo_mu_);
    if (sync_pacing_) {
      paced = true;
      sent = SendSyncRpdoLocked(node, number, frame, what, deferred);
    }
  }
  if (!paced) {
    if (absl::Status s = SendFrame(frame); !s.ok()) {
      sent = absl::UnavailableError(absl::StrCat(what, ": ", s.message()));
    }
  }
  if (!sent.ok()) return sent;
  std::lock_guard lock(mu_);
  ++(deferred ? counters_.rpdo_deferred : counters_.rpdo_sent);
  return absl::OkStatus();
}

}  // namespace drivegw::canopen
