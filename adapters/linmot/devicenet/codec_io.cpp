// LinMot DeviceNet I/O data modules: word bit names and the consumed/produced image codec, word
// by word in the module order of linmot-devicenet.md §7.7 (byte order per D-1).
#include "adapters/linmot/devicenet/codec_io.h"

#include <bit>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/core/status.h"

namespace drivegw::linmot::devicenet {
namespace {

absl::Status Invalid(const std::string& where, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("devicenet ", where, ": ", what));
}

// Word k of an image at byte offset 2k; D-1 byte order (default little-endian, §0.3).
void PutWord(std::vector<uint8_t>& out, uint16_t v, ByteOrder order) {
  const uint8_t lo = static_cast<uint8_t>(v);
  const uint8_t hi = static_cast<uint8_t>(v >> 8);
  if (order == ByteOrder::kLittleEndian) {
    out.push_back(lo);
    out.push_back(hi);
  } else {
    out.push_back(hi);
    out.push_back(lo);
  }
}

class WordReader {
 public:
  WordReader(std::span<const uint8_t> b, ByteOrder order) : b_(b), order_(order) {}
  uint16_t Next() {
    const uint8_t first = b_[at_];
    const uint8_t second = b_[at_ + 1];
    at_ += 2;
    return order_ == ByteOrder::kLittleEndian ? static_cast<uint16_t>(first | (second << 8))
                                              : static_cast<uint16_t>((first << 8) | second);
  }

 private:
  std::span<const uint8_t> b_;
  ByteOrder order_;
  size_t at_ = 0;
};

constexpr const char* kReserved = "Reserved";

// §7.1 (seed lines 340-351).
constexpr const char* kControlBits[16] = {
    kReserved,         "RUN Request",     "STOP Request",    "INIT Request",
    "FREEZE Request",  kReserved,         kReserved,         kReserved,
    "Trig In Motor A", "Trig In Motor B", "Trig In Motor C", "Trig In Motor D",
    "Freeze Motor A",  "Freeze Motor B",  "Freeze Motor C",  "Freeze Motor D"};
// §7.4 (seed lines 384-445).
constexpr const char* kStatusLowBits[16] = {
    "INIT Done",     "RUN State",      "ERROR State",   "INIT State",
    "DISABLE State", "Emergency Stop", "ERROR Pending", "WARNING Pending",
    "Curve Done A",  "Curve Done B",   "Curve Done C",  "Curve Done D",
    "In Position A", "In Position B",  "In Position C", "In Position D"};
// §7.4 (seed lines 401-417, 447-452).
constexpr const char* kStatusHighBits[16] = {
    "Motor A Following Error",  "Motor A Position Range",   "Motor A Over temperature",
    "Motor A Command Toggle",   "Motor B Following Error",  "Motor B Position Range",
    "Motor B Over temperature", "Motor B Command Toggle",   "Motor C Following Error",
    "Motor C Position Range",   "Motor C Over temperature", "Motor C Command Toggle",
    "Motor D Following Error",  "Motor D Position Range",   "Motor D Over temperature",
    "Motor D Command Toggle"};
// §8.5 System Warn State (seed lines 789-791).
constexpr const char* kSystemWarnBits[16] = {
    "Low Capacity",  "DCLV PWR Low",   "DCLV PWR High", "DCLV SIG Low",
    "DCLV SIG High", "Controller Hot", kReserved,       kReserved,
    kReserved,       kReserved,        kReserved,       kReserved,
    "Warn Motor A",  "Warn Motor B",   "Warn Motor C",  "Warn Motor D"};
// §8.5 Motor Warn State (seed lines 792-794).
constexpr const char* kMotorWarnBits[16] = {"Motor Too Hot Calc",
                                            "Motor Too Hot Sensor",
                                            "Following Error",
                                            "Slider Missing",
                                            kReserved,
                                            kReserved,
                                            "Init Position Not Done",
                                            kReserved,
                                            "Not In Position Range",
                                            "Not In Position",
                                            kReserved,
                                            kReserved,
                                            kReserved,
                                            kReserved,
                                            kReserved,
                                            kReserved};
// §8.5 System Error State (seed lines 855-857).
constexpr const char* kSystemErrorBits[16] = {
    "Low free capacity", "DCLV PWR too low",  "DCLV PWR too high",
    "DCLV SIG too low",  "DCLV SIG too high", "Controller too hot",
    "MSG error",         "Coded error",       kReserved,
    kReserved,           kReserved,           kReserved,
    "Error Motor A",     "Error Motor B",     "Error Motor C",
    "Error Motor D"};
// §8.5 Motor Error State (seed lines 858-860).
constexpr const char* kMotorErrorBits[16] = {"Motor Too Hot Calc",
                                             "Motor Too Hot Sensor",
                                             "Following Error",
                                             "Slider Missing",
                                             kReserved,
                                             "Init Failed",
                                             "Wrong motor type",
                                             "Curve missing",
                                             kReserved,
                                             kReserved,
                                             kReserved,
                                             kReserved,
                                             kReserved,
                                             kReserved,
                                             kReserved,
                                             kReserved};
// §8.5 Controller IO word (seed lines 948, 970).
constexpr const char* kControllerIoBits[16] = {
    "Run request",      "Init request",     "Freeze request",   "Stop request",
    "Analog/Trigger 1", "Analog/Trigger 2", "Analog/Trigger 3", "Analog/Trigger 4",
    "Dig In 5",         "Dig In 6",         "Warn out",         "Error out",
    "Pos error out",    "Dig out 4",        "Dig out 5",        "Dig out 6"};
// §8.5 Extended IO (seed lines 2982, 2997): inputs 7..0 low, outputs 7..0 high.
constexpr const char* kExtendedIoBits[16] = {
    "Ext Dig In 0",  "Ext Dig In 1",  "Ext Dig In 2",  "Ext Dig In 3",
    "Ext Dig In 4",  "Ext Dig In 5",  "Ext Dig In 6",  "Ext Dig In 7",
    "Ext Dig Out 0", "Ext Dig Out 1", "Ext Dig Out 2", "Ext Dig Out 3",
    "Ext Dig Out 4", "Ext Dig Out 5", "Ext Dig Out 6", "Ext Dig Out 7"};

const char* const* BitTable(WordKind kind) {
  switch (kind) {
    case WordKind::kControl:
      return kControlBits;
    case WordKind::kStatusLow:
      return kStatusLowBits;
    case WordKind::kStatusHigh:
      return kStatusHighBits;
    case WordKind::kSystemWarnState:
      return kSystemWarnBits;
    case WordKind::kMotorWarnState:
      return kMotorWarnBits;
    case WordKind::kSystemErrorState:
      return kSystemErrorBits;
    case WordKind::kMotorErrorState:
      return kMotorErrorBits;
    case WordKind::kControllerIo:
      return kControllerIoBits;
    case WordKind::kExtendedIo:
      return kExtendedIoBits;
  }
  return kControlBits;
}

}  // namespace

const char* MotorName(Motor m) {
  switch (m) {
    case Motor::kA:
      return "A";
    case Motor::kB:
      return "B";
    case Motor::kC:
      return "C";
    case Motor::kD:
      return "D";
  }
  return "?";
}

const char* WordBitName(WordKind kind, int bit) {
  if (bit < 0 || bit > 15) return "Unknown Bit";
  return BitTable(kind)[bit];
}

std::vector<std::string> SetBitNames(WordKind kind, uint16_t raw) {
  std::vector<std::string> names;
  for (int bit = 0; bit < 16; ++bit) {
    if ((raw >> bit) & 1u) names.emplace_back(WordBitName(kind, bit));
  }
  return names;
}

const char* DirectOutVariableName(uint8_t code) {
  // §6.2 (seed lines 236-243).
  static constexpr const char* kNames[8] = {"Actual Pos",         "Demand Pos",   "Position Error",
                                            "Dem Pos unfiltered", "Actual Speed", "Demand Speed",
                                            "Demand Acc",         "Current"};
  return code < 8 ? kNames[code] : "unknown";
}

// ---------------------------------------------------------------------------------------------
// Layout (§7.7).

size_t MasterDriveCount(const IoLayout& layout) {
  return static_cast<size_t>(std::popcount(static_cast<unsigned>(layout.master_drives & 0x0F)));
}

std::vector<Motor> MasterDrives(const IoLayout& layout) {
  std::vector<Motor> motors;
  for (uint8_t m = 0; m < kMotorCount; ++m) {
    if ((layout.master_drives >> m) & 1u) motors.push_back(static_cast<Motor>(m));
  }
  return motors;
}

size_t ConsumedSize(const IoLayout& l) {
  const size_t n = MasterDriveCount(l);
  return (l.modules.control_in ? 2 : 0) + (l.modules.addressed_in ? 4 : 0) +
         (l.modules.direct_in ? 4 * n : 0);
}

size_t ProducedSize(const IoLayout& l) {
  const size_t n = MasterDriveCount(l);
  return (l.modules.status_out ? 4 : 0) + (l.modules.addressed_out ? 4 : 0) +
         2 * ((l.modules.direct_out_1 ? 1 : 0) + (l.modules.direct_out_2 ? 1 : 0)) * n;
}

std::string ConsumedModulesText(const IoLayout& l) {
  std::string s;
  if (l.modules.control_in) absl::StrAppend(&s, "control_in");
  if (l.modules.addressed_in) absl::StrAppend(&s, s.empty() ? "" : "+", "addressed_in");
  if (l.modules.direct_in) absl::StrAppend(&s, s.empty() ? "" : "+", "direct_in");
  return s.empty() ? "none" : s;
}

std::string ProducedModulesText(const IoLayout& l) {
  std::string s;
  if (l.modules.status_out) absl::StrAppend(&s, "status_out");
  if (l.modules.addressed_out) absl::StrAppend(&s, s.empty() ? "" : "+", "addressed_out");
  if (l.modules.direct_out_1) absl::StrAppend(&s, s.empty() ? "" : "+", "direct_out_1");
  if (l.modules.direct_out_2) absl::StrAppend(&s, s.empty() ? "" : "+", "direct_out_2");
  return s.empty() ? "none" : s;
}

absl::Status ValidateLayout(const IoLayout& l) {
  if (l.master_drives > 0x0F) {
    return Invalid("io_layout.master_drives",
                   absl::StrFormat("0x%X exceeds 0xF (motors A-D)", l.master_drives));
  }
  return absl::OkStatus();
}

IoLayout DefaultLayoutP() {
  IoLayout l;
  l.modules.control_in = l.modules.addressed_in = true;
  l.modules.status_out = l.modules.addressed_out = true;
  l.master_drives = MotorBit(Motor::kA);
  return l;
}

IoLayout Example1Layout() {
  IoLayout l;
  l.modules = ModuleSet{true, true, true, true, true, true, true};
  l.master_drives = 0x0F;
  return l;
}

IoLayout Example2Layout() {
  IoLayout l;
  l.modules.control_in = l.modules.direct_in = true;
  l.modules.status_out = l.modules.direct_out_1 = true;
  l.master_drives = MotorBit(Motor::kA) | MotorBit(Motor::kC);
  return l;
}

// ---------------------------------------------------------------------------------------------
// Images (§7.7 order).

absl::StatusOr<std::vector<uint8_t>> EncodeConsumed(const IoLayout& l, const ConsumedImage& in) {
  DGW_RETURN_IF_ERROR(ValidateLayout(l));
  const ModuleSet& m = l.modules;
  if (m.control_in != in.control.has_value()) {
    return Invalid("consumed.control_in", m.control_in ? "selected but absent" : "not selected");
  }
  if (m.addressed_in != in.addressed.has_value()) {
    return Invalid("consumed.addressed_in",
                   m.addressed_in ? "selected but absent" : "not selected");
  }
  const size_t n = m.direct_in ? MasterDriveCount(l) : 0;
  if (in.direct.size() != n) {
    return Invalid("consumed.direct_in",
                   absl::StrCat(in.direct.size(), " slots, layout has ", n,
                                m.direct_in ? " master drives" : " (module not selected)"));
  }
  std::vector<uint8_t> out;
  out.reserve(ConsumedSize(l));
  if (in.control) PutWord(out, in.control->raw, l.byte_order);
  if (in.addressed) {
    PutWord(out, in.addressed->word, l.byte_order);
    PutWord(out, in.addressed->value, l.byte_order);
  }
  for (const CommandSlot& s : in.direct) {
    PutWord(out, s.word, l.byte_order);
    PutWord(out, s.value, l.byte_order);
  }
  return out;
}

absl::StatusOr<ConsumedImage> DecodeConsumed(const IoLayout& l, std::span<const uint8_t> b) {
  DGW_RETURN_IF_ERROR(ValidateLayout(l));
  const size_t need = ConsumedSize(l);
  if (b.size() != need) {
    return Invalid("consumed", absl::StrCat(b.size(), " bytes, layout ", ConsumedModulesText(l),
                                            " needs ", need));
  }
  WordReader r(b, l.byte_order);
  ConsumedImage img;
  if (l.modules.control_in) img.control = ControlWord{r.Next()};
  if (l.modules.addressed_in) {
    const uint16_t w = r.Next();
    img.addressed = CommandSlot{w, r.Next()};
  }
  if (l.modules.direct_in) {
    for (size_t i = 0; i < MasterDriveCount(l); ++i) {
      const uint16_t w = r.Next();
      img.direct.push_back(CommandSlot{w, r.Next()});
    }
  }
  return img;
}

absl::StatusOr<std::vector<uint8_t>> EncodeProduced(const IoLayout& l, const ProducedImage& in) {
  DGW_RETURN_IF_ERROR(ValidateLayout(l));
  const ModuleSet& m = l.modules;
  if (in.status_low.has_value() != in.status_high.has_value()) {
    return Invalid("produced.status_out", "status_low and status_high come together");
  }
  if (m.status_out != in.status_low.has_value()) {
    return Invalid("produced.status_out", m.status_out ? "selected but absent" : "not selected");
  }
  if (m.addressed_out != in.addressed.has_value()) {
    return Invalid("produced.addressed_out",
                   m.addressed_out ? "selected but absent" : "not selected");
  }
  const bool any_direct = m.direct_out_1 || m.direct_out_2;
  const size_t n = any_direct ? MasterDriveCount(l) : 0;
  if (in.direct.size() != n) {
    return Invalid("produced.direct_out",
                   absl::StrCat(in.direct.size(), " entries, layout has ", n,
                                any_direct ? " master drives" : " (modules not selected)"));
  }
  for (size_t i = 0; i < in.direct.size(); ++i) {
    if (m.direct_out_1 != in.direct[i].out_1.has_value()) {
      return Invalid(absl::StrCat("produced.direct_out[", i, "].out_1"),
                     m.direct_out_1 ? "selected but absent" : "not selected");
    }
    if (m.direct_out_2 != in.direct[i].out_2.has_value()) {
      return Invalid(absl::StrCat("produced.direct_out[", i, "].out_2"),
                     m.direct_out_2 ? "selected but absent" : "not selected");
    }
  }
  std::vector<uint8_t> out;
  out.reserve(ProducedSize(l));
  if (in.status_low) {
    PutWord(out, in.status_low->raw, l.byte_order);
    PutWord(out, in.status_high->raw, l.byte_order);
  }
  if (in.addressed) {
    PutWord(out, in.addressed->word, l.byte_order);
    PutWord(out, in.addressed->value, l.byte_order);
  }
  for (const DirectOut& d : in.direct) {  // interleaved per motor (seed lines 514-521)
    if (d.out_1) PutWord(out, *d.out_1, l.byte_order);
    if (d.out_2) PutWord(out, *d.out_2, l.byte_order);
  }
  return out;
}

absl::StatusOr<ProducedImage> DecodeProduced(const IoLayout& l, std::span<const uint8_t> b) {
  DGW_RETURN_IF_ERROR(ValidateLayout(l));
  const size_t need = ProducedSize(l);
  if (b.size() != need) {
    return Invalid("produced", absl::StrCat(b.size(), " bytes, layout ", ProducedModulesText(l),
                                            " needs ", need));
  }
  WordReader r(b, l.byte_order);
  ProducedImage img;
  if (l.modules.status_out) {
    img.status_low = StatusLowWord{r.Next()};
    img.status_high = StatusHighWord{r.Next()};
  }
  if (l.modules.addressed_out) {
    const uint16_t w = r.Next();
    img.addressed = CommandSlot{w, r.Next()};
  }
  if (l.modules.direct_out_1 || l.modules.direct_out_2) {
    for (size_t i = 0; i < MasterDriveCount(l); ++i) {
      DirectOut d;
      if (l.modules.direct_out_1) d.out_1 = r.Next();
      if (l.modules.direct_out_2) d.out_2 = r.Next();
      img.direct.push_back(d);
    }
  }
  return img;
}

ConsumedImage EmptyConsumed(const IoLayout& l) {
  ConsumedImage img;
  if (l.modules.control_in) img.control = ControlWord{};
  if (l.modules.addressed_in) img.addressed = CommandSlot{};
  if (l.modules.direct_in) img.direct.assign(MasterDriveCount(l), CommandSlot{});
  return img;
}

ProducedImage EmptyProduced(const IoLayout& l) {
  ProducedImage img;
  if (l.modules.status_out) {
    img.status_low = StatusLowWord{};
    img.status_high = StatusHighWord{};
  }
  if (l.modules.addressed_out) img.addressed = CommandSlot{};
  if (l.modules.direct_out_1 || l.modules.direct_out_2) {
    DirectOut d;
    if (l.modules.direct_out_1) d.out_1 = 0;
    if (l.modules.direct_out_2) d.out_2 = 0;
    img.direct.assign(MasterDriveCount(l), d);
  }
  return img;
}

}  // namespace drivegw::linmot::devicenet
