// PDO mapping, packing and the configuration sequence (CiA 301 v4.2.0 §7.2.2, §7.5.2.35-38).
#include "adapters/canopen/pdo.h"

#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"

namespace drivegw::canopen {
namespace {

std::string EntryName(size_t i, const PdoMappingEntry& e) {
  return absl::StrFormat("canopen pdo mapping[%d] %04Xh:%02X", i, e.index, e.sub);
}

std::string PdoName(PdoKind kind, uint16_t number) {
  return absl::StrCat(kind == PdoKind::kRpdo ? "rpdo" : "tpdo", number);
}

uint64_t WidthMask(size_t bits) { return bits >= 64 ? ~uint64_t{0} : (uint64_t{1} << bits) - 1; }

template <typename T>
std::vector<uint8_t> Le(T value) {
  std::vector<uint8_t> out(sizeof(T));
  for (size_t i = 0; i < sizeof(T); ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
  return out;
}

struct TypeSpec {
  PdoType type;
  const char* name;
  uint8_t bits;
  bool is_signed;
};
constexpr TypeSpec kTypes[] = {
    {PdoType::kU8, "u8", 8, false},    {PdoType::kI8, "i8", 8, true},
    {PdoType::kU16, "u16", 16, false}, {PdoType::kI16, "i16", 16, true},
    {PdoType::kU32, "u32", 32, false}, {PdoType::kI32, "i32", 32, true},
};
const TypeSpec& SpecOf(PdoType type) {
  for (const TypeSpec& t : kTypes) {
    if (t.type == type) return t;
  }
  return kTypes[0];
}

}  // namespace

absl::Status ValidateMapping(std::span<const PdoMappingEntry> mapping) {
  if (mapping.size() > kPdoMaxEntries) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen pdo mapping: ", mapping.size(), " entries exceed ", kPdoMaxEntries));
  }
  size_t total = 0;
  for (size_t i = 0; i < mapping.size(); ++i) {
    if (mapping[i].bits < 1 || mapping[i].bits > kPdoMaxBits) {
      return absl::InvalidArgumentError(absl::StrCat(
          "canopen pdo mapping[", i, "].bits: ", mapping[i].bits, " outside 1..", kPdoMaxBits));
    }
    total += mapping[i].bits;
  }
  if (total > kPdoMaxBits) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen pdo mapping: ", total, " bits exceed ", kPdoMaxBits));
  }
  return absl::OkStatus();
}

size_t MappingBits(std::span<const PdoMappingEntry> mapping) {
  size_t total = 0;
  for (const PdoMappingEntry& e : mapping) total += e.bits;
  return total;
}

size_t MappingBytes(std::span<const PdoMappingEntry> mapping) {
  return (MappingBits(mapping) + 7) / 8;
}

absl::StatusOr<std::vector<uint8_t>> PackPdoRaw(std::span<const PdoMappingEntry> mapping,
                                                std::span<const uint64_t> values) {
  if (auto s = ValidateMapping(mapping); !s.ok()) return s;
  if (values.size() != mapping.size()) {
    return absl::InvalidArgumentError(absl::StrCat("canopen pdo values: ", values.size(),
                                                   " values for ", mapping.size(), " entries"));
  }
  // Entries are packed LSB first without gaps (§7.2.2.1: the mapped objects follow each other
  // in the order of the mapping sub-indices, little-endian).
  uint64_t word = 0;
  size_t bit = 0;
  for (size_t i = 0; i < mapping.size(); ++i) {
    const size_t bits = mapping[i].bits;
    if ((values[i] & ~WidthMask(bits)) != 0) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: value 0x%X exceeds %d bits",
                                                        EntryName(i, mapping[i]), values[i], bits));
    }
    word |= values[i] << bit;
    bit += bits;
  }
  std::vector<uint8_t> out(MappingBytes(mapping));
  for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint8_t>(word >> (8 * i));
  return out;
}

absl::StatusOr<std::vector<uint64_t>> UnpackPdoRaw(std::span<const PdoMappingEntry> mapping,
                                                   std::span<const uint8_t> payload) {
  if (auto s = ValidateMapping(mapping); !s.ok()) return s;
  const size_t need = MappingBytes(mapping);
  if (payload.size() < need) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen pdo payload: ", payload.size(), " bytes, mapping needs ", need));
  }
  uint64_t word = 0;
  for (size_t i = 0; i < need; ++i) word |= static_cast<uint64_t>(payload[i]) << (8 * i);
  std::vector<uint64_t> out;
  out.reserve(mapping.size());
  size_t bit = 0;
  for (const PdoMappingEntry& e : mapping) {
    out.push_back(bit >= 64 ? 0 : (word >> bit) & WidthMask(e.bits));
    bit += e.bits;
  }
  return out;
}

uint8_t PdoTypeBits(PdoType type) { return SpecOf(type).bits; }
std::string_view PdoTypeName(PdoType type) { return SpecOf(type).name; }

absl::StatusOr<std::vector<uint8_t>> PackPdo(std::span<const PdoMappingEntry> mapping,
                                             std::span<const PdoValue> values) {
  if (values.size() != mapping.size()) {
    return absl::InvalidArgumentError(absl::StrCat("canopen pdo values: ", values.size(),
                                                   " values for ", mapping.size(), " entries"));
  }
  std::vector<uint64_t> raw(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const TypeSpec& t = SpecOf(values[i].type);
    if (t.bits != mapping[i].bits) {
      return absl::InvalidArgumentError(absl::StrCat(EntryName(i, mapping[i]), ": ", t.name,
                                                     " needs ", t.bits, " bits, entry maps ",
                                                     mapping[i].bits));
    }
    const int64_t min = t.is_signed ? -(int64_t{1} << (t.bits - 1)) : 0;
    const int64_t max = t.is_signed ? (int64_t{1} << (t.bits - 1)) - 1 : (int64_t{1} << t.bits) - 1;
    if (values[i].value < min || values[i].value > max) {
      return absl::InvalidArgumentError(absl::StrCat(EntryName(i, mapping[i]), ": ", t.name,
                                                     " value ", values[i].value, " outside ", min,
                                                     "..", max));
    }
    raw[i] = static_cast<uint64_t>(values[i].value) & WidthMask(t.bits);
  }
  return PackPdoRaw(mapping, raw);
}

absl::StatusOr<std::vector<PdoValue>> UnpackPdo(std::span<const PdoMappingEntry> mapping,
                                                std::span<const PdoType> types,
                                                std::span<const uint8_t> payload) {
  if (types.size() != mapping.size()) {
    return absl::InvalidArgumentError(absl::StrCat("canopen pdo types: ", types.size(),
                                                   " types for ", mapping.size(), " entries"));
  }
  for (size_t i = 0; i < types.size(); ++i) {
    const TypeSpec& t = SpecOf(types[i]);
    if (t.bits != mapping[i].bits) {
      return absl::InvalidArgumentError(absl::StrCat(EntryName(i, mapping[i]), ": ", t.name,
                                                     " needs ", t.bits, " bits, entry maps ",
                                                     mapping[i].bits));
    }
  }
  auto raw = UnpackPdoRaw(mapping, payload);
  if (!raw.ok()) return raw.status();
  std::vector<PdoValue> out;
  out.reserve(raw->size());
  for (size_t i = 0; i < raw->size(); ++i) {
    const TypeSpec& t = SpecOf(types[i]);
    int64_t v = static_cast<int64_t>((*raw)[i]);
    if (t.is_signed && ((*raw)[i] >> (t.bits - 1)) != 0) v -= int64_t{1} << t.bits;
    out.push_back(PdoValue{types[i], v});
  }
  return out;
}

absl::Status ValidateCommParams(PdoKind kind, const PdoCommParams& comm) {
  const uint8_t t = comm.transmission_type;
  if (t > kTransmissionSyncEveryMax && t < kTransmissionSyncRtr) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen ", kind == PdoKind::kRpdo ? "rpdo" : "tpdo",
                     ".transmission_type: ", t, " is reserved (241..251)"));
  }
  if (kind == PdoKind::kRpdo && (t == kTransmissionSyncRtr || t == kTransmissionEventRtr)) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen rpdo.transmission_type: ", t, " is TPDO-only (RTR)"));
  }
  if (comm.cob_id > kMaxCobId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen %s.cob_id: 0x%X exceeds 0x7FF (11-bit base format)",
                        kind == PdoKind::kRpdo ? "rpdo" : "tpdo", comm.cob_id));
  }
  return absl::OkStatus();
}

absl::StatusOr<uint16_t> DefaultPdoCobId(PdoKind kind, uint16_t number, uint8_t node) {
  if (number < 1 || number > 4) {
    return absl::InvalidArgumentError(absl::StrCat("canopen ", PdoName(kind, number),
                                                   ": the predefined set covers PDO 1..4 only"));
  }
  if (auto s = ValidateNodeId(node, absl::StrCat(PdoName(kind, number), ".node_id")); !s.ok()) {
    return s;
  }
  const uint16_t base = kind == PdoKind::kTpdo ? 0x180 : 0x200;
  return static_cast<uint16_t>(base + 0x100 * (number - 1) + node);
}

uint16_t PdoCommIndex(PdoKind kind, uint16_t number) {
  return static_cast<uint16_t>((kind == PdoKind::kRpdo ? 0x1400 : 0x1800) + number - 1);
}

uint16_t PdoMappingIndex(PdoKind kind, uint16_t number) {
  return static_cast<uint16_t>((kind == PdoKind::kRpdo ? 0x1600 : 0x1A00) + number - 1);
}

absl::StatusOr<std::vector<SdoWrite>> MappingWrites(PdoKind kind, uint16_t number, uint8_t node,
                                                    const PdoCommParams& comm,
                                                    std::span<const PdoMappingEntry> mapping) {
  if (number < 1 || number > kPdoMaxNumber) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen pdo number: ", number, " outside 1..", kPdoMaxNumber));
  }
  if (auto s = ValidateNodeId(node, absl::StrCat(PdoName(kind, number), ".node_id")); !s.ok()) {
    return s;
  }
  if (auto s = ValidateCommParams(kind, comm); !s.ok()) return s;
  if (auto s = ValidateMapping(mapping); !s.ok()) return s;
  uint16_t id = comm.cob_id;
  if (id == 0) {
    auto d = DefaultPdoCobId(kind, number, node);
    if (!d.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("canopen ", PdoName(kind, number),
                                                     ".cob_id: 0 (predefined) needs PDO 1..4"));
    }
    id = *d;
  }
  // Bit 30 (TPDO): 1 = no RTR allowed; the gateway never polls PDOs by RTR (decision 1107).
  const uint32_t cob = id | (kind == PdoKind::kTpdo ? kPdoCobIdNoRtr : 0);
  const uint16_t ci = PdoCommIndex(kind, number);
  const uint16_t mi = PdoMappingIndex(kind, number);
  std::vector<SdoWrite> out;
  // §7.2.2.4 / Figure 17: the PDO must be invalid while its mapping and inhibit time change,
  // and the mapping count 0 while the entries change.
  out.push_back({ci, 1, Le<uint32_t>(cob | kPdoCobIdInvalid)});
  out.push_back({mi, 0, Le<uint8_t>(0)});
  for (size_t i = 0; i < mapping.size(); ++i) {
    out.push_back({mi, static_cast<uint8_t>(i + 1), Le<uint32_t>(EncodeMappingEntry(mapping[i]))});
  }
  out.push_back({mi, 0, Le<uint8_t>(static_cast<uint8_t>(mapping.size()))});
  out.push_back({ci, 2, Le<uint8_t>(comm.transmission_type)});
  if (kind == PdoKind::kTpdo) out.push_back({ci, 3, Le<uint16_t>(comm.inhibit_time_100us)});
  out.push_back({ci, 5, Le<uint16_t>(comm.event_timer_ms)});
  out.push_back({ci, 1, Le<uint32_t>(comm.valid ? cob : cob | kPdoCobIdInvalid)});
  return out;
}

}  // namespace drivegw::canopen
