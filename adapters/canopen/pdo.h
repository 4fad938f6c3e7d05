// CANopen process data objects: the mapping model (entries {index, sub, bit length}, at most 64
// bits), packing typed values into a PDO payload and back, the communication parameter record,
// and the ordered SDO writes that (re)configure one PDO. Pure (no I/O).
// Source: CiA 301 v4.2.0 §7.2.2 (PDO; transmission types: 0 synchronous acyclic, 1..240
// synchronous every n-th SYNC, 252/253 RTR-only, 254/255 event-driven), §7.5.2.35-38
// (1400h/1600h RPDO and 1800h/1A00h TPDO records; COB-ID bit 31 valid, bit 30 RTR, bit 29
// frame), §7.2.2.4 / Figure 17 (mapping re-configuration procedure: invalidate, sub 0 = 0,
// entries, sub 0 = n, validate).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::canopen {

enum class PdoKind : uint8_t { kRpdo, kTpdo };  // RPDO: master → node; TPDO: node → master
inline constexpr size_t kPdoMaxBits = 64;       // classic CAN: 8 data bytes
inline constexpr size_t kPdoMaxEntries = 64;    // mapping sub-indices 1..64
inline constexpr uint16_t kPdoMaxNumber = 512;  // 1400h..15FFh etc.

// One mapped object (§7.5.2.36: u32 = index << 16 | sub << 8 | bit length).
struct PdoMappingEntry {
  uint16_t index = 0;
  uint8_t sub = 0;
  uint8_t bits = 0;  // 1..64
  friend constexpr bool operator==(PdoMappingEntry, PdoMappingEntry) = default;
};
constexpr uint32_t EncodeMappingEntry(PdoMappingEntry e) {
  return static_cast<uint32_t>(e.index) << 16 | static_cast<uint32_t>(e.sub) << 8 | e.bits;
}
constexpr PdoMappingEntry DecodeMappingEntry(uint32_t v) {
  return {static_cast<uint16_t>(v >> 16), static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)};
}

// Entries in payload order, bit-packed LSB first (entry 0 starts at bit 0 of byte 0).
using PdoMapping = std::vector<PdoMappingEntry>;
// OK when every entry has 1..64 bits, at most 64 entries and at most 64 bits in total:
// "canopen pdo mapping: 72 bits exceed 64", "canopen pdo mapping[2].bits: 0 outside 1..64".
absl::Status ValidateMapping(std::span<const PdoMappingEntry> mapping);
size_t MappingBits(std::span<const PdoMappingEntry> mapping);
size_t MappingBytes(std::span<const PdoMappingEntry> mapping);  // ceil(bits / 8)

// Raw packing: value i fills entry i's bits (values wider than the entry are InvalidArgument:
// "canopen pdo mapping[1] 6040h:00: value 0x10000 exceeds 16 bits").
absl::StatusOr<std::vector<uint8_t>> PackPdoRaw(std::span<const PdoMappingEntry> mapping,
                                                std::span<const uint64_t> values);
// The first MappingBytes() bytes are used; a shorter payload is InvalidArgument (CiA 301
// §7.2.2.2: too short RPDO is not processed, EMCY 8210h), longer ones are accepted.
absl::StatusOr<std::vector<uint64_t>> UnpackPdoRaw(std::span<const PdoMappingEntry> mapping,
                                                   std::span<const uint8_t> payload);

// Typed values: little-endian integers whose width must equal the entry's bit length.
enum class PdoType : uint8_t { kU8, kI8, kU16, kI16, kU32, kI32 };
uint8_t PdoTypeBits(PdoType type);
std::string_view PdoTypeName(PdoType type);  // "u8", "i8", ...
struct PdoValue {
  PdoType type = PdoType::kU8;
  int64_t value = 0;
  friend constexpr bool operator==(PdoValue, PdoValue) = default;
};
// Range checks name the entry: "canopen pdo mapping[0] 6040h:00: u16 value 70000 outside
// 0..65535"; a type/width mismatch: "... i32 needs 32 bits, entry maps 16".
absl::StatusOr<std::vector<uint8_t>> PackPdo(std::span<const PdoMappingEntry> mapping,
                                             std::span<const PdoValue> values);
absl::StatusOr<std::vector<PdoValue>> UnpackPdo(std::span<const PdoMappingEntry> mapping,
                                                std::span<const PdoType> types,
                                                std::span<const uint8_t> payload);

// Transmission type (§7.5.2.35 sub 2).
inline constexpr uint8_t kTransmissionSyncAcyclic = 0;
inline constexpr uint8_t kTransmissionSyncEveryMax = 240;  // 1..240: every n-th SYNC
inline constexpr uint8_t kTransmissionSyncRtr = 252;       // TPDO only
inline constexpr uint8_t kTransmissionEventRtr = 253;      // TPDO only
inline constexpr uint8_t kTransmissionEventManufacturer = 254;
inline constexpr uint8_t kTransmissionEventProfile = 255;

// COB-ID entry bits (§7.5.2.35 sub 1).
inline constexpr uint32_t kPdoCobIdInvalid = 0x80000000;   // bit 31 = 1: PDO does not exist
inline constexpr uint32_t kPdoCobIdNoRtr = 0x40000000;     // bit 30 = 1: no RTR allowed
inline constexpr uint32_t kPdoCobIdExtended = 0x20000000;  // bit 29 = 1: 29-bit id (refused)

struct PdoCommParams {
  uint16_t cob_id = 0;  // 11-bit identifier; 0 = predefined set (PDO 1..4 only)
  bool valid = true;    // false leaves bit 31 set: the PDO stays disabled
  uint8_t transmission_type = kTransmissionEventProfile;
  uint16_t inhibit_time_100us = 0;  // TPDO sub 3, units of 100 µs
  uint16_t event_timer_ms = 0;      // sub 5: TPDO event timer, RPDO deadline monitoring
  friend bool operator==(const PdoCommParams&, const PdoCommParams&) = default;
};
// Reserved transmission types 241..251 and RTR types 252/253 on an RPDO are InvalidArgument
// ("canopen rpdo1.transmission_type: 252 is TPDO-only (RTR)").
absl::Status ValidateCommParams(PdoKind kind, const PdoCommParams& comm);

// Predefined-set COB-ID of PDO 1..4 of `node` (180h/200h + 100h * (number - 1) + node).
absl::StatusOr<uint16_t> DefaultPdoCobId(PdoKind kind, uint16_t number, uint8_t node);
// 1400h/1800h + number - 1 and 1600h/1A00h + number - 1 (number 1..512).
uint16_t PdoCommIndex(PdoKind kind, uint16_t number);
uint16_t PdoMappingIndex(PdoKind kind, uint16_t number);

// One SDO download of the configuration sequence; `data` is the little-endian object value
// with the object's width (u32 COB-ID and entries, u8 counts and type, u16 times).
struct SdoWrite {
  uint16_t index = 0;
  uint8_t sub = 0;
  std::vector<uint8_t> data;
  friend bool operator==(const SdoWrite&, const SdoWrite&) = default;
};
// The CiA 301 §7.2.2.4 sequence for PDO `number` (1..512) of `node`: COB-ID with bit 31 set,
// mapping sub 0 = 0, mapping entries 1..n, mapping sub 0 = n, transmission type, (TPDO) inhibit
// time, event timer, COB-ID as configured (bit 31 clear when comm.valid; TPDO bit 30 set: no RTR).
absl::StatusOr<std::vector<SdoWrite>> MappingWrites(PdoKind kind, uint16_t number, uint8_t node,
                                                    const PdoCommParams& comm,
                                                    std::span<const PdoMappingEntry> mapping);

}  // namespace drivegw::canopen
