// ObjectDictionary: typed entries, access rules, hooks and the SDO abort code of every refusal
// (CiA 301 v4.2.0 §7.4, Table 22; decisions 1121, 1122).
#include "sim/canopen/object_dictionary.h"

#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::sim::canopen {
namespace {

using drivegw::canopen::PdoKind;
using drivegw::canopen::PdoMappingEntry;
using drivegw::canopen::SdoAbortStatus;

struct IntLimits {
  int64_t lo;
  int64_t hi;
};
// The u64 type's limits are not representable here; EncodeInteger accepts every pattern.
IntLimits TypeLimits(DataType type) {
  switch (type) {
    case DataType::kU8:
      return {0, 0xFF};
    case DataType::kI8:
      return {-128, 127};
    case DataType::kU16:
      return {0, 0xFFFF};
    case DataType::kI16:
      return {-32768, 32767};
    case DataType::kU32:
      return {0, 0xFFFFFFFFll};
    case DataType::kI32:
      return {std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max()};
    default:
      return {std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max()};
  }
}

// a < b in the type's order (u64: unsigned).
bool Less(DataType type, int64_t a, int64_t b) {
  if (type == DataType::kU64) return static_cast<uint64_t>(a) < static_cast<uint64_t>(b);
  return a < b;
}

std::string FormatValue(DataType type, int64_t v) {
  if (type == DataType::kU64) return absl::StrCat(static_cast<uint64_t>(v));
  return absl::StrCat(v);
}

// CiA 301 §7.4.7.1: dummy mapping of the basic types 0001h..0007h (RPDO only).
std::optional<uint8_t> DummyBits(uint16_t index) {
  switch (index) {
    case 0x0001:
      return 1;  // BOOLEAN
    case 0x0002:
    case 0x0005:
      return 8;  // INTEGER8, UNSIGNED8
    case 0x0003:
    case 0x0006:
      return 16;  // INTEGER16, UNSIGNED16
    case 0x0004:
    case 0x0007:
      return 32;  // INTEGER32, UNSIGNED32
    default:
      return std::nullopt;
  }
}

}  // namespace

std::string_view DataTypeName(DataType type) {
  switch (type) {
    case DataType::kU8:
      return "u8";
    case DataType::kI8:
      return "i8";
    case DataType::kU16:
      return "u16";
    case DataType::kI16:
      return "i16";
    case DataType::kU32:
      return "u32";
    case DataType::kI32:
      return "i32";
    case DataType::kU64:
      return "u64";
    case DataType::kString:
      return "string";
    case DataType::kDomain:
      return "domain";
  }
  return "unknown";
}

size_t DataTypeSize(DataType type) {
  switch (type) {
    case DataType::kU8:
    case DataType::kI8:
      return 1;
    case DataType::kU16:
    case DataType::kI16:
      return 2;
    case DataType::kU32:
    case DataType::kI32:
      return 4;
    case DataType::kU64:
      return 8;
    case DataType::kString:
    case DataType::kDomain:
      return 0;
  }
  return 0;
}

bool IsInteger(DataType type) { return DataTypeSize(type) != 0; }

bool IsSigned(DataType type) {
  return type == DataType::kI8 || type == DataType::kI16 || type == DataType::kI32;
}

std::string_view AccessName(Access access) {
  switch (access) {
    case Access::kRo:
      return "ro";
    case Access::kWo:
      return "wo";
    case Access::kRw:
      return "rw";
    case Access::kConst:
      return "const";
  }
  return "unknown";
}

bool IsReadable(Access access) { return access != Access::kWo; }
bool IsWritable(Access access) { return access == Access::kWo || access == Access::kRw; }

absl::StatusOr<std::vector<uint8_t>> EncodeInteger(DataType type, int64_t value) {
  const size_t size = DataTypeSize(type);
  if (size == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(DataTypeName(type)), " is no integer type"));
  }
  if (type != DataType::kU64) {
    const IntLimits l = TypeLimits(type);
    if (value < l.lo || value > l.hi) {
      return absl::InvalidArgumentError(absl::StrCat(std::string(DataTypeName(type)), " value ",
                                                     value, " outside ", l.lo, "..", l.hi));
    }
  }
  std::vector<uint8_t> out(size);
  const auto bits = static_cast<uint64_t>(value);
  for (size_t i = 0; i < size; ++i) out[i] = static_cast<uint8_t>(bits >> (8 * i));
  return out;
}

absl::StatusOr<int64_t> DecodeInteger(DataType type, std::span<const uint8_t> bytes) {
  const size_t size = DataTypeSize(type);
  if (size == 0 || bytes.size() != size) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(DataTypeName(type)), ": ", bytes.size(), " bytes, need ", size));
  }
  uint64_t bits = 0;
  for (size_t i = 0; i < size; ++i) bits |= static_cast<uint64_t>(bytes[i]) << (8 * i);
  if (IsSigned(type)) {
    const unsigned shift = static_cast<unsigned>(64 - 8 * size);
    return static_cast<int64_t>(bits << shift) >> shift;  // sign extension
  }
  return static_cast<int64_t>(bits);
}

ObjectDef Integer(uint16_t index, uint8_t sub, std::string name, DataType type, Access access,
                  int64_t default_value) {
  ObjectDef d;
  d.index = index;
  d.sub = sub;
  d.name = std::move(name);
  d.type = type;
  d.access = access;
  d.default_int = default_value;
  return d;
}

ObjectDef String(uint16_t index, uint8_t sub, std::string name, std::string_view default_value,
                 Access access) {
  ObjectDef d;
  d.index = index;
  d.sub = sub;
  d.name = std::move(name);
  d.type = DataType::kString;
  d.access = access;
  d.default_bytes.assign(default_value.begin(), default_value.end());
  return d;
}

ObjectDef Domain(uint16_t index, uint8_t sub, std::string name, Access access) {
  ObjectDef d;
  d.index = index;
  d.sub = sub;
  d.name = std::move(name);
  d.type = DataType::kDomain;
  d.access = access;
  return d;
}

std::string ObjectLabel(uint16_t index, uint8_t sub, std::string_view name) {
  std::string label = absl::StrFormat("%04Xh:%02X", index, sub);
  if (!name.empty()) absl::StrAppend(&label, " ", std::string(name));
  return label;
}

absl::Status ObjectDictionary::Add(ObjectDef def) {
  const std::string label = ObjectLabel(def.index, def.sub, def.name);
  if (entries_.contains(Key(def.index, def.sub))) {
    return absl::AlreadyExistsError(absl::StrCat("object ", label, ": already in the dictionary"));
  }
  Entry e;
  if (IsInteger(def.type)) {
    if (def.min && def.max && Less(def.type, *def.max, *def.min)) {
      return absl::InvalidArgumentError(
          absl::StrCat("object ", label, ".min: ", FormatValue(def.type, *def.min), " above max ",
                       FormatValue(def.type, *def.max)));
    }
    auto bytes = EncodeInteger(def.type, def.default_int);
    if (!bytes.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("object ", label, ".default: ", bytes.status().message()));
    }
    if ((def.min && Less(def.type, def.default_int, *def.min)) ||
        (def.max && Less(def.type, *def.max, def.default_int))) {
      return absl::InvalidArgumentError(
          absl::StrCat("object ", label, ".default: ", FormatValue(def.type, def.default_int),
                       " outside min..max"));
    }
    e.value = *std::move(bytes);
  } else {
    if (def.min || def.max) {
      return absl::InvalidArgumentError(absl::StrCat("object ", label,
                                                     ": min/max need an integer type, not ",
                                                     std::string(DataTypeName(def.type))));
    }
    if (def.max_size == 0) def.max_size = drivegw::canopen::kSdoDefaultMaxSize;
    if (def.default_bytes.size() > def.max_size) {
      return absl::InvalidArgumentError(absl::StrCat("object ", label,
                                                     ".default: ", def.default_bytes.size(),
                                                     " bytes exceed max_size ", def.max_size));
    }
    e.value = def.default_bytes;
  }
  e.def = std::move(def);
  entries_.emplace(Key(e.def.index, e.def.sub), std::move(e));
  return absl::OkStatus();
}

bool ObjectDictionary::Contains(uint16_t index) const {
  auto it = entries_.lower_bound(Key(index, 0));
  return it != entries_.end() && it->second.def.index == index;
}

bool ObjectDictionary::Contains(uint16_t index, uint8_t sub) const {
  return entries_.contains(Key(index, sub));
}

const ObjectDef* ObjectDictionary::Find(uint16_t index, uint8_t sub) const {
  auto it = entries_.find(Key(index, sub));
  return it == entries_.end() ? nullptr : &it->second.def;
}

std::vector<const ObjectDef*> ObjectDictionary::Objects() const {
  std::vector<const ObjectDef*> out;
  out.reserve(entries_.size());
  for (const auto& [key, e] : entries_) out.push_back(&e.def);
  return out;
}

absl::StatusOr<const ObjectDictionary::Entry*> ObjectDictionary::Lookup(uint16_t index,
                                                                        uint8_t sub) const {
  auto it = entries_.find(Key(index, sub));
  if (it != entries_.end()) return &it->second;
  // Table 22 tells the two cases apart: the index or only the sub-index is missing.
  if (!Contains(index)) {
    return SdoAbortStatus(SdoAbortCode::kNoObject, absl::StrFormat("object %04Xh", index));
  }
  return SdoAbortStatus(SdoAbortCode::kNoSubIndex, ObjectLabel(index, sub));
}

absl::StatusOr<ObjectDictionary::Entry*> ObjectDictionary::Lookup(uint16_t index, uint8_t sub) {
  auto found = std::as_const(*this).Lookup(index, sub);
  if (!found.ok()) return found.status();
  return const_cast<Entry*>(*found);
}

absl::StatusOr<std::vector<uint8_t>> ObjectDictionary::Read(uint16_t index, uint8_t sub) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  Entry& entry = **e;
  if (!IsReadable(entry.def.access)) {
    return SdoAbortStatus(SdoAbortCode::kWriteOnly,
                          ObjectLabel(index, sub, entry.def.name) + " is write-only");
  }
  if (entry.read) {
    auto value = entry.read();
    if (!value.ok()) return value.status();
    // A hook returning the wrong width is a model bug; serve it as a device incompatibility.
    if (IsInteger(entry.def.type) && value->size() != DataTypeSize(entry.def.type)) {
      return SdoAbortStatus(
          SdoAbortCode::kInternalIncompatible,
          absl::StrCat(ObjectLabel(index, sub, entry.def.name), ": read hook returned ",
                       value->size(), " bytes for ", std::string(DataTypeName(entry.def.type))));
    }
    entry.value = *std::move(value);
  }
  return entry.value;
}

absl::Status ObjectDictionary::CheckRange(const Entry& e, int64_t value) const {
  const ObjectDef& d = e.def;
  if (d.max && Less(d.type, *d.max, value)) {
    return SdoAbortStatus(
        SdoAbortCode::kValueTooHigh,
        absl::StrCat(ObjectLabel(d.index, d.sub, d.name), ": value ", FormatValue(d.type, value),
                     " above max ", FormatValue(d.type, *d.max)));
  }
  if (d.min && Less(d.type, value, *d.min)) {
    return SdoAbortStatus(
        SdoAbortCode::kValueTooLow,
        absl::StrCat(ObjectLabel(d.index, d.sub, d.name), ": value ", FormatValue(d.type, value),
                     " below min ", FormatValue(d.type, *d.min)));
  }
  return absl::OkStatus();
}

absl::Status ObjectDictionary::Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  Entry& entry = **e;
  const ObjectDef& d = entry.def;
  const std::string label = ObjectLabel(index, sub, d.name);
  if (!IsWritable(d.access)) {
    return SdoAbortStatus(SdoAbortCode::kReadOnly,
                          absl::StrCat(label, " is ", std::string(AccessName(d.access))));
  }
  if (IsInteger(d.type)) {
    const size_t size = DataTypeSize(d.type);
    if (data.size() != size) {
      return SdoAbortStatus(
          data.size() > size ? SdoAbortCode::kLengthTooHigh : SdoAbortCode::kLengthTooLow,
          absl::StrCat(label, ": ", data.size(), " bytes, ", std::string(DataTypeName(d.type)),
                       " has ", size));
    }
    const int64_t value = DecodeInteger(d.type, data).value_or(0);
    if (absl::Status s = CheckRange(entry, value); !s.ok()) return s;
  } else if (data.size() > d.max_size) {
    return SdoAbortStatus(SdoAbortCode::kLengthTooHigh,
                          absl::StrCat(label, ": ", data.size(), " bytes exceed ", d.max_size));
  }
  if (entry.write) {
    if (absl::Status s = entry.write(data); !s.ok()) return s;
  }
  entry.value.assign(data.begin(), data.end());
  // Observers may read the dictionary (not add entries): the loop does not touch `entry`.
  for (const auto& observer : observers_) observer(index, sub);
  return absl::OkStatus();
}

absl::StatusOr<int64_t> ObjectDictionary::GetInt(uint16_t index, uint8_t sub) const {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  if (!IsInteger((*e)->def.type)) {
    return absl::InvalidArgumentError(absl::StrCat(ObjectLabel(index, sub, (*e)->def.name),
                                                   " is a ",
                                                   std::string(DataTypeName((*e)->def.type))));
  }
  return DecodeInteger((*e)->def.type, (*e)->value);
}

absl::StatusOr<std::vector<uint8_t>> ObjectDictionary::GetBytes(uint16_t index, uint8_t sub) const {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  return (*e)->value;
}

absl::StatusOr<std::string> ObjectDictionary::GetString(uint16_t index, uint8_t sub) const {
  auto bytes = GetBytes(index, sub);
  if (!bytes.ok()) return bytes.status();
  return std::string(bytes->begin(), bytes->end());
}

absl::Status ObjectDictionary::SetInt(uint16_t index, uint8_t sub, int64_t value) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  auto bytes = EncodeInteger((*e)->def.type, value);
  if (!bytes.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(ObjectLabel(index, sub, (*e)->def.name), ": ", bytes.status().message()));
  }
  (*e)->value = *std::move(bytes);
  return absl::OkStatus();
}

absl::Status ObjectDictionary::SetBytes(uint16_t index, uint8_t sub,
                                        std::span<const uint8_t> bytes) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return e.status();
  const ObjectDef& d = (*e)->def;
  const size_t size = DataTypeSize(d.type);
  if ((size != 0 && bytes.size() != size) || (size == 0 && bytes.size() > d.max_size)) {
    return absl::InvalidArgumentError(absl::StrCat(ObjectLabel(index, sub, d.name), ": ",
                                                   bytes.size(), " bytes do not fit ",
                                                   std::string(DataTypeName(d.type))));
  }
  (*e)->value.assign(bytes.begin(), bytes.end());
  return absl::OkStatus();
}

absl::Status ObjectDictionary::SetString(uint16_t index, uint8_t sub, std::string_view value) {
  const auto* p = reinterpret_cast<const uint8_t*>(value.data());
  return SetBytes(index, sub, std::span<const uint8_t>(p, value.size()));
}

absl::Status ObjectDictionary::SetDefaultInt(uint16_t index, uint8_t sub, int64_t value) {
  if (absl::Status s = SetInt(index, sub, value); !s.ok()) return s;
  entries_.at(Key(index, sub)).def.default_int = value;
  return absl::OkStatus();
}

absl::Status ObjectDictionary::OnRead(uint16_t index, uint8_t sub, ReadHook hook) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return absl::NotFoundError(std::string(e.status().message()));
  (*e)->read = std::move(hook);
  return absl::OkStatus();
}

absl::StatusOr<ObjectDictionary::Entry*> ObjectDictionary::LookupIntegerHook(uint16_t index,
                                                                             uint8_t sub) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return absl::NotFoundError(std::string(e.status().message()));
  const DataType type = (*e)->def.type;
  if (!IsInteger(type)) {
    return absl::InvalidArgumentError(absl::StrCat(ObjectLabel(index, sub, (*e)->def.name),
                                                   ": integer hook on a ",
                                                   std::string(DataTypeName(type))));
  }
  return e;
}

absl::Status ObjectDictionary::OnReadInt(uint16_t index, uint8_t sub, ReadIntHook hook) {
  auto e = LookupIntegerHook(index, sub);
  if (!e.ok()) return e.status();
  const DataType type = (*e)->def.type;
  const std::string label = ObjectLabel(index, sub, (*e)->def.name);
  (*e)->read = [type, label, hook = std::move(hook)]() -> absl::StatusOr<std::vector<uint8_t>> {
    auto v = hook();
    if (!v.ok()) return v.status();
    auto bytes = EncodeInteger(type, *v);
    if (!bytes.ok()) {
      return SdoAbortStatus(SdoAbortCode::kInternalIncompatible,
                            absl::StrCat(label, ": read hook ", bytes.status().message()));
    }
    return bytes;
  };
  return absl::OkStatus();
}

absl::Status ObjectDictionary::OnWrite(uint16_t index, uint8_t sub, WriteHook hook) {
  auto e = Lookup(index, sub);
  if (!e.ok()) return absl::NotFoundError(std::string(e.status().message()));
  (*e)->write = std::move(hook);
  return absl::OkStatus();
}

absl::Status ObjectDictionary::OnWriteInt(uint16_t index, uint8_t sub, WriteIntHook hook) {
  auto e = LookupIntegerHook(index, sub);
  if (!e.ok()) return e.status();
  const DataType type = (*e)->def.type;
  // Write() has checked the length already, so decoding cannot fail here.
  (*e)->write = [type, hook = std::move(hook)](std::span<const uint8_t> bytes) {
    return hook(DecodeInteger(type, bytes).value_or(0));
  };
  return absl::OkStatus();
}

void ObjectDictionary::AddWriteObserver(WriteObserver observer) {
  observers_.push_back(std::move(observer));
}

void ObjectDictionary::ResetToDefaults(uint16_t first, uint16_t last) {
  for (auto it = entries_.lower_bound(Key(first, 0)); it != entries_.end(); ++it) {
    Entry& e = it->second;
    if (e.def.index > last) break;
    if (e.def.access == Access::kConst) continue;
    if (IsInteger(e.def.type)) {
      e.value = EncodeInteger(e.def.type, e.def.default_int).value_or(e.value);
    } else {
      e.value = e.def.default_bytes;
    }
  }
}

absl::Status ObjectDictionary::CheckMappable(PdoKind kind, PdoMappingEntry m) const {
  const std::string what = absl::StrFormat("mapping %04Xh:%02X/%d bits", m.index, m.sub, m.bits);
  if (kind == PdoKind::kRpdo && m.sub == 0) {
    if (auto dummy = DummyBits(m.index)) {
      if (*dummy == m.bits) return absl::OkStatus();
      return SdoAbortStatus(SdoAbortCode::kNotMappable,
                            absl::StrCat(what, ": dummy entry has ", *dummy, " bits"));
    }
  }
  auto e = Lookup(m.index, m.sub);
  if (!e.ok()) {
    // §7.5.2.36: an entry naming a missing object is refused with 0602 0000h, whether the
    // index or only the sub-index is missing.
    return SdoAbortStatus(SdoAbortCode::kNoObject, absl::StrCat(what, ": no such object"));
  }
  const ObjectDef& d = (*e)->def;
  const std::string label = absl::StrCat(what, " (", ObjectLabel(d.index, d.sub, d.name), ")");
  if (!d.pdo_mappable) {
    return SdoAbortStatus(SdoAbortCode::kNotMappable, absl::StrCat(label, ": not PDO-mappable"));
  }
  const bool access_ok = kind == PdoKind::kTpdo ? IsReadable(d.access) : IsWritable(d.access);
  if (!access_ok) {
    return SdoAbortStatus(
        SdoAbortCode::kNotMappable,
        absl::StrCat(label, ": ", std::string(AccessName(d.access)), " cannot be mapped into ",
                     kind == PdoKind::kTpdo ? "a TPDO" : "an RPDO"));
  }
  if (!IsInteger(d.type) || DataTypeSize(d.type) * 8 != m.bits) {
    return SdoAbortStatus(SdoAbortCode::kNotMappable,
                          absl::StrCat(label, ": ", std::string(DataTypeName(d.type)), " needs ",
                                       DataTypeSize(d.type) * 8, " bits"));
  }
  return absl::OkStatus();
}

}  // namespace drivegw::sim::canopen
