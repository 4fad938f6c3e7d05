// The STOBER object map: table, conversions, packed status, default PDO layout (decisions
// 1171-1175; stober-motion.md §5, §7.2; CiA 402 data types of 6040h..60FFh).
#include "adapters/stober/object_map.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace drivegw::stober {
namespace {

namespace co = drivegw::canopen;

// Quantity classes (decision 1172).
enum class Kind {
  kPos,      // signed user units (u, u/s): INTEGER32, 0.001
  kUPos,     // non-negative user units (u/s², u/s³, windows, speeds): UNSIGNED32, 0.001
  kMs,       // times in ms: UNSIGNED32, 1 µs
  kPct,      // percent (torque, override): INTEGER16, 0.1 % (CiA 402 6071h per thousand)
  kPctRate,  // %/s: UNSIGNED32, 0.1 %/s (CiA 402 6087h per thousand per second)
  kBool,     // UNSIGNED8 0/1
  kU8,
  kI8,
  kU16,
  kI32,  // integers as they are
};

struct Row {
  const char* id;
  const char* name;
  Kind kind;
  bool ro = false;
};

constexpr bool RO = true;

// Every parameter of the simulated axis's catalogue (sim/stober/parameters.cpp, §9 checklist);
// CiA 402 rows keep their standard CiA 402 data type (CiA 402-2: 6040h/6041h u16, 6060h/6061h/
// 6098h i8, 6064h/607Ah/607Ch/60B1h/60C1h/60FFh i32, 6071h/60B2h i16, 6081h/6083h/6084h/6087h/
// 6099h/609Ah/60A4h u32, 60F2h u16).
constexpr Row kRows[] = {
    {"A150", "cycle time motion core", Kind::kMs},
    {"A291", "controller cycle time", Kind::kMs},
    {"A340", "velocity override (CiA 402 source)", Kind::kPct},
    {"A515", "control word", Kind::kU16},
    {"A516", "status word", Kind::kU16, RO},
    {"A541", "modes of operation", Kind::kI8},
    {"A542", "modes of operation display", Kind::kI8, RO},
    {"A545", "position actual value", Kind::kPos, RO},
    {"A558", "target torque", Kind::kPct},
    {"A561", "torque slope", Kind::kPctRate},
    {"A567", "target position", Kind::kPos},
    {"A569", "home offset", Kind::kPos},
    {"A574", "profile velocity", Kind::kUPos},
    {"A576", "profile acceleration", Kind::kUPos},
    {"A577", "profile deceleration", Kind::kUPos},
    {"A586", "homing method", Kind::kI8},
    {"A587[0]", "homing speed fast", Kind::kUPos},
    {"A587[1]", "homing speed slow", Kind::kUPos},
    {"A588", "homing acceleration", Kind::kUPos},
    {"A590", "profile jerk", Kind::kUPos},
    {"A592", "velocity offset", Kind::kPos},
    {"A593", "torque offset", Kind::kPct},
    {"A601", "interpolation data record", Kind::kPos},
    {"A621", "positioning option code", Kind::kU16},
    {"A638", "target velocity", Kind::kPos},
    {"C40", "velocity window", Kind::kUPos},
    {"E07", "calculated set velocity", Kind::kPos, RO},
    {"E65", "maximum torque positive", Kind::kPct},
    {"E66", "maximum torque negative", Kind::kPct},
    {"E90", "actual torque", Kind::kPct, RO},
    {"F00", "brake control", Kind::kU8},
    {"I00", "travel range", Kind::kU8},
    {"I01", "revolution length", Kind::kPos},
    {"I04", "permitted direction", Kind::kU8},
    {"I10", "maximum velocity", Kind::kUPos},
    {"I11", "maximum acceleration", Kind::kUPos},
    {"I16", "maximum jerk", Kind::kUPos},
    {"I22", "position window", Kind::kUPos},
    {"I25", "velocity feedforward", Kind::kPct},
    {"I28", "homing torque limit", Kind::kPct},
    {"I29", "time homing torque limit", Kind::kMs},
    {"I30", "referencing type", Kind::kU8},
    {"I31", "referencing direction", Kind::kU8},
    {"I32", "referencing speed fast", Kind::kUPos},
    {"I33", "referencing speed slow", Kind::kUPos},
    {"I34", "reference position", Kind::kPos},
    {"I35", "referencing with zero pulse", Kind::kU8},
    {"I37", "index search distance", Kind::kUPos},
    {"I39", "referencing acceleration", Kind::kUPos},
    {"I42", "brake wait time", Kind::kMs},
    {"I43", "move to reference position", Kind::kU8},
    {"I44", "reference jerk", Kind::kUPos},
    {"I50", "software limit switch positive", Kind::kPos},
    {"I51", "software limit switch negative", Kind::kPos},
    {"I80", "actual position", Kind::kPos, RO},
    {"I82", "active motion ID", Kind::kI32, RO},
    {"I83", "state motion command", Kind::kU8, RO},
    {"I85", "motion profile done", Kind::kBool, RO},
    {"I86", "in reference", Kind::kBool, RO},
    {"I87", "position window time", Kind::kMs},
    {"I88", "actual velocity", Kind::kPos, RO},
    {"I89", "PLCopen state", Kind::kU8, RO},
    {"I90", "PLCopen ErrorStop cause", Kind::kU8, RO},
    {"I91", "error", Kind::kBool, RO},
    {"I92", "done", Kind::kBool, RO},
    {"I96", "calculated set position", Kind::kPos, RO},
    {"I100", "source Execute", Kind::kU8},
    {"I101", "source positive limit switch", Kind::kU8},
    {"I102", "source negative limit switch", Kind::kU8},
    {"I103", "source reference switch", Kind::kU8},
    {"I113", "MC_MoveVelocity mode", Kind::kU8},
    {"I119", "disable v-set at command change", Kind::kU8},
    {"I180", "actual position in window", Kind::kBool, RO},
    {"I183", "speed reached", Kind::kBool, RO},
    {"I190", "velocity limit active", Kind::kBool, RO},
    {"I191", "acceleration/jerk limit active", Kind::kBool, RO},
    {"I192", "cyclical position limiting active", Kind::kBool, RO},
    {"I193", "cyclical velocity limit active", Kind::kBool, RO},
    {"I194", "cyclical torque limit active", Kind::kBool, RO},
    {"I195", "cyclical acceleration limit active", Kind::kBool, RO},
    {"I199", "set and actual velocity zero", Kind::kBool, RO},
    {"I216", "cyclic acceleration", Kind::kUPos},
    {"I217", "cyclic deceleration", Kind::kUPos},
    {"I230", "velocity override", Kind::kPct},
    {"I400", "motion ID", Kind::kI32},
    {"I401", "command", Kind::kU8},
    {"I402", "execute", Kind::kBool},
    {"I403", "position", Kind::kPos},
    {"I404", "velocity", Kind::kPos},
    {"I405", "acceleration", Kind::kUPos},
    {"I406", "deceleration", Kind::kUPos},
    {"I407", "jerk", Kind::kUPos},
    {"I409", "command mode", Kind::kU8},
    {"I410", "engage brake at the end", Kind::kBool},
    {"I411", "movement direction", Kind::kU8},
    {"I421", "cyclic position reference value", Kind::kPos},
    {"I423", "extrapolation time", Kind::kMs},
    {"I425", "interpolation type", Kind::kU8},
    {"I426", "cyclic reference speed", Kind::kPos},
    {"I428", "cyclic reference torque", Kind::kPct},
    {"I429", "end velocity", Kind::kUPos},
    {"I430", "torque ramp up", Kind::kPctRate},
    {"I431", "torque ramp down", Kind::kPctRate},
    {"I441", "signal positive limit switch", Kind::kBool, RO},
    {"I442", "signal negative limit switch", Kind::kBool, RO},
};

ObjectBinding MakeBinding(const Row& row) {
  ObjectBinding b;
  b.param = P(row.id);
  b.address = *ToCanOpen(b.param);  // every row is addressable (tested)
  b.name = row.name;
  b.read_only = row.ro;
  switch (row.kind) {
    case Kind::kPos:
      b.type = WireType::kI32;
      b.scale = kUserUnitScale;
      break;
    case Kind::kUPos:
      b.type = WireType::kU32;
      b.scale = kUserUnitScale;
      break;
    case Kind::kMs:
      b.type = WireType::kU32;
      b.scale = kMillisecondScale;
      break;
    case Kind::kPct:
      b.type = WireType::kI16;
      b.scale = kPercentScale;
      break;
    case Kind::kPctRate:
      b.type = WireType::kU32;
      b.scale = kPercentScale;
      break;
    case Kind::kBool:
      b.type = WireType::kU8;
      b.boolean = true;
      break;
    case Kind::kU8:
      b.type = WireType::kU8;
      break;
    case Kind::kI8:
      b.type = WireType::kI8;
      break;
    case Kind::kU16:
      b.type = WireType::kU16;
      break;
    case Kind::kI32:
      b.type = WireType::kI32;
      break;
  }
  return b;
}

std::vector<ObjectBinding> MakeMap() {
  std::vector<ObjectBinding> map;
  for (const Row& row : kRows) map.push_back(MakeBinding(row));
  // CiA 402 606Ch velocity actual value: STOBER's A-line for it is not in the reference, so the
  // object carries the motion core's actual velocity I88 (decision 1173).
  ObjectBinding velocity = MakeBinding({"I88", "velocity actual value", Kind::kPos, RO});
  velocity.address = {0x606C, 0};
  map.push_back(velocity);
  std::sort(map.begin(), map.end(),
            [](const ObjectBinding& a, const ObjectBinding& b) { return a.address < b.address; });
  return map;
}

std::string Label(const ObjectBinding& b) {
  return absl::StrCat(ToString(b.param), " (", std::string(b.name), ")");
}

std::string FormatUser(const ObjectBinding& b, int64_t raw) {
  if (b.scale == 1) return absl::StrCat(raw);
  const int decimals = b.scale == kPercentScale ? 1 : 3;
  return absl::StrFormat("%.*f", decimals, static_cast<double>(raw) * b.scale);
}

PdoField Field(const char* id) {
  absl::StatusOr<ObjectBinding> b = FindBinding(P(id));
  return PdoField{
      b->param, {b->address.index, b->address.sub_index, WireTypeBits(b->type)}, b->type};
}
PdoField FieldAt(CanOpenAddress address) {
  absl::StatusOr<ObjectBinding> b = FindBinding(address);
  return PdoField{b->param, {address.index, address.sub_index, WireTypeBits(b->type)}, b->type};
}

std::vector<PdoLayout> MakeLayout() {
  using co::PdoKind;
  co::PdoCommParams rpdo;  // predefined COB-ID, event-driven: applied on reception
  rpdo.transmission_type = co::kTransmissionEventProfile;
  co::PdoCommParams status = rpdo;  // every change at once (no inhibit), 100 ms refresh
  status.event_timer_ms = 100;
  co::PdoCommParams actual = rpdo;  // at most every 10 ms while moving, 100 ms refresh
  actual.inhibit_time_100us = 100;
  actual.event_timer_ms = 100;
  const PdoField flags{std::nullopt, {kStatusFlagsIndex, kStatusFlagsSub, 32}, WireType::kU32};
  return {
      {PdoKind::kRpdo, 1, rpdo, {Field("A515"), Field("I401"), Field("I403"), Field("I402")}},
      {PdoKind::kRpdo, 2, rpdo, {Field("I404"), Field("I405")}},
      {PdoKind::kRpdo, 3, rpdo, {Field("I406"), Field("I407")}},
      {PdoKind::kRpdo, 4, rpdo, {Field("I230"), Field("I411"), Field("I410"), Field("I400")}},
      {PdoKind::kTpdo, 1, status, {Field("A516"), Field("I89"), Field("I90"), flags}},
      {PdoKind::kTpdo, 2, actual, {Field("A545"), FieldAt({0x606C, 0})}},
  };
}

}  // namespace

std::string_view WireTypeName(WireType type) {
  switch (type) {
    case WireType::kU8:
      return "u8";
    case WireType::kI8:
      return "i8";
    case WireType::kU16:
      return "u16";
    case WireType::kI16:
      return "i16";
    case WireType::kU32:
      return "u32";
    case WireType::kI32:
      return "i32";
  }
  return "?";
}

uint8_t WireTypeBits(WireType type) {
  switch (type) {
    case WireType::kU8:
    case WireType::kI8:
      return 8;
    case WireType::kU16:
    case WireType::kI16:
      return 16;
    case WireType::kU32:
    case WireType::kI32:
      return 32;
  }
  return 0;
}

bool WireTypeSigned(WireType type) {
  return type == WireType::kI8 || type == WireType::kI16 || type == WireType::kI32;
}

int64_t WireTypeMin(WireType type) {
  if (!WireTypeSigned(type)) return 0;
  return -(int64_t{1} << (WireTypeBits(type) - 1));
}

int64_t WireTypeMax(WireType type) {
  const int bits = WireTypeBits(type);
  return WireTypeSigned(type) ? (int64_t{1} << (bits - 1)) - 1 : (int64_t{1} << bits) - 1;
}

co::PdoType ToPdoType(WireType type) {
  switch (type) {
    case WireType::kU8:
      return co::PdoType::kU8;
    case WireType::kI8:
      return co::PdoType::kI8;
    case WireType::kU16:
      return co::PdoType::kU16;
    case WireType::kI16:
      return co::PdoType::kI16;
    case WireType::kU32:
      return co::PdoType::kU32;
    case WireType::kI32:
      return co::PdoType::kI32;
  }
  return co::PdoType::kU8;
}

const std::vector<ObjectBinding>& ObjectMap() {
  static const std::vector<ObjectBinding> kMap = MakeMap();
  return kMap;
}

absl::StatusOr<ObjectBinding> FindBinding(ParamId id) {
  absl::StatusOr<CanOpenAddress> address = ToCanOpen(id);
  if (address.ok()) {
    for (const ObjectBinding& b : ObjectMap()) {
      if (b.param == id && b.address == *address) return b;
    }
  }
  return absl::NotFoundError(
      absl::StrCat("STOBER parameter ", ToString(id), " has no object in the CANopen object map"));
}

absl::StatusOr<ObjectBinding> FindBinding(CanOpenAddress address) {
  const std::vector<ObjectBinding>& map = ObjectMap();
  auto it = std::lower_bound(
      map.begin(), map.end(), address,
      [](const ObjectBinding& b, const CanOpenAddress& a) { return b.address < a; });
  if (it != map.end() && it->address == address) return *it;
  return absl::NotFoundError(
      absl::StrFormat("CANopen object %04Xh:%02X is not in the STOBER "
                      "object map",
                      address.index, address.sub_index));
}

absl::StatusOr<int64_t> ToRaw(const ObjectBinding& b, double value) {
  if (!std::isfinite(value)) {
    return absl::InvalidArgumentError(absl::StrCat(Label(b), ": value must be finite"));
  }
  if ((b.scale == 1 || b.boolean) && value != std::floor(value)) {
    return absl::InvalidArgumentError(absl::StrCat(Label(b), ": ", value, " is not an integer"));
  }
  const int64_t lo = b.boolean ? 0 : WireTypeMin(b.type);
  const int64_t hi = b.boolean ? 1 : WireTypeMax(b.type);
  const double scaled = std::round(value / b.scale);
  if (scaled > static_cast<double>(hi)) {
    return absl::OutOfRangeError(absl::StrCat(Label(b), ": ", value, " above the ",
                                              std::string(WireTypeName(b.type)), " wire maximum ",
                                              FormatUser(b, hi)));
  }
  if (scaled < static_cast<double>(lo)) {
    return absl::OutOfRangeError(absl::StrCat(Label(b), ": ", value, " below the ",
                                              std::string(WireTypeName(b.type)), " wire minimum ",
                                              FormatUser(b, lo)));
  }
  return static_cast<int64_t>(scaled);
}

double FromRaw(const ObjectBinding& b, int64_t raw) {
  return b.scale == 1 ? static_cast<double>(raw) : static_cast<double>(raw) * b.scale;
}

absl::StatusOr<std::vector<uint8_t>> Encode(const ObjectBinding& b, double value) {
  absl::StatusOr<int64_t> raw = ToRaw(b, value);
  if (!raw.ok()) return raw.status();
  const size_t n = WireTypeBits(b.type) / 8;
  std::vector<uint8_t> bytes(n);
  const auto bits = static_cast<uint64_t>(*raw);
  for (size_t i = 0; i < n; ++i) bytes[i] = static_cast<uint8_t>(bits >> (8 * i));
  return bytes;
}

absl::StatusOr<double> Decode(const ObjectBinding& b, std::span<const uint8_t> bytes) {
  const size_t n = WireTypeBits(b.type) / 8;
  if (bytes.size() != n) {
    return absl::InvalidArgumentError(absl::StrCat(Label(b), ": ", bytes.size(), " bytes, the ",
                                                   std::string(WireTypeName(b.type)),
                                                   " object has ", n));
  }
  uint64_t bits = 0;
  for (size_t i = 0; i < n; ++i) bits |= static_cast<uint64_t>(bytes[i]) << (8 * i);
  int64_t raw = static_cast<int64_t>(bits);
  if (WireTypeSigned(b.type) && n < 8 && (bits >> (8 * n - 1)) != 0) {
    raw = static_cast<int64_t>(bits | (~uint64_t{0} << (8 * n)));
  }
  if (b.boolean && raw > 1) {
    return absl::OutOfRangeError(absl::StrCat(Label(b), ": ", raw, " is not a boolean 0/1"));
  }
  return FromRaw(b, raw);
}

absl::StatusOr<std::vector<uint8_t>> Encode(ParamId id, double value) {
  absl::StatusOr<ObjectBinding> b = FindBinding(id);
  if (!b.ok()) return b.status();
  return Encode(*b, value);
}

absl::StatusOr<double> Decode(ParamId id, std::span<const uint8_t> bytes) {
  absl::StatusOr<ObjectBinding> b = FindBinding(id);
  if (!b.ok()) return b.status();
  return Decode(*b, bytes);
}

const std::vector<StatusFlagBit>& StatusFlagBits() {
  namespace sb = status_bit;
  static const std::vector<StatusFlagBit> kBits = {
      {P("I91"), sb::kError, false},
      {P("I92"), sb::kDone, false},
      {P("I83"), sb::kCommandStateMask, true},
      {P("I85"), sb::kProfileDone, false},
      {P("I86"), sb::kInReference, false},
      {P("I180"), sb::kInWindow, false},
      {P("I183"), sb::kSpeedReached, false},
      {P("I199"), sb::kStandstill, false},
      {P("I190"), sb::kVelocityLimit, false},
      {P("I191"), sb::kDynamicsLimit, false},
      {P("I192"), sb::kCyclicPositionLimit, false},
      {P("I193"), sb::kCyclicVelocityLimit, false},
      {P("I194"), sb::kCyclicTorqueLimit, false},
      {P("I195"), sb::kCyclicAccelerationLimit, false},
      {P("I441"), sb::kPositiveLimitSwitch, false},
      {P("I442"), sb::kNegativeLimitSwitch, false},
  };
  return kBits;
}

co::PdoMapping PdoLayout::Mapping() const {
  co::PdoMapping mapping;
  for (const PdoField& f : fields) mapping.push_back(f.entry);
  return mapping;
}

const std::vector<PdoLayout>& DefaultPdoLayout() {
  static const std::vector<PdoLayout> kLayout = MakeLayout();
  return kLayout;
}

const PdoLayout* FindDefaultPdo(co::PdoKind kind, uint16_t number) {
  for (const PdoLayout& l : DefaultPdoLayout()) {
    if (l.kind == kind && l.number == number) return &l;
  }
  return nullptr;
}

absl::StatusOr<std::vector<uint8_t>> PackLayout(const PdoLayout& layout,
                                                std::span<const double> values) {
  if (values.size() != layout.fields.size()) {
    return absl::InvalidArgumentError(absl::StrCat("stober pdo: ", values.size(), " values for ",
                                                   layout.fields.size(), " fields"));
  }
  std::vector<co::PdoValue> typed;
  for (size_t i = 0; i < values.size(); ++i) {
    const PdoField& f = layout.fields[i];
    int64_t raw = 0;
    if (f.param) {
      absl::StatusOr<ObjectBinding> b = FindBinding(CanOpenAddress{f.entry.index, f.entry.sub});
      if (!b.ok()) return b.status();
      absl::StatusOr<int64_t> r = ToRaw(*b, values[i]);
      if (!r.ok()) return r.status();
      raw = *r;
    } else {
      if (values[i] < 0 || values[i] > 4294967295.0 || values[i] != std::floor(values[i])) {
        return absl::OutOfRangeError(
            absl::StrCat("stober pdo: packed status ", values[i], " outside 0..4294967295"));
      }
      raw = static_cast<int64_t>(values[i]);
    }
    typed.push_back({ToPdoType(f.type), raw});
  }
  const co::PdoMapping mapping = layout.Mapping();
  return co::PackPdo(mapping, typed);
}

absl::StatusOr<std::vector<double>> UnpackLayout(const PdoLayout& layout,
                                                 std::span<const uint8_t> payload) {
  std::vector<co::PdoType> types;
  for (const PdoField& f : layout.fields) types.push_back(ToPdoType(f.type));
  const co::PdoMapping mapping = layout.Mapping();
  absl::StatusOr<std::vector<co::PdoValue>> typed = co::UnpackPdo(mapping, types, payload);
  if (!typed.ok()) return typed.status();
  std::vector<double> values;
  for (size_t i = 0; i < typed->size(); ++i) {
    const PdoField& f = layout.fields[i];
    if (!f.param) {
      values.push_back(static_cast<double>((*typed)[i].value));
      continue;
    }
    absl::StatusOr<ObjectBinding> b = FindBinding(CanOpenAddress{f.entry.index, f.entry.sub});
    if (!b.ok()) return b.status();
    values.push_back(FromRaw(*b, (*typed)[i].value));
  }
  return values;
}

absl::StatusOr<MotionStatus> DecodeStatusTpdo(std::span<const uint8_t> payload) {
  const PdoLayout* layout = FindDefaultPdo(co::PdoKind::kTpdo, 1);
  absl::StatusOr<std::vector<double>> v = UnpackLayout(*layout, payload);
  if (!v.ok()) return v.status();
  MotionStatus s;
  s.status_word = static_cast<uint16_t>((*v)[0]);
  s.plc_state = static_cast<int>((*v)[1]);
  s.cause = static_cast<int>((*v)[2]);
  s.flags = static_cast<uint32_t>((*v)[3]);
  return s;
}

absl::StatusOr<ActualValues> DecodeActualTpdo(std::span<const uint8_t> payload) {
  const PdoLayout* layout = FindDefaultPdo(co::PdoKind::kTpdo, 2);
  absl::StatusOr<std::vector<double>> v = UnpackLayout(*layout, payload);
  if (!v.ok()) return v.status();
  return ActualValues{(*v)[0], (*v)[1]};
}

}  // namespace drivegw::stober
