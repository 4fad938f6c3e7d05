// CiA 301 communication objects of the simulated slave and their write rules (CiA 301 v4.2.0
// §7.5.2; decisions 1123-1125).
#include "sim/canopen/communication_objects.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/sync.h"

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;
using co::PdoKind;
using co::SdoAbortStatus;

constexpr uint32_t kCobIdInvalid = 0x80000000;  // bit 31 (PDO, EMCY: object not valid)
constexpr uint32_t kCobIdBit30 = 0x40000000;    // PDO: no RTR; SYNC: this node produces SYNC
constexpr uint32_t kCobIdFrame = 0x20000000;    // bit 29: 29-bit identifier

uint16_t CommIndex(PdoKind kind, uint16_t n) { return co::PdoCommIndex(kind, n); }
uint16_t MapIndex(PdoKind kind, uint16_t n) { return co::PdoMappingIndex(kind, n); }
const char* KindName(PdoKind kind) { return kind == PdoKind::kTpdo ? "tpdo" : "rpdo"; }

uint32_t U32(std::span<const uint8_t> b) {
  return static_cast<uint32_t>(DecodeInteger(DataType::kU32, b).value_or(0));
}

absl::Status Invalid(std::string message) {
  return SdoAbortStatus(co::SdoAbortCode::kValueRange, message);
}

// Every entry 1..count of a mapping object must name a mappable object, 64 bits at most
// (§7.5.2.36: abort 0602 0000h, 0604 0041h, 0604 0042h).
absl::Status CheckMapping(const ObjectDictionary& od, PdoKind kind, uint16_t number,
                          uint8_t count) {
  const uint16_t map = MapIndex(kind, number);
  size_t bits = 0;
  for (uint8_t sub = 1; sub <= count; ++sub) {
    const auto raw = od.GetInt(map, sub);
    if (!raw.ok()) return raw.status();
    const co::PdoMappingEntry e = co::DecodeMappingEntry(static_cast<uint32_t>(*raw));
    if (absl::Status s = od.CheckMappable(kind, e); !s.ok()) {
      return SdoAbortStatus(co::AbortCodeForStatus(s),
                            absl::StrFormat("%04Xh:%02X: %s", map, sub, std::string(s.message())));
    }
    bits += e.bits;
  }
  if (bits > co::kPdoMaxBits) {
    return SdoAbortStatus(co::SdoAbortCode::kPdoLength,
                          absl::StrFormat("%04Xh: %d objects map %d bits, more than %d", map, count,
                                          bits, co::kPdoMaxBits));
  }
  return absl::OkStatus();
}

bool PdoValid(const ObjectDictionary& od, PdoKind kind, uint16_t number) {
  const int64_t cob = od.GetInt(CommIndex(kind, number), 1).value_or(kCobIdInvalid);
  return (static_cast<uint32_t>(cob) & kCobIdInvalid) == 0;
}

absl::Status AddPdo(ObjectDictionary& od, PdoKind kind, uint16_t number, uint8_t node) {
  const uint16_t comm = CommIndex(kind, number);
  const uint16_t map = MapIndex(kind, number);
  const std::string name = absl::StrCat(KindName(kind), number);
  const bool tpdo = kind == PdoKind::kTpdo;
  const uint32_t predefined = co::DefaultPdoCobId(kind, number, node).value_or(0);
  // Predefined identifier, invalid until the master configures the PDO; TPDOs without RTR
  // (decision 1123, as the library writes them: decision 1107).
  const uint32_t cob_default = kCobIdInvalid | (tpdo ? kCobIdBit30 : 0) | predefined;

  std::vector<ObjectDef> defs;
  defs.push_back(Integer(comm, 0, name + " highest sub-index", DataType::kU8, Access::kConst, 5));
  defs.push_back(Integer(comm, 1, name + " cob-id", DataType::kU32, Access::kRw, cob_default));
  defs.push_back(Integer(comm, 2, name + " transmission type", DataType::kU8, Access::kRw,
                         co::kTransmissionEventProfile));
  if (tpdo) defs.push_back(Integer(comm, 3, name + " inhibit time", DataType::kU16));
  defs.push_back(Integer(comm, 5, name + " event timer", DataType::kU16));
  defs.push_back(Integer(map, 0, name + " mapped objects", DataType::kU8, Access::kRw, 0)
                     .Range(0, kPdoMappingEntries));
  for (uint8_t i = 1; i <= kPdoMappingEntries; ++i) {
    defs.push_back(Integer(map, i, absl::StrCat(name, " mapping ", i), DataType::kU32));
  }
  for (ObjectDef& d : defs) {
    if (absl::Status s = od.Add(std::move(d)); !s.ok()) return s;
  }

  ObjectDictionary* dict = &od;
  // Sub 1, COB-ID (§7.5.2.35/37): bits 11..28 and 29 (29-bit ids) must be 0; the identifier may
  // not change while the PDO is valid; a PDO becomes valid only with a non-restricted identifier
  // and at least one mapped object (decision 1124).
  absl::Status s =
      od.OnWrite(comm, 1, [dict, comm, map](std::span<const uint8_t> bytes) -> absl::Status {
        const uint32_t cob = U32(bytes);
        const std::string label = absl::StrFormat("%04Xh:01 cob-id 0x%08X", comm, cob);
        if ((cob & 0x1FFFF800) != 0 || (cob & kCobIdFrame) != 0) {
          return Invalid(absl::StrCat(label, ": bits 11..29 must be 0 (11-bit identifiers only)"));
        }
        const bool valid = (cob & kCobIdInvalid) == 0;
        if (!valid) return absl::OkStatus();
        const uint16_t id = cob & 0x7FF;
        const uint32_t old = static_cast<uint32_t>(dict->GetInt(comm, 1).value_or(kCobIdInvalid));
        if ((old & kCobIdInvalid) == 0 && (old & 0x7FF) != id) {
          return Invalid(absl::StrCat(label, ": identifier changes only while bit 31 is set"));
        }
        if (IsRestrictedCanId(id)) {
          return Invalid(
              absl::StrFormat("%s: identifier 0x%03X is restricted (CiA 301 §7.3.5)", label, id));
        }
        if (dict->GetInt(map, 0).value_or(0) == 0) {
          return Invalid(absl::StrFormat("%s: %04Xh:00 maps no object", label, map));
        }
        return absl::OkStatus();
      });
  if (!s.ok()) return s;
  // Sub 2, transmission type (§7.5.2.35 Table 70/§7.5.2.37 Table 72): 241..251 reserved,
  // 252/253 (RTR) only for TPDOs.
  s = od.OnWriteInt(comm, 2, [comm, tpdo](int64_t type) -> absl::Status {
    if (type > co::kTransmissionSyncEveryMax && type < co::kTransmissionSyncRtr) {
      return Invalid(
          absl::StrFormat("%04Xh:02 transmission type %d: 241..251 are reserved", comm, type));
    }
    if (!tpdo && (type == co::kTransmissionSyncRtr || type == co::kTransmissionEventRtr)) {
      return Invalid(
          absl::StrFormat("%04Xh:02 transmission type %d: RTR types are TPDO-only", comm, type));
    }
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  if (tpdo) {
    // Sub 3, inhibit time: "shall not be changed while the PDO exists" (§7.5.2.37).
    s = od.OnWriteInt(comm, 3, [dict, kind, number, comm](int64_t) -> absl::Status {
      if (PdoValid(*dict, kind, number)) {
        return Invalid(
            absl::StrFormat("%04Xh:03 inhibit time: changes only while %04Xh:01 bit "
                            "31 is set",
                            comm, comm));
      }
      return absl::OkStatus();
    });
    if (!s.ok()) return s;
  }
  // Mapping (§7.2.2.4 steps 1-5): writable only while the PDO is invalid, entries only while
  // sub 0 is 0 (0601 0000h otherwise, decision 1124); each entry is checked when written, the
  // whole mapping when sub 0 enables it.
  s = od.OnWriteInt(map, 0, [dict, kind, number, map, comm](int64_t count) -> absl::Status {
    if (PdoValid(*dict, kind, number)) {
      return SdoAbortStatus(co::SdoAbortCode::kUnsupportedAccess,
                            absl::StrFormat("%04Xh:00: mapping changes only while %04Xh:01 bit "
                                            "31 is set",
                                            map, comm));
    }
    return CheckMapping(*dict, kind, number, static_cast<uint8_t>(count));
  });
  if (!s.ok()) return s;
  for (uint8_t i = 1; i <= kPdoMappingEntries; ++i) {
    s = od.OnWriteInt(map, i, [dict, kind, number, map, comm, i](int64_t raw) -> absl::Status {
      if (PdoValid(*dict, kind, number)) {
        return SdoAbortStatus(co::SdoAbortCode::kUnsupportedAccess,
                              absl::StrFormat("%04Xh:%02X: mapping changes only while %04Xh:01 "
                                              "bit 31 is set",
                                              map, i, comm));
      }
      if (dict->GetInt(map, 0).value_or(0) != 0) {
        return SdoAbortStatus(co::SdoAbortCode::kUnsupportedAccess,
                              absl::StrFormat("%04Xh:%02X: entries change only while %04Xh:00 "
                                              "is 0",
                                              map, i, map));
      }
      if (raw == 0) return absl::OkStatus();  // clearing an entry
      const co::PdoMappingEntry e = co::DecodeMappingEntry(static_cast<uint32_t>(raw));
      if (absl::Status m = dict->CheckMappable(kind, e); !m.ok()) {
        return SdoAbortStatus(co::AbortCodeForStatus(m),
                              absl::StrFormat("%04Xh:%02X: %s", map, i, std::string(m.message())));
      }
      return absl::OkStatus();
    });
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status AddErrorHistory(ObjectDictionary& od) {
  if (absl::Status s = od.Add(Integer(0x1003, 0, "error history count", DataType::kU8)); !s.ok()) {
    return s;
  }
  ObjectDictionary* dict = &od;
  // §7.5.2.4: only 0 may be written (clears the history); other values 0609 0030h.
  absl::Status s = od.OnWriteInt(0x1003, 0, [dict](int64_t v) -> absl::Status {
    if (v != 0) {
      return Invalid(absl::StrCat("1003h:00 error history count: ", v, " written, only 0 clears"));
    }
    for (uint8_t i = 1; i <= kErrorHistoryDepth; ++i) (void)dict->SetInt(0x1003, i, 0);
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  for (uint8_t i = 1; i <= kErrorHistoryDepth; ++i) {
    s = od.Add(Integer(0x1003, i, absl::StrCat("error history ", i), DataType::kU32, Access::kRo));
    if (!s.ok()) return s;
    // Entries beyond the count hold no error: 0800 0024h "no data available" (decision 1125).
    s = od.OnRead(0x1003, i, [dict, i]() -> absl::StatusOr<std::vector<uint8_t>> {
      const int64_t count = dict->GetInt(0x1003, 0).value_or(0);
      if (i > count) {
        return SdoAbortStatus(
            co::SdoAbortCode::kNoData,
            absl::StrCat("1003h:", i, " error history: ", count, " errors recorded"));
      }
      return dict->GetBytes(0x1003, i);
    });
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status AddHeartbeatConsumers(ObjectDictionary& od) {
  if (absl::Status s = od.Add(Integer(0x1016, 0, "consumer heartbeat highest sub-index",
                                      DataType::kU8, Access::kConst, kHeartbeatConsumerCount));
      !s.ok()) {
    return s;
  }
  ObjectDictionary* dict = &od;
  for (uint8_t i = 1; i <= kHeartbeatConsumerCount; ++i) {
    if (absl::Status s =
            od.Add(Integer(0x1016, i, absl::StrCat("consumer heartbeat ", i), DataType::kU32));
        !s.ok()) {
      return s;
    }
    // §7.5.2.25: bits 24..31 reserved; one active entry per node id (0604 0043h otherwise).
    absl::Status s = od.OnWriteInt(0x1016, i, [dict, i](int64_t raw) -> absl::Status {
      const auto v = static_cast<uint32_t>(raw);
      const uint8_t node = static_cast<uint8_t>(v >> 16);
      const uint16_t time = static_cast<uint16_t>(v);
      if ((v & 0xFF000000) != 0 || node > co::kMaxNodeId) {
        return Invalid(absl::StrFormat(
            "1016h:%02X consumer heartbeat 0x%08X: node id %d outside 0..127 or reserved bits", i,
            v, node));
      }
      if (node == 0 || time == 0) return absl::OkStatus();
      for (const HeartbeatConsumer& c : ReadHeartbeatConsumers(*dict)) {
        if (c.sub != i && c.node == node) {
          return SdoAbortStatus(
              co::SdoAbortCode::kParameterIncompatible,
              absl::StrFormat("1016h:%02X: node %d is already monitored by 1016h:%02X", i, node,
                              c.sub));
        }
      }
      return absl::OkStatus();
    });
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace

bool IsRestrictedCanId(uint16_t id) {
  return id <= 0x07F || (id >= 0x101 && id <= 0x180) || (id >= 0x581 && id <= 0x5FF) ||
         (id >= 0x601 && id <= 0x67F) || (id >= 0x6E0 && id <= 0x6FF) || id >= 0x701;
}

absl::Status AddCommunicationObjects(ObjectDictionary& od, uint8_t node_id,
                                     const DeviceIdentity& identity) {
  if (absl::Status s = co::ValidateNodeId(node_id); !s.ok()) return s;
  std::vector<ObjectDef> defs;
  defs.push_back(
      Integer(0x1000, 0, "device type", DataType::kU32, Access::kConst, identity.device_type));
  // 1001h is commonly mapped into a TPDO (§7.5.2.2: PDO mapping optional).
  defs.push_back(Integer(0x1001, 0, "error register", DataType::kU8, Access::kRo).Mappable());
  defs.push_back(Integer(0x1005, 0, "cob-id sync", DataType::kU32, Access::kRw, co::kSyncCobId));
  defs.push_back(String(0x1008, 0, "manufacturer device name", identity.device_name));
  defs.push_back(String(0x1009, 0, "manufacturer hardware version", identity.hardware_version));
  defs.push_back(String(0x100A, 0, "manufacturer software version", identity.software_version));
  defs.push_back(Integer(0x1014, 0, "cob-id emcy", DataType::kU32, Access::kRw, 0x80 + node_id));
  defs.push_back(Integer(0x1017, 0, "producer heartbeat time", DataType::kU16));
  defs.push_back(
      Integer(0x1018, 0, "identity highest sub-index", DataType::kU8, Access::kConst, 4));
  defs.push_back(
      Integer(0x1018, 1, "vendor-id", DataType::kU32, Access::kConst, identity.vendor_id));
  defs.push_back(
      Integer(0x1018, 2, "product code", DataType::kU32, Access::kConst, identity.product_code));
  defs.push_back(
      Integer(0x1018, 3, "revision number", DataType::kU32, Access::kConst, identity.revision));
  defs.push_back(
      Integer(0x1018, 4, "serial number", DataType::kU32, Access::kConst, identity.serial_number));
  defs.push_back(
      Integer(0x1029, 0, "error behaviour highest sub-index", DataType::kU8, Access::kConst, 1));
  defs.push_back(Integer(0x1029, 1, "communication error", DataType::kU8, Access::kRw,
                         static_cast<int64_t>(ErrorBehaviour::kPreOperational))
                     .Range(0, static_cast<int64_t>(ErrorBehaviour::kStopped)));
  // 1200h: the default server SDO channel, read-only (§7.5.2.33).
  defs.push_back(
      Integer(0x1200, 0, "sdo server highest sub-index", DataType::kU8, Access::kConst, 2));
  defs.push_back(Integer(0x1200, 1, "sdo cob-id client to server", DataType::kU32, Access::kConst,
                         0x600 + node_id));
  defs.push_back(Integer(0x1200, 2, "sdo cob-id server to client", DataType::kU32, Access::kConst,
                         0x580 + node_id));
  for (ObjectDef& d : defs) {
    if (absl::Status s = od.Add(std::move(d)); !s.ok()) return s;
  }
  if (absl::Status s = AddErrorHistory(od); !s.ok()) return s;
  if (absl::Status s = AddHeartbeatConsumers(od); !s.ok()) return s;

  ObjectDictionary* dict = &od;
  // 1005h (§7.5.2.5): this slave only consumes SYNC, so bit 30 (generate) is refused, as are
  // 29-bit identifiers and bits 11..28 (decision 1124).
  absl::Status s = od.OnWriteInt(0x1005, 0, [](int64_t raw) -> absl::Status {
    const auto v = static_cast<uint32_t>(raw);
    if ((v & kCobIdBit30) != 0) {
      return Invalid(
          absl::StrFormat("1005h cob-id sync 0x%08X: bit 30 set, this node cannot "
                          "produce SYNC",
                          v));
    }
    if ((v & 0x3FFFF800) != 0) {
      return Invalid(absl::StrFormat("1005h cob-id sync 0x%08X: bits 11..29 must be 0", v));
    }
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  // 1014h (§7.5.2.17): bits 11..30 zero, identifier fixed while valid.
  s = od.OnWriteInt(0x1014, 0, [dict](int64_t raw) -> absl::Status {
    const auto v = static_cast<uint32_t>(raw);
    if ((v & 0x7FFFF800) != 0) {
      return Invalid(absl::StrFormat("1014h cob-id emcy 0x%08X: bits 11..30 must be 0", v));
    }
    const auto old = static_cast<uint32_t>(dict->GetInt(0x1014, 0).value_or(0));
    if ((v & kCobIdInvalid) == 0 && (old & kCobIdInvalid) == 0 && (old & 0x7FF) != (v & 0x7FF)) {
      return Invalid(
          absl::StrFormat("1014h cob-id emcy 0x%08X: identifier changes only while "
                          "bit 31 is set",
                          v));
    }
    if ((v & kCobIdInvalid) == 0 && IsRestrictedCanId(v & 0x7FF)) {
      return Invalid(absl::StrFormat("1014h cob-id emcy 0x%08X: identifier restricted", v));
    }
    return absl::OkStatus();
  });
  if (!s.ok()) return s;

  for (uint16_t n = 1; n <= kPdoCount; ++n) {
    if (absl::Status a = AddPdo(od, PdoKind::kRpdo, n, node_id); !a.ok()) return a;
    if (absl::Status a = AddPdo(od, PdoKind::kTpdo, n, node_id); !a.ok()) return a;
  }
  return absl::OkStatus();
}

absl::StatusOr<PdoConfig> ReadPdoConfig(const ObjectDictionary& od, PdoKind kind, uint16_t number) {
  if (number < 1 || number > kPdoCount) {
    return absl::InvalidArgumentError(
        absl::StrCat(KindName(kind), " number ", number, " outside 1..", kPdoCount));
  }
  const uint16_t comm = CommIndex(kind, number);
  const uint16_t map = MapIndex(kind, number);
  PdoConfig c;
  c.kind = kind;
  c.number = number;
  auto cob = od.GetInt(comm, 1);
  auto type = od.GetInt(comm, 2);
  auto event = od.GetInt(comm, 5);
  auto count = od.GetInt(map, 0);
  if (!cob.ok() || !type.ok() || !event.ok() || !count.ok()) {
    return absl::InternalError(
        absl::StrFormat("%04Xh/%04Xh: communication objects missing", comm, map));
  }
  const auto v = static_cast<uint32_t>(*cob);
  c.valid = (v & kCobIdInvalid) == 0;
  c.can_id = static_cast<uint16_t>(v & 0x7FF);
  c.rtr_allowed = kind == PdoKind::kTpdo && (v & kCobIdBit30) == 0;
  c.transmission_type = static_cast<uint8_t>(*type);
  c.event_ms = static_cast<uint16_t>(*event);
  if (kind == PdoKind::kTpdo)
    c.inhibit_100us = static_cast<uint16_t>(od.GetInt(comm, 3).value_or(0));
  for (uint8_t sub = 1; sub <= *count && sub <= kPdoMappingEntries; ++sub) {
    c.mapping.push_back(
        co::DecodeMappingEntry(static_cast<uint32_t>(od.GetInt(map, sub).value_or(0))));
  }
  return c;
}

absl::Status SetDefaultPdo(ObjectDictionary& od, PdoKind kind, uint16_t number, uint8_t node_id,
                           const co::PdoCommParams& comm,
                           std::span<const co::PdoMappingEntry> mapping) {
  const std::string what = absl::StrCat(KindName(kind), number);
  if (number < 1 || number > kPdoCount) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": number outside 1..", kPdoCount));
  }
  if (mapping.size() > kPdoMappingEntries) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ".mapping: ", mapping.size(), " entries exceed ", kPdoMappingEntries));
  }
  if (absl::Status s = co::ValidateMapping(mapping); !s.ok()) return s;
  if (absl::Status s = co::ValidateCommParams(kind, comm); !s.ok()) return s;
  for (size_t i = 0; i < mapping.size(); ++i) {
    if (absl::Status s = od.CheckMappable(kind, mapping[i]); !s.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, ".mapping[", i, "]: ", std::string(s.message())));
    }
  }
  uint16_t id = comm.cob_id;
  if (id == 0) {
    auto predefined = co::DefaultPdoCobId(kind, number, node_id);
    if (!predefined.ok()) return predefined.status();
    id = *predefined;
  }
  if (comm.valid && (IsRestrictedCanId(id) || mapping.empty())) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.cob_id: 0x%03X restricted or no mapped object for a valid PDO", what, id));
  }
  const uint16_t ci = CommIndex(kind, number);
  const uint16_t mi = MapIndex(kind, number);
  uint32_t cob = id;
  if (!comm.valid) cob |= kCobIdInvalid;
  if (kind == PdoKind::kTpdo) cob |= kCobIdBit30;
  absl::Status s = od.SetDefaultInt(ci, 1, cob);
  if (s.ok()) s = od.SetDefaultInt(ci, 2, comm.transmission_type);
  if (s.ok() && kind == PdoKind::kTpdo) s = od.SetDefaultInt(ci, 3, comm.inhibit_time_100us);
  if (s.ok()) s = od.SetDefaultInt(ci, 5, comm.event_timer_ms);
  if (s.ok()) s = od.SetDefaultInt(mi, 0, static_cast<int64_t>(mapping.size()));
  for (uint8_t i = 1; s.ok() && i <= kPdoMappingEntries; ++i) {
    const uint32_t raw = i <= mapping.size() ? co::EncodeMappingEntry(mapping[i - 1]) : 0;
    s = od.SetDefaultInt(mi, i, raw);
  }
  return s;
}

std::vector<HeartbeatConsumer> ReadHeartbeatConsumers(const ObjectDictionary& od) {
  std::vector<HeartbeatConsumer> out;
  for (uint8_t i = 1; i <= kHeartbeatConsumerCount; ++i) {
    const auto v = static_cast<uint32_t>(od.GetInt(0x1016, i).value_or(0));
    HeartbeatConsumer c{i, static_cast<uint8_t>(v >> 16), static_cast<uint16_t>(v)};
    if (c.node != 0 && c.time_ms != 0) out.push_back(c);
  }
  return out;
}

}  // namespace drivegw::sim::canopen
