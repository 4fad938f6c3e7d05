// ObjectDictionary: the typed object dictionary of a simulated CANopen slave (CiA 301 v4.2.0
// §7.4: index/sub-index addressing, data types, access attributes, PDO mapping attribute) with
// read/write hooks for the device model behind it, and the SDO abort code for every refusal
// (Table 22). Implements the protocol library's ObjectAccess so that canopen::SdoServer serves
// it directly. Generic: the CiA 301 communication objects are added by
// communication_objects.h, device profiles by the model (decisions 1121, 1122).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"

namespace drivegw::sim::canopen {

using drivegw::canopen::SdoAbortCode;

// CiA 301 §7.1.6 basic data types this simulator offers (UNSIGNED8..64, INTEGER8..32,
// VISIBLE_STRING, DOMAIN).
enum class DataType : uint8_t { kU8, kI8, kU16, kI16, kU32, kI32, kU64, kString, kDomain };
std::string_view DataTypeName(DataType type);  // "u8", ..., "string", "domain"
// Bytes of an integer type (1, 2, 4, 8); 0 for string and domain (variable size).
size_t DataTypeSize(DataType type);
bool IsInteger(DataType type);
bool IsSigned(DataType type);

// CiA 301 §7.4.5 access attributes. kConst is read-only and never changed by a reset either.
enum class Access : uint8_t { kRo, kWo, kRw, kConst };
std::string_view AccessName(Access access);  // "ro", "wo", "rw", "const"
bool IsReadable(Access access);
bool IsWritable(Access access);  // from the bus (SDO, RPDO)

// Integers travel as int64_t: signed types sign-extended, unsigned zero-extended, u64 as its
// bit pattern (limits of a u64 object compare unsigned).
// Little-endian bytes of `value` with the type's width; InvalidArgument when it does not fit
// ("u16 value 70000 outside 0..65535").
absl::StatusOr<std::vector<uint8_t>> EncodeInteger(DataType type, int64_t value);
// Exactly DataTypeSize(type) bytes; InvalidArgument otherwise.
absl::StatusOr<int64_t> DecodeInteger(DataType type, std::span<const uint8_t> bytes);

// One sub-index: its definition. Built with the helpers below and adjusted with the chained
// setters, e.g. `Integer(0x6040, 0, "controlword", DataType::kU16).Mappable()`.
struct ObjectDef {
  uint16_t index = 0;
  uint8_t sub = 0;
  std::string name;  // for messages and listings ("controlword")
  DataType type = DataType::kU8;
  Access access = Access::kRw;
  bool pdo_mappable = false;
  std::optional<int64_t> min;          // integers: bus writes below are refused with 0609 0032h
  std::optional<int64_t> max;          // integers: bus writes above are refused with 0609 0031h
  int64_t default_int = 0;             // integers: power-on / reset value
  std::vector<uint8_t> default_bytes;  // string/domain: power-on / reset value
  size_t max_size = 0;  // string/domain: longest accepted write (0: kSdoDefaultMaxSize)

  ObjectDef& Mappable(bool mappable = true) {
    pdo_mappable = mappable;
    return *this;
  }
  ObjectDef& Range(int64_t lo, int64_t hi) {
    min = lo;
    max = hi;
    return *this;
  }
  ObjectDef& WithAccess(Access a) {
    access = a;
    return *this;
  }
  ObjectDef& Default(int64_t value) {
    default_int = value;
    return *this;
  }
  ObjectDef& MaxSize(size_t n) {
    max_size = n;
    return *this;
  }
};
ObjectDef Integer(uint16_t index, uint8_t sub, std::string name, DataType type,
                  Access access = Access::kRw, int64_t default_value = 0);
ObjectDef String(uint16_t index, uint8_t sub, std::string name, std::string_view default_value,
                 Access access = Access::kConst);
ObjectDef Domain(uint16_t index, uint8_t sub, std::string name, Access access = Access::kRw);

// "6040h:00 controlword" (names may be empty: "6040h:00").
std::string ObjectLabel(uint16_t index, uint8_t sub, std::string_view name = {});

// Hooks run for accesses from the bus (SDO and PDO), not for Get*/Set* by the model.
// Read: returns the value to serve (and store); an error refuses the read with its abort code.
using ReadHook = std::function<absl::StatusOr<std::vector<uint8_t>>()>;
using ReadIntHook = std::function<absl::StatusOr<int64_t>()>;
// Write: runs after the access, length and range checks and before the value is stored; an
// error refuses the write (SdoAbortStatus picks the code, other statuses map per decision 1104).
using WriteHook = std::function<absl::Status(std::span<const uint8_t> bytes)>;
using WriteIntHook = std::function<absl::Status(int64_t value)>;
// Runs after every successful write from the bus (SDO download, RPDO).
using WriteObserver = std::function<void(uint16_t index, uint8_t sub)>;

class ObjectDictionary : public drivegw::canopen::ObjectAccess {
 public:
  // AlreadyExists for a duplicate index:sub; InvalidArgument for a default that does not fit
  // the type or lies outside min..max, min > max, or limits on a string/domain.
  absl::Status Add(ObjectDef def);

  bool Contains(uint16_t index) const;
  bool Contains(uint16_t index, uint8_t sub) const;
  const ObjectDef* Find(uint16_t index, uint8_t sub) const;
  // Definitions in index:sub order.
  std::vector<const ObjectDef*> Objects() const;

  // ---- the bus side (SDO server, PDOs): access rights, hooks, abort codes ----
  // 0602 0000h no object, 0609 0011h no sub-index, 0601 0001h write-only, or the hook's error.
  absl::StatusOr<std::vector<uint8_t>> Read(uint16_t index, uint8_t sub) override;
  // 0602 0000h, 0609 0011h, 0601 0002h read-only/const, integers 0607 0012h/0607 0013h for a
  // length above/below the type's, 0609 0031h/0609 0032h above max/below min; strings and
  // domains 0607 0012h above max_size; then the hook's error.
  absl::Status Write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) override;

  // ---- the model side: stored values, no access rights, no hooks ----
  absl::StatusOr<int64_t> GetInt(uint16_t index, uint8_t sub) const;
  absl::StatusOr<std::vector<uint8_t>> GetBytes(uint16_t index, uint8_t sub) const;
  absl::StatusOr<std::string> GetString(uint16_t index, uint8_t sub) const;
  // Checks only that the value fits the type (min/max bound the bus, not the device itself).
  absl::Status SetInt(uint16_t index, uint8_t sub, int64_t value);
  absl::Status SetBytes(uint16_t index, uint8_t sub, std::span<const uint8_t> bytes);
  absl::Status SetString(uint16_t index, uint8_t sub, std::string_view value);
  // Changes the power-on value as well as the current one (e.g. a model's default PDO mapping).
  absl::Status SetDefaultInt(uint16_t index, uint8_t sub, int64_t value);

  // One hook of each kind per object; a later call replaces it. NotFound for a missing object,
  // InvalidArgument for an integer hook on a string/domain.
  absl::Status OnRead(uint16_t index, uint8_t sub, ReadHook hook);
  absl::Status OnReadInt(uint16_t index, uint8_t sub, ReadIntHook hook);
  absl::Status OnWrite(uint16_t index, uint8_t sub, WriteHook hook);
  absl::Status OnWriteInt(uint16_t index, uint8_t sub, WriteIntHook hook);
  void AddWriteObserver(WriteObserver observer);

  // Values of every non-const object with first <= index <= last back to their defaults
  // (NMT reset node / reset communication, CiA 301 §7.2.8.2.2.4).
  void ResetToDefaults(uint16_t first, uint16_t last);

  // Whether index:sub can be mapped with `bits` into a PDO of `kind` (§7.5.2.36): OK, or 0602
  // 0000h when it does not exist, 0604 0041h when it is not mappable, not readable (TPDO) or
  // writable (RPDO), or `bits` differs from its size. RPDOs may map the dummy entries 0002h..
  // 0007h sub 0 (§7.4.7.1) with their type's size.
  absl::Status CheckMappable(drivegw::canopen::PdoKind kind,
                             drivegw::canopen::PdoMappingEntry entry) const;

 private:
  struct Entry {
    ObjectDef def;
    std::vector<uint8_t> value;
    ReadHook read;
    WriteHook write;
  };
  static uint32_t Key(uint16_t index, uint8_t sub) {
    return static_cast<uint32_t>(index) << 8 | sub;
  }
  absl::StatusOr<Entry*> Lookup(uint16_t index, uint8_t sub);
  absl::StatusOr<const Entry*> Lookup(uint16_t index, uint8_t sub) const;
  // OnReadInt/OnWriteInt: the entry (NotFound if absent), refused unless its type is an integer.
  absl::StatusOr<Entry*> LookupIntegerHook(uint16_t index, uint8_t sub);
  absl::Status CheckRange(const Entry& e, int64_t value) const;

  std::map<uint32_t, Entry> entries_;
  std::vector<WriteObserver> observers_;
};

}  // namespace drivegw::sim::canopen
