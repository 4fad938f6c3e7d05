// LinMot DeviceNet general-purpose commands: the 102-entry table of linmot-devicenet.md §8.4,
// table-driven command/response encode/decode, toggle helpers and the §8.6 coded errors.
#include "adapters/linmot/devicenet/commands.h"

#include <algorithm>
#include <bit>
#include <cctype>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"

namespace drivegw::linmot::devicenet {
namespace {

using MS = MotorSelect;
using RK = ResponseKind;
using Req = Requirement;

// Value specs (§8.4 "Range" and "Unit"; D-17 where overview and detail disagree).
constexpr ValueSpec X{};
constexpr ValueSpec Pos(const char* name) {
  return ValueSpec{ValueType::kInt16, -32256, 32256, "pos", name, WordKind::kControl};
}
constexpr ValueSpec I16(const char* name, int32_t min, int32_t max, const char* unit) {
  return ValueSpec{ValueType::kInt16, min, max, unit, name, WordKind::kControl};
}
constexpr ValueSpec U16(const char* name, int32_t min, int32_t max, const char* unit) {
  return ValueSpec{ValueType::kUInt16, min, max, unit, name, WordKind::kControl};
}
constexpr ValueSpec Bits(const char* name, WordKind kind) {
  return ValueSpec{ValueType::kBits, 0, 0xFFFF, "bits", name, kind};
}
constexpr ValueSpec Curve() { return U16("curve_number", 0, 63, ""); }

// Row builders. Get: Addressed only, response = value. Set: Addressed + Direct, echo.
constexpr CommandSpec Get(uint8_t id, const char* name, MS ms, ValueSpec response,
                          const char* lines, Req req = Req::kNone) {
  return CommandSpec{id,   name,       CommandKind::kGet, true,  false, ms,    false,
                     X,    RK::kValue, response,          false, req,   false, false,
                     true, lines};
}
constexpr CommandSpec Set(uint8_t id, const char* name, MS ms, ValueSpec request, const char* lines,
                          Req req = Req::kNone, bool serial = false) {
  return CommandSpec{id,      name,      CommandKind::kSet, true,   true, ms,    false,
                     request, RK::kEcho, request,           serial, req,  false, false,
                     true,    lines};
}
// Actions: Addressed + Direct, echo; flags per D-4 / §11.4.
struct ActionFlags {
  bool toggle = false;
  bool serial = false;
  bool trigger_armed = false;
  bool one_shot = false;
  bool documented = true;
  Req req = Req::kNone;
  RK response = RK::kEcho;
};
constexpr CommandSpec Action(uint8_t id, const char* name, MS ms, ValueSpec request,
                             const char* lines, ActionFlags f) {
  return CommandSpec{id,
                     name,
                     CommandKind::kAction,
                     true,
                     true,
                     ms,
                     f.toggle,
                     request,
                     f.response,
                     request,
                     f.serial,
                     f.req,
                     f.trigger_armed,
                     f.one_shot,
                     f.documented,
                     lines};
}
constexpr ActionFlags kOneShot{false, false, false, true, true, Req::kNone, RK::kEcho};
constexpr ActionFlags kToggleOneShot{true, false, false, true, true, Req::kNone, RK::kEcho};
constexpr ActionFlags kSerialToggle{true, true, false, true, true, Req::kNone, RK::kEcho};
constexpr ActionFlags kSerialTrigger{false, true, true, true, true, Req::kNone, RK::kEcho};
constexpr ActionFlags kUndocumented{false, false, false, false, false, Req::kNone, RK::kEcho};

constexpr const char* kCounts = "counts";
constexpr const char* kMa = "23.438 mA";
constexpr const char* kPercent = "0.0244140625 %";

// linmot-devicenet.md §8.4, one row per command, ascending ID. Seed lines in the last column.
constexpr CommandSpec kCommands[] = {
    {0x00, "No Command", CommandKind::kNoCommand, true, true, MS::kSystem, false, X, RK::kDontCare,
     X, false, Req::kNone, false, false, true, "664-682"},
    Get(0x02, "Get Status Low Word", MS::kSystem, Bits("status_low", WordKind::kStatusLow),
        "684-702"),
    Get(0x03, "Get Status High Word", MS::kSystem, Bits("status_high", WordKind::kStatusHigh),
        "704-724"),
    Get(0x04, "Get Control Word", MS::kSystem, Bits("control_word", WordKind::kControl), "726-744"),
    Set(0x05, "Set Control Word", MS::kSystem, Bits("control_word", WordKind::kControl), "746-766"),
    Get(0x06, "Get Warn State", MS::kOptional, Bits("warn_state", WordKind::kSystemWarnState),
        "768-794"),
    Action(0x07, "Reset Warn State", MS::kSystem, X, "796-816", kOneShot),
    Get(0x08, "Get Error State", MS::kOptional, Bits("error_state", WordKind::kSystemErrorState),
        "818-860"),
    Action(0x09, "Reset Error State", MS::kOptional, X, "862-888", kOneShot),  // D-22
    Get(0x0A, "Get Coded Error", MS::kSystem, U16("coded_error", 0, 0xFFFF, "code"), "890-906"),
    Action(0x0B, "Reset Coded Error", MS::kSystem, X, "908-926", kOneShot),
    Get(0x0C, "Get Controller IO", MS::kSystem, Bits("controller_io", WordKind::kControllerIo),
        "928-948"),
    {0x0D, "Set Controller IO", CommandKind::kSet, true, true, MS::kSystem, false,
     Bits("controller_io_outputs", WordKind::kControllerIo), RK::kActualIo,
     Bits("controller_io", WordKind::kControllerIo), false, Req::kNone, false, false, true,
     "950-970"},
    Action(0x0F, "Reset Controller", MS::kSystem, X, "972-984",
           ActionFlags{false, false, false, true, true, Req::kNone, RK::kNoResponse}),
    Get(0x10, "Get Position Setpoint", MS::kRequired, Pos("position_setpoint"), "986-1011"),
    Set(0x11, "Set Position Setpoint", MS::kRequired, Pos("position_setpoint"), "1013-1045",
        Req::kNone, /*serial=*/true),
    Action(0x12, "Set Position Setpoint Waiting for Trigger", MS::kRequired,
           Pos("position_setpoint"), "1047-1079",
           ActionFlags{false, true, true, false, true, Req::kNone, RK::kEcho}),
    Action(0x13, "Increment Position Setpoint", MS::kRequired, Pos("increment"), "1081-1113",
           kSerialToggle),
    Action(0x14, "Increment Position Setpoint Waiting for Trigger", MS::kRequired, Pos("increment"),
           "1115-1147", kSerialTrigger),
    Action(0x15, "Move Home Position", MS::kRequired, Pos("home_position"), "1149-1181",
           kToggleOneShot),
    Get(0x18, "Get Actual Position", MS::kRequired, I16("actual_position", -32768, 32767, "pos"),
        "1183-1209"),  // D-17: full INT16
    Action(0x19, "Set Actual Position", MS::kRequired, Pos("actual_position"), "1211-1244",
           kToggleOneShot),
    Action(0x20, "Start Curve", MS::kRequired, Curve(), "1246-1268", kSerialToggle),
    Action(0x21, "Start Curve Waiting for Trigger", MS::kRequired, Curve(), "1270-1292",
           kSerialTrigger),
    Action(0x22, "Start Curve Incremental", MS::kRequired, Curve(), "1294-1316", kSerialToggle),
    Action(0x23, "Start Curve Incremental Waiting for Trigger", MS::kRequired, Curve(), "1318-1340",
           kSerialTrigger),
    Get(0x24, "Get Rise Curve Number", MS::kRequired, Curve(), "1342-1363"),
    Set(0x25, "Set Rise Curve Number", MS::kRequired, Curve(), "1365-1387"),
    Get(0x26, "Get Fall Curve Number", MS::kRequired, Curve(), "1389-1411"),
    Set(0x27, "Set Fall Curve Number", MS::kRequired, Curve(), "1413-1435"),
    Get(0x28, "Get Curve Offset", MS::kRequired, Pos("curve_offset"), "1437-1463"),
    Set(0x29, "Set Curve Offset", MS::kRequired, Pos("curve_offset"), "1465-1497"),
    Get(0x2A, "Get Curve Amplitude", MS::kRequired, U16("curve_amplitude", 0, 4096, kPercent),
        "1499-1521"),
    Set(0x2B, "Set Curve Amplitude", MS::kRequired, U16("curve_amplitude", 0, 4096, kPercent),
        "1523-1547"),
    Get(0x2C, "Get Curve Speed", MS::kRequired, U16("curve_speed", 0, 4096, kPercent), "1549-1571"),
    Set(0x2D, "Set Curve Speed", MS::kRequired, U16("curve_speed", 0, 4096, kPercent), "1573-1597"),
    // Current ranges: the 1000 series' (widest); the 100 series' 0..128 / -64..64 is the
    // drive's check (decision 906).
    Get(0x30, "Get Controller Maximal Current", MS::kRequired, U16("maximal_current", 0, 256, kMa),
        "1599-1619"),
    Set(0x31, "Set Controller Maximal Current", MS::kRequired, U16("maximal_current", 0, 256, kMa),
        "1621-1645"),
    Get(0x32, "Get Controller Current Offset", MS::kRequired, I16("current_offset", -127, 128, kMa),
        "1647-1667"),
    Set(0x33, "Set Controller Current Offset", MS::kRequired, I16("current_offset", -127, 128, kMa),
        "1669-1693"),
    Get(0x34, "Get Controller P", MS::kRequired, U16("p_gain", 0, 32640, "2.3438 mA/mm"),
        "1695-1717"),
    Set(0x35, "Set Controller P", MS::kRequired, U16("p_gain", 0, 32640, "2.3438 mA/mm"),
        "1719-1743"),
    Get(0x36, "Get Controller D", MS::kRequired, U16("d_gain", 0, 32640, "15 mA*s/m"), "1745-1767"),
    Set(0x37, "Set Controller D", MS::kRequired, U16("d_gain", 0, 32640, "15 mA*s/m"), "1769-1793"),
    Get(0x38, "Get Controller I", MS::kRequired, U16("i_gain", 0, 32640, "0.0457 A/(mm*s)"),
        "1795-1817"),
    Set(0x39, "Set Controller I", MS::kRequired, U16("i_gain", 0, 32640, "0.0457 A/(mm*s)"),
        "1819-1843"),
    Get(0x3A, "Get Controller FF Friction", MS::kRequired, U16("ff_friction", 0, 255, kMa),
        "1845-1867"),
    Set(0x3B, "Set Controller FF Friction", MS::kRequired, U16("ff_friction", 0, 255, kMa),
        "1869-1893"),
    Get(0x3C, "Get Controller FF Acceleration", MS::kRequired,
        U16("ff_acceleration", 0, 32640, "100 mA/(m/s^2)"), "1895-1915"),
    Set(0x3D, "Set Controller FF Acceleration", MS::kRequired,
        U16("ff_acceleration", 0, 32640, "100 mA/(m/s^2)"), "1917-1941"),
    Get(0x3E, "Get Controller FF Deceleration", MS::kRequired,
        U16("ff_deceleration", 0, 32640, "100 mA/(m/s^2)"), "1943-1965"),
    Set(0x3F, "Set Controller FF Deceleration", MS::kRequired,
        U16("ff_deceleration", 0, 32640, "100 mA/(m/s^2)"), "1967-1991"),
    Get(0x40, "Get Minimal Position", MS::kRequired, Pos("minimal_position"), "1993-2019"),
    Set(0x41, "Set Minimal Position", MS::kRequired, Pos("minimal_position"), "2021-2053"),
    Get(0x42, "Get Maximal Position", MS::kRequired, Pos("maximal_position"), "2055-2081"),
    Set(0x43, "Set Maximal Position", MS::kRequired, Pos("maximal_position"), "2083-2115"),
    Get(0x44, "Get Pos Range Min", MS::kRequired, Pos("pos_range_min"), "2117-2143"),
    Set(0x45, "Set Pos Range Min", MS::kRequired, Pos("pos_range_min"), "2145-2177"),
    Get(0x46, "Get Pos Range Max", MS::kRequired, Pos("pos_range_max"), "2179-2208"),
    Set(0x47, "Set Pos Range Max", MS::kRequired, Pos("pos_range_max"), "2210-2242"),
    Get(0x48, "Get In Position -", MS::kRequired, U16("in_position_minus", 2, 511, "pos"),
        "2244-2273"),
    Set(0x49, "Set In Position -", MS::kRequired, U16("in_position_minus", 2, 511, "pos"),
        "2275-2307"),
    Get(0x4A, "Get In Position +", MS::kRequired, U16("in_position_plus", 2, 511, "pos"),
        "2309-2334"),
    Set(0x4B, "Set In Position +", MS::kRequired, U16("in_position_plus", 2, 511, "pos"),
        "2336-2368"),
    Get(0x4C, "Get Following Error -", MS::kRequired, U16("following_error_minus", 4, 511, "pos"),
        "2370-2396"),
    Set(0x4D, "Set Following Error -", MS::kRequired, U16("following_error_minus", 4, 511, "pos"),
        "2398-2430"),
    Get(0x4E, "Get Following Error +", MS::kRequired, U16("following_error_plus", 4, 511, "pos"),
        "2432-2458"),
    Set(0x4F, "Set Following Error +", MS::kRequired, U16("following_error_plus", 4, 511, "pos"),
        "2460-2492"),
    Get(0x50, "Get Filter Max Speed", MS::kRequired, U16("max_speed", 6, 24576, "190.735 um/s"),
        "2494-2520"),
    Set(0x51, "Set Filter Max Speed", MS::kRequired, U16("max_speed", 6, 24576, "190.735 um/s"),
        "2522-2554"),
    Get(0x52, "Get Filter Max Acceleration", MS::kRequired,
        U16("max_acceleration", 1, 1536, "238.419 mm/s^2"), "2556-2582"),  // D-17: detail 1..
    Set(0x53, "Set Filter Max Acceleration", MS::kRequired,
        U16("max_acceleration", 1, 1536, "238.419 mm/s^2"), "2584-2616"),
    Get(0x56, "Get 0 V Position", MS::kRequired, Pos("zero_volt_position"), "2618-2641"),
    Set(0x57, "Set 0 V Position", MS::kRequired, Pos("zero_volt_position"), "2643-2675"),
    Get(0x58, "Get 10 V Position", MS::kRequired, Pos("ten_volt_position"), "2677-2703"),
    Set(0x59, "Set 10 V Position", MS::kRequired, Pos("ten_volt_position"), "2705-2737"),
    Get(0x5A, "Get '0' Position", MS::kRequired, Pos("two_point_0_position"),
        "2739-2768"),  // D-31
    Set(0x5B, "Set '0' Position", MS::kRequired, Pos("two_point_0_position"), "2770-2802"),
    Get(0x5C, "Get '1' Position", MS::kRequired, Pos("two_point_1_position"), "2804-2830"),
    Set(0x5D, "Set '1' Position", MS::kRequired, Pos("two_point_1_position"), "2832-2864"),
    Get(0x60, "Get Encoder 1 Position", MS::kSystem,
        I16("encoder_1_position", -32768, 32767, kCounts), "2866-2886",
        Req::kMasterEncoder),  // D-17: detail INT16
    Set(0x61, "Set Encoder 1 Position", MS::kSystem,
        I16("encoder_1_position", -32768, 32767, kCounts), "2888-2912", Req::kMasterEncoder),
    Get(0x62, "Get CAM Length", MS::kRequired, U16("cam_length", 16, 32767, kCounts), "2914-2936",
        Req::kMasterEncoder),
    Set(0x63, "Set CAM Length", MS::kRequired, U16("cam_length", 16, 32767, kCounts), "2938-2962",
        Req::kMasterEncoder),
    Get(0x64, "Get Extended IO", MS::kSystem, Bits("extended_io", WordKind::kExtendedIo),
        "2964-2982", Req::kEncoderOrDigitalIo),
    {0x65, "Set Extended IO", CommandKind::kSet, true, true, MS::kSystem, false,
     Bits("extended_outputs", WordKind::kExtendedIo), RK::kActualIo,
     Bits("extended_io", WordKind::kExtendedIo), false, Req::kEncoderOrDigitalIo, false, false,
     true, "2984-3004"},
    // MAX_COUNT is not given: the whole UInt16 (decision 906).
    Get(0x66, "Get Encoder 1 Offset", MS::kSystem, U16("encoder_1_offset", 0, 0xFFFF, kCounts),
        "3006-3026", Req::kMasterEncoder),
    Set(0x67, "Set Encoder 1 Offset", MS::kSystem, U16("encoder_1_offset", 0, 0xFFFF, kCounts),
        "3028-3052", Req::kMasterEncoder),
    Action(0x68, "Start CAM at Counts", MS::kUndefined, U16("counts", 0, 0xFFFF, kCounts), "645",
           ActionFlags{false, false, false, false, false, Req::kMasterEncoder, RK::kEcho}),
    Get(0x6A, "Get CAM Delay", MS::kRequired, U16("cam_delay", 0, 32767, kCounts), "3054-3076",
        Req::kMasterEncoder),
    Set(0x6B, "Set CAM Delay", MS::kRequired, U16("cam_delay", 0, 32767, kCounts), "3078-3102",
        Req::kMasterEncoder),
    Action(0x6D, "Set Continuous Curve Mode", MS::kUndefined, X, "648", kUndocumented),
    Action(0x6E, "Set Serial Run Mode", MS::kRequired, X, "3104-3122", kOneShot),  // D-18
    Action(0x6F, "Set Master Encoder Run Mode", MS::kRequired, X, "3124-3142", kOneShot),
    Get(0x70, "Get Direct Out 1 Variable", MS::kRequired, U16("variable", 0, 7, "code"),
        "3144-3174"),
    Set(0x71, "Set Direct Out 1 Variable", MS::kRequired, U16("variable", 0, 7, "code"),
        "3176-3208"),
    Get(0x72, "Get Direct Out 2 Variable", MS::kRequired, U16("variable", 0, 7, "code"),
        "3210-3240"),
    Set(0x73, "Set Direct Out 2 Variable", MS::kRequired, U16("variable", 0, 7, "code"),
        "3242-3274"),
    {0x74, "Get Direct Out 1 Address", CommandKind::kGet, true, false, MS::kUndefined, false, X,
     RK::kValue, U16("address", 0, 7, ""), false, Req::kNone, false, false, false, "655"},
    Action(0x75, "Set Direct Out 1 Address", MS::kUndefined, U16("address", 0, 7, ""), "656",
           kUndocumented),
    {0x76, "Get Direct Out 2 Address", CommandKind::kGet, true, false, MS::kUndefined, false, X,
     RK::kValue, U16("address", 0, 7, ""), false, Req::kNone, false, false, false, "657"},
    Action(0x77, "Set Direct Out 2 Address", MS::kUndefined, U16("address", 0, 7, ""), "658",
           kUndocumented),
};
static_assert(std::size(kCommands) == kCommandCount, "§8.4 lists 102 commands");

constexpr bool Ascending() {
  for (size_t i = 1; i < std::size(kCommands); ++i) {
    if (kCommands[i - 1].id >= kCommands[i].id) return false;
  }
  return true;
}
static_assert(Ascending(), "kCommands must be sorted by ID");

// §8.6 (seed line 906; D-2: hexadecimal). Triggers are [SEED-INF] from the names.
constexpr CodedError kCodedErrors[] = {
    {0x8100, "Application needs DN servo controller", "DeviceNet firmware on non-DN hardware"},
    {0x8101, "DeviceNet MACID already in use", "failed duplicate MAC ID check"},
    {0x8104, "Processor speed not supported", "hardware mismatch"},
    {0x8108, "Unknown command", "command ID not in the command table"},
    {0x8110, "Drive not specified", "motor command without a motor select bit"},
    {0x8111, "Drive not master", "command addressed to a motor that is not a master drive"},
    {0x8112, "Drive not in serial mode", "0x11-0x14, 0x20-0x23 while run mode is not serial"},
    {0x8118, "Range error", "value outside the command's range"},
    {0x8120, "Encoder not exists", "encoder/CAM command without master encoder module"},
    {0x8121, "Encoder in SSI mode", "encoder command not allowed in SSI mode"},
    {0x8130, "Curve doesn't exist", "start/select of an undefined curve"},
    {0x8131, "Curve type mismatch", "curve not usable for the command"},
    {0x8132, "Curve processing", "curve command while a curve is running"},
    {0x8140, "CAN no error", "CAN controller last-error code: none"},
    {0x8141, "CAN stuff error", ""},
    {0x8142, "CAN form error", ""},
    {0x8143, "CAN acknowledge error", "no node acknowledged (alone on the bus)"},
    {0x8144, "CAN bit 1 error", ""},
    {0x8145, "CAN CRC error", ""},
    {0x8148, "CAN BOFF error", "bus-off"},
};

std::string Hex2(unsigned v) { return absl::StrFormat("0x%02X", v); }

const char* TypeName(ValueType t) {
  switch (t) {
    case ValueType::kDontCare:
      return "don't care";
    case ValueType::kInt16:
      return "Int16";
    case ValueType::kUInt16:
      return "UInt16";
    case ValueType::kBits:
      return "bit field";
  }
  return "?";
}

// Word 2 from a typed value; OutOfRange when it does not fit the type.
absl::StatusOr<uint16_t> ToWord(const ValueSpec& spec, int32_t value, const std::string& field) {
  switch (spec.type) {
    case ValueType::kDontCare:
      return uint16_t{0};
    case ValueType::kInt16:
      if (value < -32768 || value > 32767) {
        return absl::OutOfRangeError(
            absl::StrCat("devicenet ", field, ": ", value, " outside Int16 -32768..32767"));
      }
      return static_cast<uint16_t>(static_cast<int16_t>(value));
    case ValueType::kUInt16:
    case ValueType::kBits:
      if (value < 0 || value > 0xFFFF) {
        return absl::OutOfRangeError(absl::StrCat("devicenet ", field, ": ", value, " outside ",
                                                  TypeName(spec.type), " 0..65535"));
      }
      return static_cast<uint16_t>(value);
  }
  return uint16_t{0};
}

int32_t FromWord(const ValueSpec& spec, uint16_t raw) {
  return spec.type == ValueType::kInt16 ? int32_t{static_cast<int16_t>(raw)} : int32_t{raw};
}

std::string FieldOf(const CommandSpec& spec, const ValueSpec& v) {
  return *v.name ? absl::StrCat(spec.key(), ".", v.name) : absl::StrCat(spec.key(), ".value");
}

bool IsCurveStart(uint8_t id) { return id >= 0x20 && id <= 0x23; }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Table.

std::string CommandSpec::key() const {
  std::string k;
  bool pending_sep = false;
  for (const char* p = name; *p; ++p) {
    const unsigned char c = static_cast<unsigned char>(*p);
    std::string word;
    if (std::isalnum(c)) {
      word = std::string(1, static_cast<char>(std::tolower(c)));
    } else if (c == '+') {
      word = "plus";
    } else if (c == '-') {
      word = "minus";
    } else {
      pending_sep = !k.empty();
      continue;
    }
    if (pending_sep || ((c == '+' || c == '-') && !k.empty())) k += '_';
    pending_sep = (c == '+' || c == '-');
    k += word;
  }
  return k;
}

std::vector<uint16_t> CommandSpec::ErrorCodes() const {
  std::vector<uint16_t> codes;
  if (!documented) codes.push_back(kCodedUnknownCommand);  // D-19 option
  if (motor_select != MotorSelect::kSystem) {
    codes.push_back(kCodedDriveNotSpecified);
    codes.push_back(kCodedDriveNotMaster);
  }
  if (serial_mode) codes.push_back(kCodedDriveNotSerial);
  const bool narrow =
      (request.type == ValueType::kInt16 && (request.min > -32768 || request.max < 32767)) ||
      (request.type == ValueType::kUInt16 && (request.min > 0 || request.max < 0xFFFF));
  if (narrow) codes.push_back(kCodedRangeError);
  if (requirement != Requirement::kNone) codes.push_back(kCodedEncoderNotExists);
  if (requirement == Requirement::kMasterEncoder) codes.push_back(kCodedEncoderSsiMode);
  if (IsCurveStart(id)) {
    codes.push_back(kCodedCurveMissing);
    codes.push_back(kCodedCurveTypeMismatch);
    codes.push_back(kCodedCurveProcessing);
  }
  std::sort(codes.begin(), codes.end());
  codes.erase(std::unique(codes.begin(), codes.end()), codes.end());
  return codes;
}

std::span<const CommandSpec> AllCommands() { return kCommands; }

const CommandSpec* FindCommand(uint8_t id) {
  const auto* it = std::lower_bound(std::begin(kCommands), std::end(kCommands), id,
                                    [](const CommandSpec& s, uint8_t v) { return s.id < v; });
  return (it != std::end(kCommands) && it->id == id) ? it : nullptr;
}

const char* ModuleName(Module m) { return m == Module::kAddressed ? "addressed" : "direct"; }

// ---------------------------------------------------------------------------------------------
// Encode / decode.

absl::Status CheckRange(const CommandSpec& spec, int32_t value) {
  const ValueSpec& v = spec.request;
  if (v.type != ValueType::kInt16 && v.type != ValueType::kUInt16) return absl::OkStatus();
  absl::Status s;
  if (value < v.min) {
    s = absl::OutOfRangeError(
        absl::StrCat("devicenet ", FieldOf(spec, v), ": ", value, " below minimum ", v.min));
  } else if (value > v.max) {
    s = absl::OutOfRangeError(
        absl::StrCat("devicenet ", FieldOf(spec, v), ": ", value, " exceeds maximum ", v.max));
  } else {
    return absl::OkStatus();
  }
  AttachCodedError(s, kCodedRangeError);
  return s;
}

absl::StatusOr<CommandSlot> EncodeCommand(const Command& c, Module module, bool strict) {
  const CommandSpec* spec = FindCommand(c.id);
  if (spec == nullptr || c.id > 0x7F) {
    return absl::NotFoundError(
        absl::StrCat("devicenet command ", Hex2(c.id), ": not in the command table"));
  }
  const std::string where = absl::StrCat("devicenet ", spec->key());
  if (module == Module::kDirect && c.motor) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": motor ", MotorName(*c.motor),
                     " given for a Direct slot (bits 15..8 reserved; the slot selects the motor)"));
  }
  if (strict) {
    if (!spec->documented) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": undocumented in the seed, never sent (D-19)"));
    }
    if (module == Module::kDirect && !spec->direct) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": not allowed in a Direct slot"));
    }
    if (module == Module::kAddressed) {
      if (spec->motor_select == MotorSelect::kRequired && !c.motor) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": needs exactly one motor (A-D)"));
      }
      if (spec->motor_select == MotorSelect::kSystem && c.motor) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": system command, motor ", MotorName(*c.motor), " given"));
      }
    }
    if (spec->request.type != ValueType::kDontCare) {
      DGW_RETURN_IF_ERROR(CheckRange(*spec, c.value));
    }
  }
  DGW_ASSIGN_OR_RETURN(uint16_t value,
                       ToWord(spec->request, c.value, FieldOf(*spec, spec->request)));
  CommandWord w;
  w.id = c.id;
  w.toggle = c.toggle;
  w.motor_mask = c.motor ? MotorBit(*c.motor) : 0;
  return CommandSlot{w.raw(), value};
}

absl::StatusOr<DecodedCommand> DecodeCommand(CommandSlot slot, Module module) {
  DecodedCommand d;
  d.word = CommandWord::FromRaw(slot.word);
  d.raw_value = slot.value;
  d.spec = FindCommand(d.word.id);
  if (d.spec == nullptr) {
    absl::Status s = absl::NotFoundError(
        absl::StrCat("devicenet command ", Hex2(d.word.id), ": not in the command table"));
    AttachCodedError(s, kCodedUnknownCommand);
    return s;
  }
  d.value = FromWord(d.spec->request, slot.value);
  if (module == Module::kDirect || d.spec->motor_select == MotorSelect::kSystem) {
    return d;  // Direct: bits 15..8 reserved (§7.3); system: bits reserved (§8.1)
  }
  const int bits = std::popcount(static_cast<unsigned>(d.word.motor_mask));
  const std::string where = absl::StrCat("devicenet ", d.spec->key());
  absl::Status s;
  if (bits > 1) {
    s = absl::InvalidArgumentError(absl::StrCat(where, ": ", bits, " motor select bits ",
                                                absl::StrFormat("0x%X", d.word.motor_mask),
                                                ", at most one (D-6)"));
  } else if (bits == 0 && d.spec->motor_select == MotorSelect::kRequired) {
    s = absl::InvalidArgumentError(absl::StrCat(where, ": no motor select bit, needs one (A-D)"));
  }
  if (!s.ok()) {
    AttachCodedError(s, kCodedDriveNotSpecified);
    return s;
  }
  if (bits == 1) d.motor = static_cast<Motor>(std::countr_zero(unsigned{d.word.motor_mask}));
  return d;
}

absl::StatusOr<CommandSlot> EncodeResponse(const DecodedCommand& c, int32_t response_value) {
  if (c.spec == nullptr) return absl::InternalError("devicenet response: command without spec");
  const std::string where = absl::StrCat("devicenet ", c.spec->key(), " response");
  uint16_t value = 0;
  switch (c.spec->response_kind) {
    case ResponseKind::kNoResponse:
      return absl::FailedPreconditionError(
          absl::StrCat(where, ": the drive resets and never answers (seed line 984)"));
    case ResponseKind::kEcho:
      value = c.raw_value;
      break;
    case ResponseKind::kDontCare:  // 0x00: word 2 has no meaning; low 16 bits as given
      value = static_cast<uint16_t>(response_value);
      break;
    case ResponseKind::kValue:
    case ResponseKind::kActualIo: {
      DGW_ASSIGN_OR_RETURN(
          value, ToWord(c.spec->response, response_value, FieldOf(*c.spec, c.spec->response)));
      break;
    }
  }
  return CommandSlot{c.word.raw(), value};
}

absl::StatusOr<DecodedResponse> DecodeResponse(CommandSlot received) {
  DecodedResponse r;
  r.echo = CommandWord::FromRaw(received.word);
  r.raw_value = received.value;
  r.spec = FindCommand(r.echo.id);
  if (r.spec == nullptr) {
    return absl::NotFoundError(absl::StrCat("devicenet response: echoed command ", Hex2(r.echo.id),
                                            " not in the command table"));
  }
  switch (r.spec->response_kind) {
    case ResponseKind::kEcho:
      r.value = FromWord(r.spec->request, received.value);
      break;
    case ResponseKind::kValue:
    case ResponseKind::kActualIo:
      r.value = FromWord(r.spec->response, received.value);
      break;
    case ResponseKind::kNoResponse:
    case ResponseKind::kDontCare:
      r.value = received.value;
      break;
  }
  return r;
}

bool ToggleFor(const CommandSpec& spec, StatusHighWord status_high, Motor motor) {
  return spec.toggle && NextToggle(status_high, motor);
}

// ---------------------------------------------------------------------------------------------
// Coded errors.

std::span<const CodedError> AllCodedErrors() { return kCodedErrors; }

const CodedError* FindCodedError(uint16_t code) {
  for (const CodedError& e : kCodedErrors) {
    if (e.code == code) return &e;
  }
  return nullptr;
}

std::string CodedErrorText(uint16_t code) {
  if (code == kCodedNoError) return "no coded error (0x0000)";
  if (const CodedError* e = FindCodedError(code)) {
    return absl::StrFormat("%s (0x%04X)", e->text, code);
  }
  return absl::StrFormat("LinMot coded error 0x%04X", code);
}

void AttachCodedError(absl::Status& status, uint16_t code) {
  status.SetPayload(kCodedErrorPayloadUrl, absl::Cord(absl::StrFormat("%04X", code)));
}

std::optional<uint16_t> GetCodedError(const absl::Status& status) {
  auto payload = status.GetPayload(kCodedErrorPayloadUrl);
  if (!payload) return std::nullopt;
  const std::string s(*payload);
  if (s.size() != 4) return std::nullopt;
  uint16_t v = 0;
  for (char c : s) {
    int d = -1;
    if (c >= '0' && c <= '9') d = c - '0';
    if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
    if (d < 0) return std::nullopt;
    v = static_cast<uint16_t>(v * 16 + d);
  }
  return v;
}

}  // namespace drivegw::linmot::devicenet
