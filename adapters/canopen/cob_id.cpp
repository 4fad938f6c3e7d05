// Predefined connection set identifiers (CiA 301 v4.2.0 §7.3.3, Tables 71 and 72).
#include "adapters/canopen/cob_id.h"

#include <array>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::canopen {
namespace {

struct FunctionSpec {
  Function function;
  const char* name;
  uint16_t base;
  bool broadcast;
};

// Table 71 (broadcast) and Table 72 (peer-to-peer), ordered by identifier base.
constexpr std::array<FunctionSpec, 15> kFunctions = {{
    {Function::kNmt, "nmt", 0x000, true},
    {Function::kSync, "sync", 0x080, true},
    {Function::kEmcy, "emcy", 0x080, false},
    {Function::kTime, "time", 0x100, true},
    {Function::kTpdo1, "tpdo1", 0x180, false},
    {Function::kRpdo1, "rpdo1", 0x200, false},
    {Function::kTpdo2, "tpdo2", 0x280, false},
    {Function::kRpdo2, "rpdo2", 0x300, false},
    {Function::kTpdo3, "tpdo3", 0x380, false},
    {Function::kRpdo3, "rpdo3", 0x400, false},
    {Function::kTpdo4, "tpdo4", 0x480, false},
    {Function::kRpdo4, "rpdo4", 0x500, false},
    {Function::kSdoTx, "sdo_tx", 0x580, false},
    {Function::kSdoRx, "sdo_rx", 0x600, false},
    {Function::kNmtErrorControl, "nmt_error_control", 0x700, false},
}};

const FunctionSpec& SpecOf(Function function) {
  for (const FunctionSpec& s : kFunctions) {
    if (s.function == function) return s;
  }
  return kFunctions[0];
}

}  // namespace

std::string_view FunctionName(Function function) { return SpecOf(function).name; }
uint16_t FunctionBase(Function function) { return SpecOf(function).base; }
bool IsBroadcast(Function function) { return SpecOf(function).broadcast; }

absl::Status ValidateNodeId(uint8_t node, std::string_view field) {
  if (node < kMinNodeId || node > kMaxNodeId) {
    return absl::InvalidArgumentError(absl::StrCat("canopen ", std::string(field), ": ", node,
                                                   " outside ", kMinNodeId, "..", kMaxNodeId));
  }
  return absl::OkStatus();
}

absl::StatusOr<uint16_t> CobId(Function function, uint8_t node) {
  const FunctionSpec& spec = SpecOf(function);
  if (spec.broadcast) {
    if (node != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("canopen ", spec.name, ".node_id: ", node, " must be 0 (broadcast object)"));
    }
    return spec.base;
  }
  if (auto s = ValidateNodeId(node, absl::StrCat(spec.name, ".node_id")); !s.ok()) return s;
  return static_cast<uint16_t>(spec.base + node);
}

absl::StatusOr<CobIdClass> ClassifyCobId(uint32_t id) {
  if (id > kMaxCobId) {
    return absl::InvalidArgumentError(
        absl::StrFormat("canopen cob id 0x%X: exceeds 0x7FF (11-bit base format)", id));
  }
  const uint16_t base = static_cast<uint16_t>(id & 0x780);
  const uint8_t node = static_cast<uint8_t>(id & 0x7F);
  if (id == 0x000) return CobIdClass{Function::kNmt, 0};
  if (id == 0x080) return CobIdClass{Function::kSync, 0};
  if (id == 0x100) return CobIdClass{Function::kTime, 0};
  if (node != 0) {
    for (const FunctionSpec& s : kFunctions) {
      if (!s.broadcast && s.base == base) return CobIdClass{s.function, node};
    }
  }
  return absl::NotFoundError(
      absl::StrFormat("canopen cob id 0x%03X: not in the CiA 301 predefined connection set", id));
}

}  // namespace drivegw::canopen
