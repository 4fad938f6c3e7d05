// Trinamic SIXpack/QUADpack codec: the instruction table and byte-by-byte encode/decode of
// commands, serial replies (R8/R9) and CAN frames (trinamic-sixpack.md §2-4).
#include "adapters/trinamic/codec.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace drivegw::trinamic {
namespace {

int64_t TypeMin(FieldType t) {
  switch (t) {
    case FieldType::kI8:
      return INT8_MIN;
    case FieldType::kI16:
      return INT16_MIN;
    case FieldType::kI32:
      return INT32_MIN;
    default:
      return 0;
  }
}

int64_t TypeMax(FieldType t) {
  switch (t) {
    case FieldType::kU8:
      return UINT8_MAX;
    case FieldType::kI8:
      return INT8_MAX;
    case FieldType::kU16:
      return UINT16_MAX;
    case FieldType::kI16:
      return INT16_MAX;
    case FieldType::kU32:
      return UINT32_MAX;
    case FieldType::kI32:
      return INT32_MAX;
  }
  return 0;
}

constexpr FieldType kU8 = FieldType::kU8;
constexpr FieldType kI8 = FieldType::kI8;
constexpr FieldType kU16 = FieldType::kU16;
constexpr FieldType kI16 = FieldType::kI16;
constexpr FieldType kU32 = FieldType::kU32;
constexpr FieldType kI32 = FieldType::kI32;

// A field with an explicit range.
FieldSpec F(const char* name, FieldType type, uint8_t param, int64_t min, int64_t max,
            uint8_t multiple_of = 1) {
  return FieldSpec{name, type, param, min, max, multiple_of};
}
// A field using the whole range of its wire type (no narrower range stated).
FieldSpec T(const char* name, FieldType type, uint8_t param) {
  return FieldSpec{name, type, param, TypeMin(type), TypeMax(type), 1};
}
FieldSpec Motnr(uint8_t param = 0) { return F("motnr", kU8, param, 0, kMotorCount - 1); }
FieldSpec Mask(const char* name, uint8_t param) { return F(name, kU8, param, 0, kMotorMask); }
// RA: any byte at codec level; framing rules are ValidateResponseAddress / ReplyCanId.
FieldSpec Ra(uint8_t param) { return T("ra", kU8, param); }
FieldSpec Bit(const char* name, uint8_t param) { return F(name, kU8, param, 0, 1); }

OpcodeSpec Row(Opcode op, const char* name, std::initializer_list<FieldSpec> fields,
               std::initializer_list<FieldSpec> reply_fields = {}, bool has_reply = false) {
  OpcodeSpec spec{};
  spec.opcode = op;
  spec.name = name;
  spec.response_address_field = -1;
  for (const FieldSpec& f : fields) {
    if (std::string_view(f.name) == "ra") spec.response_address_field = spec.field_count;
    spec.fields[spec.field_count++] = f;
  }
  spec.has_reply = has_reply;
  for (const FieldSpec& f : reply_fields) spec.reply_fields[spec.reply_field_count++] = f;
  return spec;
}
OpcodeSpec Query(Opcode op, const char* name, std::initializer_list<FieldSpec> fields,
                 std::initializer_list<FieldSpec> reply_fields) {
  return Row(op, name, fields, reply_fields, true);
}

using O = Opcode;

// §4.1 / §4.2, one row per opcode; ranges as stated there (line citations in the reference).
const std::array<OpcodeSpec, kOpcodeCount>& Table() {
  static const std::array<OpcodeSpec, kOpcodeCount> table = {
      // L505-512: value 0..255; only motnr 0/2/4 effective (pair), other motnr still encodable.
      Row(O::kPeakCurrent, "peak_current", {Motnr(), T("value", kU8, 1)}),
      // L514-528: indices 0..8, T0 1..65535 × 2 ms.
      Row(O::kCurrentControl, "current_control",
          {Motnr(), F("i0", kU8, 1, 0, 8), F("i1", kU8, 2, 0, 8), F("i2", kU8, 3, 0, 8),
           F("i3", kU8, 4, 0, 8), F("t0", kU16, 5, 1, 65535)}),
      Row(O::kVelocitySetting, "velocity_setting", {F("clkdiv", kU8, 0, 0, 31)}),  // L530-535
      // L537-546: vmin 0..511, vstart 1..511 (G-08), div 0..3.
      Row(O::kStartingVelocity, "starting_velocity",
          {Motnr(), F("vmin", kU16, 1, 0, 511), F("vstart", kU16, 3, 1, 511),
           F("div", kU8, 5, 0, 3)}),
      // L550-561: amax 1..32767, vmax 1..511.
      Row(O::kSetRamp, "set_ramp",
          {Motnr(), F("amax", kU16, 1, 1, 32767), F("vmax", kU16, 3, 1, 511)}),
      // L563-603: poslimit 0..0x7FFFFFF (G-37), motor type low/high byte.
      Row(O::kMotorParameters, "motor_parameters",
          {Motnr(), F("poslimit", kU32, 1, 0, 0x7FFFFFF), T("motor_type_low", kU8, 5),
           T("motor_type_high", kU8, 6)}),
      // L607-616: vrefmax 1..511, debounce mask, P5 bit 0 = stop after search.
      Row(O::kReferenceParameters, "reference_parameters",
          {Motnr(), F("vrefmax", kU16, 1, 1, 511), T("debounce_mask", kU16, 3),
           Bit("stop_after_search", 5)}),
      // L618-625: pointer 0, 4, 8, 12 and four entries.
      Row(O::kWriteTable, "write_table",
          {F("index", kU8, 0, 0, 12, 4), T("entry0", kU8, 1), T("entry1", kU8, 2),
           T("entry2", kU8, 3), T("entry3", kU8, 4)}),
      Row(O::kNullOffset, "null_offset",  // L627-634
          {Motnr(), T("nulloffset", kI32, 1), T("testnullrange", kU16, 5)}),
      Row(O::kPiParameters, "pi_parameters",  // L636-645
          {Motnr(), F("propdiv", kU8, 1, 1, 255), F("intdiv", kU16, 2, 1, 32767),
           F("intclip", kU16, 4, 1, 32767), T("intinpclip", kU8, 6)}),
      // L649-663: reply motnr, posact, action, stop flag.
      Query(
          O::kQueryPosition, "query_position", {Motnr(), Ra(1)},
          {T("motnr", kU8, 0), T("posact", kI32, 1), T("action", kU8, 5), T("stop_flag", kU8, 6)}),
      // L665-676: reply motnr, vact, action; P4-P6 undefined (G-02).
      Query(O::kQueryVelocity, "query_velocity", {Motnr(), Ra(1)},
            {T("motnr", kU8, 0), T("vact", kI16, 1), T("action", kU8, 3)}),
      Row(O::kStartReferenceSearch, "start_reference_search", {Motnr()}),   // L678-685
      Row(O::kStartRamp, "start_ramp", {Motnr(), T("target", kI32, 1)}),    // L689-701
      Row(O::kActivatePi, "activate_pi", {Motnr(), T("target", kI32, 1)}),  // L703-709
      Row(O::kStartRotation, "start_rotation",                              // L711-718
          {Motnr(), F("velocity", kI16, 1, -511, 511)}),
      Row(O::kSetTarget, "set_target", {Motnr(), T("target", kI32, 1)}),        // L720-726
      Row(O::kSetPosition, "set_position", {Motnr(), T("position", kI32, 1)}),  // L728-734
      // L738-756: reply actions of motors 0..5; P6 undefined (G-02).
      Query(O::kQueryActivities, "query_activities", {Ra(0), Mask("delay_mask", 1)},
            {T("action0", kU8, 0), T("action1", kU8, 1), T("action2", kU8, 2), T("action3", kU8, 3),
             T("action4", kU8, 4), T("action5", kU8, 5)}),
      Row(O::kStartRampParallel, "start_ramp_parallel", {Mask("start_mask", 0)}),  // L758-763
      Row(O::kStopMotors, "stop_motors", {Mask("stop_mask", 0)}),                  // L765-771
      // L775-792: channel 0..7; reply channel, analogue value, ref bits, TTLIO1; P6 undefined.
      Query(O::kReadInputs, "read_inputs", {F("channel", kU8, 0, 0, 7), Ra(1)},
            {T("channel", kU8, 0), T("analog", kU16, 1), T("ref_input", kU8, 3),
             T("ref_inputs", kU8, 4), T("ttlio1", kU8, 5)}),
      // L794-801: channel of a motor's analogue input (decision 1014), limits as u16.
      Row(O::kAnalogStopLimits, "analog_stop_limits",
          {F("channel", kU8, 0, 0, kMotorCount - 1), T("min_left", kU16, 1),
           T("max_right", kU16, 3)}),
      Row(O::kSetOutputs, "set_outputs",  // L803-814: bit 0 of P0..P3
          {Bit("ttlout1_level", 0), Bit("ttlio1_direction", 1), Bit("ttlio1_level", 2),
           Bit("ttlout1_ready", 3)}),
      Row(O::kReadyOutput, "ready_output",  // L816-825
          {Mask("active_mask", 0), Mask("reference_mask", 1)}),
      // L829-833: divisor = 1 250 000 / baud (0 would divide by zero), switchover 1..1000.
      Row(O::kSetBaudRate, "set_baud_rate",
          {F("divisor", kU16, 0, 1, 65535), F("switchover", kU16, 2, 1, 1000)}),
      Row(O::kSetPacketTimeout, "set_packet_timeout",  // L835-838
          {F("timeout", kU16, 0, 2, 65535)}),
      Row(O::kChangeAddress, "change_address",  // L840-843, G-05: 1..255
          {F("new_address", kU8, 0, 1, 255)}),
      // L845-855: reply fw revision, reset flag, temperature, serial; P5-P6 undefined.
      Query(O::kUnitInformation, "unit_information", {Ra(0)},
            {T("firmware", kU8, 0), T("reset_flag", kU8, 1), T("temperature", kI8, 2),
             T("serial", kU16, 3)}),
      // L857-869: reply send-buffer fill and CTS; P2-P6 undefined.
      Query(O::kRs232Tunnel, "rs232_tunnel",
            {Ra(0), T("tunnel_address", kU8, 1), F("packet_size", kU8, 2, 0, 8)},
            {T("tx_fill", kU8, 0), T("cts", kU8, 1)}),
      // L873-893: action bits 0..3; reply status bits.
      Query(O::kPowerDown, "power_down", {Ra(0), F("actions", kU8, 1, 0, 0x0F)},
            {T("status", kU8, 0)}),
      Row(O::kHardwareReset, "hardware_reset", {T("value", kU8, 0)}),  // L895-902, G-21
      Row(O::kInterpolate, "interpolate", {Mask("motor_mask", 0)}),    // L904-912
      // Service functions L916-982 (never sent by the gateway, encodable for the simulator).
      Query(O::kFlashEnable, "flash_enable", {Ra(0), T("magic", kU32, 1)}, {T("ok", kU8, 0)}),
      Row(O::kFlashProgram, "flash_program",
          {T("data0", kU8, 0), T("data1", kU8, 1), T("data2", kU8, 2), T("data3", kU8, 3),
           T("data4", kU8, 4), T("data5", kU8, 5), T("data6", kU8, 6)}),
      Query(O::kFlashChecksum, "flash_checksum", {Ra(0)}, {T("checksum", kU16, 0)}),
      Query(O::kFlashRead, "flash_read", {Ra(0)},
            {T("data0", kU8, 0), T("data1", kU8, 1), T("data2", kU8, 2), T("data3", kU8, 3),
             T("data4", kU8, 4), T("data5", kU8, 5), T("data6", kU8, 6)}),
      Query(O::kEepromWrite, "eeprom_write",
            {Ra(0), T("magic", kU16, 1), T("eeprom_address", kU16, 3), T("value", kU16, 5)},
            {T("ok", kU8, 0)}),
      // G-22: printed as a copy of $F6 (decision 1016).
      Query(O::kEepromRead, "eeprom_read",
            {Ra(0), T("magic", kU16, 1), T("eeprom_address", kU16, 3), T("value", kU16, 5)},
            {T("ok", kU8, 0)}),
  };
  return table;
}

std::string Hex(unsigned v) {
  static const char* const kDigits = "0123456789ABCDEF";
  std::string s = "0x";
  s += kDigits[(v >> 4) & 0xF];
  s += kDigits[v & 0xF];
  return s;
}

absl::Status CheckField(const char* op, const FieldSpec& f, int64_t v) {
  const std::string where = absl::StrCat(op, ".", f.name, ": ", v);
  if (v > f.max) return absl::InvalidArgumentError(absl::StrCat(where, " exceeds ", f.max));
  if (v < f.min) return absl::InvalidArgumentError(absl::StrCat(where, " below ", f.min));
  if (f.multiple_of > 1 && v % f.multiple_of != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, " is not a multiple of ", static_cast<int>(f.multiple_of)));
  }
  return absl::OkStatus();
}

absl::Status CheckFields(const char* op, std::span<const FieldSpec> fields,
                         const std::array<int64_t, kParamCount>& values) {
  for (size_t i = 0; i < fields.size(); ++i) {
    if (auto s = CheckField(op, fields[i], values[i]); !s.ok()) return s;
  }
  return absl::OkStatus();
}

// Writes the fields into the 7 parameter bytes, least significant byte first (L475, L503).
std::array<uint8_t, kParamCount> PackParams(std::span<const FieldSpec> fields,
                                            const std::array<int64_t, kParamCount>& values) {
  std::array<uint8_t, kParamCount> p{};  // unused bytes 00 (L375, L410-411)
  for (size_t i = 0; i < fields.size(); ++i) {
    const uint64_t raw = static_cast<uint64_t>(values[i]);  // two's complement for signed
    for (size_t b = 0; b < FieldWidth(fields[i].type); ++b) {
      p[fields[i].param + b] = static_cast<uint8_t>((raw >> (8 * b)) & 0xFF);
    }
  }
  return p;
}

std::array<int64_t, kParamCount> UnpackParams(std::span<const FieldSpec> fields,
                                              std::span<const uint8_t> p) {
  std::array<int64_t, kParamCount> values{};
  for (size_t i = 0; i < fields.size(); ++i) {
    const size_t width = FieldWidth(fields[i].type);
    uint64_t raw = 0;
    for (size_t b = 0; b < width; ++b) raw |= uint64_t{p[fields[i].param + b]} << (8 * b);
    int64_t v = static_cast<int64_t>(raw);
    const FieldType t = fields[i].type;
    if ((t == kI8 || t == kI16 || t == kI32) && (raw >> (8 * width - 1)) != 0) {
      v -= int64_t{1} << (8 * width);  // sign extension
    }
    values[i] = v;
  }
  return values;
}

absl::Status CheckAddress(const char* op, unsigned address) {
  if (address == 0) return absl::InvalidArgumentError(absl::StrCat(op, ".address: 0 below 1"));
  return absl::OkStatus();
}

absl::StatusOr<int64_t> Lookup(const char* op, std::span<const FieldSpec> fields,
                               const std::array<int64_t, kParamCount>& values,
                               std::string_view field) {
  for (size_t i = 0; i < fields.size(); ++i) {
    if (field == fields[i].name) return values[i];
  }
  return absl::NotFoundError(absl::StrCat(op, ": no field ", std::string(field)));
}

absl::StatusOr<const OpcodeSpec*> ReplySpec(uint8_t byte) {
  auto spec = FindOpcode(byte);
  if (!spec.ok())
    return absl::InvalidArgumentError(absl::StrCat("reply: ", spec.status().message()));
  if (!(*spec)->has_reply) {
    return absl::InvalidArgumentError(
        absl::StrCat("reply: opcode ", Hex(byte), " (", (*spec)->name, ") produces no reply"));
  }
  return *spec;
}

}  // namespace

size_t FieldWidth(FieldType type) {
  switch (type) {
    case FieldType::kU8:
    case FieldType::kI8:
      return 1;
    case FieldType::kU16:
    case FieldType::kI16:
      return 2;
    case FieldType::kU32:
    case FieldType::kI32:
      return 4;
  }
  return 1;
}

std::span<const OpcodeSpec> OpcodeTable() { return Table(); }

absl::StatusOr<const OpcodeSpec*> FindOpcode(uint8_t byte) {
  for (const OpcodeSpec& spec : Table()) {
    if (static_cast<uint8_t>(spec.opcode) == byte) return &spec;
  }
  return absl::NotFoundError(absl::StrCat("unknown opcode ", Hex(byte)));
}

const OpcodeSpec& SpecOf(Opcode opcode) {
  auto spec = FindOpcode(static_cast<uint8_t>(opcode));
  return spec.ok() ? **spec : Table()[0];
}

absl::Status ValidateCommand(const Command& command) {
  auto spec = FindOpcode(static_cast<uint8_t>(command.opcode));
  if (!spec.ok())
    return absl::InvalidArgumentError(absl::StrCat("command: ", spec.status().message()));
  if (auto s = CheckAddress((*spec)->name, command.address); !s.ok()) return s;
  return CheckFields((*spec)->name, (*spec)->Fields(), command.values);
}

absl::Status ValidateReply(const Reply& reply) {
  auto spec = ReplySpec(static_cast<uint8_t>(reply.opcode));
  if (!spec.ok()) return spec.status();
  return CheckFields((*spec)->name, (*spec)->ReplyFields(), reply.values);
}

absl::StatusOr<Command> MakeCommand(uint8_t address, Opcode opcode,
                                    std::initializer_list<int64_t> values) {
  auto spec = FindOpcode(static_cast<uint8_t>(opcode));
  if (!spec.ok())
    return absl::InvalidArgumentError(absl::StrCat("command: ", spec.status().message()));
  if (values.size() != (*spec)->field_count) {
    return absl::InvalidArgumentError(absl::StrCat((*spec)->name, ": ", values.size(),
                                                   " values, expected ", (*spec)->field_count));
  }
  Command c{address, opcode, {}};
  size_t i = 0;
  for (int64_t v : values) c.values[i++] = v;
  if (auto s = ValidateCommand(c); !s.ok()) return s;
  return c;
}

absl::StatusOr<int64_t> GetField(const Command& command, std::string_view field) {
  const OpcodeSpec& spec = SpecOf(command.opcode);
  return Lookup(spec.name, spec.Fields(), command.values, field);
}

absl::Status SetField(Command& command, std::string_view field, int64_t value) {
  const OpcodeSpec& spec = SpecOf(command.opcode);
  for (size_t i = 0; i < spec.field_count; ++i) {
    if (field == spec.fields[i].name) {
      if (auto s = CheckField(spec.name, spec.fields[i], value); !s.ok()) return s;
      command.values[i] = value;
      return absl::OkStatus();
    }
  }
  return absl::NotFoundError(absl::StrCat(spec.name, ": no field ", std::string(field)));
}

absl::StatusOr<int64_t> GetField(const Reply& reply, std::string_view field) {
  const OpcodeSpec& spec = SpecOf(reply.opcode);
  return Lookup(spec.name, spec.ReplyFields(), reply.values, field);
}

absl::StatusOr<std::vector<uint8_t>> EncodeCommand(const Command& command) {
  if (auto s = ValidateCommand(command); !s.ok()) return s;
  const OpcodeSpec& spec = SpecOf(command.opcode);
  const auto p = PackParams(spec.Fields(), command.values);
  std::vector<uint8_t> out;
  out.reserve(kCommandSize);
  out.push_back(command.address);                       // byte 0: A
  out.push_back(static_cast<uint8_t>(command.opcode));  // byte 1: CMD
  for (uint8_t b : p) out.push_back(b);                 // bytes 2..8: P0..P6
  return out;
}

absl::StatusOr<Command> DecodeCommand(std::span<const uint8_t> bytes) {
  if (bytes.size() != kCommandSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("command: ", bytes.size(), " bytes, expected ", kCommandSize));
  }
  auto spec = FindOpcode(bytes[1]);
  if (!spec.ok())
    return absl::InvalidArgumentError(absl::StrCat("command: ", spec.status().message()));
  Command c{bytes[0], (*spec)->opcode, UnpackParams((*spec)->Fields(), bytes.subspan(2))};
  if (auto s = ValidateCommand(c); !s.ok()) return s;
  return c;
}

absl::Status ValidateResponseAddress(uint8_t response_address) {
  if (response_address == 0) {
    return absl::InvalidArgumentError("response_address: 0 is the stray reset byte (L228)");
  }
  auto spec = FindOpcode(response_address);
  if (spec.ok() && (*spec)->has_reply) {
    return absl::InvalidArgumentError(
        absl::StrCat("response_address: ", Hex(response_address), " equals a reply opcode"));
  }
  return absl::OkStatus();
}

absl::StatusOr<ReplyFraming> DetectReplyFraming(uint8_t first_byte, uint8_t response_address) {
  if (auto s = ValidateResponseAddress(response_address); !s.ok()) return s;
  if (first_byte == response_address) return ReplyFraming::kR9;
  auto spec = FindOpcode(first_byte);
  if (spec.ok() && (*spec)->has_reply) return ReplyFraming::kR8;
  return absl::InvalidArgumentError(absl::StrCat("reply framing: first byte ", Hex(first_byte),
                                                 " is neither RA ", Hex(response_address),
                                                 " nor a reply opcode"));
}

size_t ReplySize(ReplyFraming framing) {
  return framing == ReplyFraming::kR9 ? kReplyBodySize + 1 : kReplyBodySize;
}

absl::StatusOr<std::vector<uint8_t>> EncodeReply(const Reply& reply, ReplyFraming framing) {
  if (auto s = ValidateReply(reply); !s.ok()) return s;
  std::vector<uint8_t> out;
  out.reserve(ReplySize(framing));
  if (framing == ReplyFraming::kR9) {
    if (auto s = ValidateResponseAddress(reply.response_address); !s.ok()) return s;
    out.push_back(reply.response_address);
  }
  out.push_back(static_cast<uint8_t>(reply.opcode));
  // Undefined reply bytes are sent as 00 (G-02, decision 1012).
  for (uint8_t b : PackParams(SpecOf(reply.opcode).ReplyFields(), reply.values)) out.push_back(b);
  return out;
}

absl::StatusOr<Reply> DecodeReply(std::span<const uint8_t> bytes, ReplyFraming framing) {
  if (bytes.size() != ReplySize(framing)) {
    return absl::InvalidArgumentError(
        absl::StrCat("reply: ", bytes.size(), " bytes, expected ", ReplySize(framing)));
  }
  Reply r;
  if (framing == ReplyFraming::kR9) {
    if (auto s = ValidateResponseAddress(bytes[0]); !s.ok()) return s;
    r.response_address = bytes[0];
    bytes = bytes.subspan(1);
  }
  auto spec = ReplySpec(bytes[0]);
  if (!spec.ok()) return spec.status();
  r.opcode = (*spec)->opcode;
  r.values = UnpackParams((*spec)->ReplyFields(), bytes.subspan(1));
  return r;
}

absl::StatusOr<uint16_t> CommandCanId(uint8_t address) {
  // Address 0 is invalid on CAN (L289): IDs $008 ... $7F8.
  if (address == 0) return absl::InvalidArgumentError("can.address: 0 below 1");
  return static_cast<uint16_t>(address << 3);
}

absl::StatusOr<uint16_t> ReplyCanId(uint8_t response_address) {
  if (response_address == 0) return absl::InvalidArgumentError("can.response_address: 0 below 1");
  return static_cast<uint16_t>(response_address << 3);  // L291
}

absl::StatusOr<uint16_t> TunnelTransmitCanId(uint8_t address) {
  auto id = CommandCanId(address);
  if (!id.ok()) return id.status();
  return static_cast<uint16_t>(*id + 1);  // L315
}

absl::StatusOr<uint16_t> TunnelReceiveCanId(uint8_t tunnel_address) {
  if (tunnel_address == 0) return absl::InvalidArgumentError("can.tunnel_address: 0 below 1");
  return static_cast<uint16_t>(tunnel_address << 3);  // L317, L863, G-30
}

absl::StatusOr<CanFrame> EncodeCommandCan(const Command& command) {
  auto wire = EncodeCommand(command);
  if (!wire.ok()) return wire.status();
  CanFrame f;
  f.id = static_cast<uint16_t>(command.address << 3);
  f.dlc = 8;  // always DLC 8, zero padded (G-27, decision 1015)
  for (size_t i = 0; i < 8; ++i) f.data[i] = (*wire)[i + 1];  // serial word without A (§3.1)
  return f;
}

static absl::Status CheckCanFrame(const CanFrame& frame, const char* what) {
  if (frame.id > 0x7FF || (frame.id & 0x7) != 0 || frame.id == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": identifier ", frame.id, " is not an address << 3 (L289)"));
  }
  if (frame.dlc != 8) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": dlc ", frame.dlc, ", expected 8"));
  }
  return absl::OkStatus();
}

absl::StatusOr<Command> DecodeCommandCan(const CanFrame& frame) {
  if (auto s = CheckCanFrame(frame, "can command"); !s.ok()) return s;
  std::array<uint8_t, kCommandSize> word{};
  word[0] = static_cast<uint8_t>(frame.id >> 3);
  for (size_t i = 0; i < 8; ++i) word[i + 1] = frame.data[i];
  return DecodeCommand(word);
}

absl::StatusOr<CanFrame> EncodeReplyCan(const Reply& reply) {
  auto id = ReplyCanId(reply.response_address);
  if (!id.ok()) return id.status();
  auto body = EncodeReply(reply, ReplyFraming::kR8);
  if (!body.ok()) return body.status();
  CanFrame f;
  f.id = *id;
  f.dlc = 8;
  for (size_t i = 0; i < 8; ++i) f.data[i] = (*body)[i];
  return f;
}

absl::StatusOr<Reply> DecodeReplyCan(const CanFrame& frame) {
  if (auto s = CheckCanFrame(frame, "can reply"); !s.ok()) return s;
  auto reply = DecodeReply(frame.data, ReplyFraming::kR8);
  if (!reply.ok()) return reply.status();
  reply->response_address = static_cast<uint8_t>(frame.id >> 3);
  return reply;
}

namespace {
// Rates a termios port takes that a 1 250 000 / divisor UART reaches within 3 % (§2.1 table;
// 230400 and above miss by more than 8 %).
constexpr int kDivisorBauds[] = {1200, 1800, 2400, 4800, 9600, 19200, 38400, 57600, 115200};
}  // namespace

int DivisorOfBaud(int baud) { return baud <= 0 ? 0 : (1'250'000 + baud / 2) / baud; }

absl::StatusOr<int> BaudOfDivisor(int64_t divisor) {
  std::string accepted;
  for (int baud : kDivisorBauds) {
    if (DivisorOfBaud(baud) == divisor) return baud;
    absl::StrAppend(&accepted, accepted.empty() ? "" : ", ", DivisorOfBaud(baud), " (", baud, ")");
  }
  return absl::InvalidArgumentError(
      absl::StrCat("$40.divisor: ", divisor,
                   " is not 1 250 000 / a standard baud rate (§2.1, L832); use one of ", accepted));
}

}  // namespace drivegw::trinamic
