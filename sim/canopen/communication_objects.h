// The CiA 301 communication profile area (1000h..1FFFh) of a simulated slave: the objects every
// node gets, their power-on values, and the write rules CiA 301 attaches to them (PDO COB-ID,
// transmission type, inhibit time and mapping rules, SYNC/EMCY COB-ID bits, error history
// clearing, heartbeat consumer entries), plus readers the node's runtime uses. No device
// profile knowledge (decisions 1123-1125).
// Source: CiA 301 v4.2.0 §7.5.2 (object descriptions 1000h..1A00h), §7.2.2.4 (PDO mapping
// procedure), §7.3.5 (restricted CAN-IDs).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/pdo.h"
#include "sim/canopen/object_dictionary.h"

namespace drivegw::sim::canopen {

// Values of 1000h, 1008h..100Ah and 1018h.
struct DeviceIdentity {
  uint32_t device_type = 0;  // 1000h: profile number (bits 0..15) and additional information
  std::string device_name = "drivegw CANopen slave";  // 1008h
  std::string hardware_version = "1";                 // 1009h
  std::string software_version = "1";                 // 100Ah
  uint32_t vendor_id = 0;                             // 1018h:01
  uint32_t product_code = 0;                          // 1018h:02
  uint32_t revision = 0;                              // 1018h:03
  uint32_t serial_number = 0;                         // 1018h:04
};

// Sizes of the communication area (decision 1123).
inline constexpr uint16_t kPdoCount = 4;               // RPDO/TPDO 1..4 (1400h..1403h, ...)
inline constexpr uint8_t kPdoMappingEntries = 8;       // 1600h/1A00h sub 1..8
inline constexpr uint8_t kErrorHistoryDepth = 8;       // 1003h sub 1..8
inline constexpr uint8_t kHeartbeatConsumerCount = 4;  // 1016h sub 1..4

// 1029h sub 1 (§7.5.2.32): what a communication error (heartbeat consumer timeout) does.
enum class ErrorBehaviour : uint8_t {
  kPreOperational = 0,  // operational → pre-operational; other states stay
  kNoChange = 1,
  kStopped = 2,
};

// Adds every communication object with its rules. `node_id` 1..127 fixes the predefined-set
// identifiers (EMCY 80h+n, SDO 600h/580h+n, PDO 180h..500h+n). PDOs start invalid with empty
// mappings; a model sets its defaults with SetDefaultPdo.
absl::Status AddCommunicationObjects(ObjectDictionary& od, uint8_t node_id,
                                     const DeviceIdentity& identity);

// One PDO as the runtime sees it, read from 1400h../1600h.. or 1800h../1A00h...
struct PdoConfig {
  drivegw::canopen::PdoKind kind = drivegw::canopen::PdoKind::kTpdo;
  uint16_t number = 1;       // 1..kPdoCount
  bool valid = false;        // COB-ID bit 31 clear
  uint16_t can_id = 0;       // COB-ID bits 0..10
  bool rtr_allowed = false;  // TPDO COB-ID bit 30 clear
  uint8_t transmission_type = drivegw::canopen::kTransmissionEventProfile;
  uint16_t inhibit_100us = 0;            // TPDO sub 3
  uint16_t event_ms = 0;                 // sub 5: TPDO event timer, RPDO deadline monitoring
  drivegw::canopen::PdoMapping mapping;  // entries 1..sub 0
};
absl::StatusOr<PdoConfig> ReadPdoConfig(const ObjectDictionary& od, drivegw::canopen::PdoKind kind,
                                        uint16_t number);

// Replaces the power-on configuration of one PDO (communication record and mapping), checked
// like the bus would (mapped objects exist and are mappable, at most 64 bits, valid transmission
// type). `comm.cob_id` 0 takes the predefined identifier of `node_id`.
absl::Status SetDefaultPdo(ObjectDictionary& od, drivegw::canopen::PdoKind kind, uint16_t number,
                           uint8_t node_id, const drivegw::canopen::PdoCommParams& comm,
                           std::span<const drivegw::canopen::PdoMappingEntry> mapping);

// 1016h sub 1..n entries with a node id and a time (the others are off).
struct HeartbeatConsumer {
  uint8_t sub = 1;
  uint8_t node = 0;
  uint16_t time_ms = 0;
};
std::vector<HeartbeatConsumer> ReadHeartbeatConsumers(const ObjectDictionary& od);

// CiA 301 §7.3.5: identifiers no PDO or EMCY may use (NMT, SDO, error control, reserved).
bool IsRestrictedCanId(uint16_t id);

}  // namespace drivegw::sim::canopen
