// LinMot UPID catalogue (decision 009). Types, units and ranges only where a reference states
// them (linmot-mc.md §0.4 units, §9.2 table; the motion command layouts of §5 that write a UPID);
// everything else is "unknown" with the 32-bit range the RTC channel carries (decision 705).
#include "adapters/linmot/linudp/catalogue.h"

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/linmot/common/parameter_id.h"
#include "adapters/linmot/linudp/factory.h"

namespace drivegw::linmot::linudp {
namespace {

// What the RTC channel carries: 32 bits, UInt32 above 7FFF'FFFFh given unsigned (decision 705).
constexpr int64_t kWireMin = std::numeric_limits<int32_t>::min();
constexpr int64_t kWireMax = std::numeric_limits<uint32_t>::max();
constexpr int64_t kI32Min = std::numeric_limits<int32_t>::min();
constexpr int64_t kI32Max = std::numeric_limits<int32_t>::max();
constexpr int64_t kU32Max = std::numeric_limits<uint32_t>::max();

enum class Kind : uint8_t {
  kParameter,         // RAM and ROM value (§9.1)
  kVariable,          // runtime value, RAM only, written by the drive (read-only)
  kWritableVariable,  // runtime value that motion commands / the master write (1E72h, 1EA0h)
};

struct Row {
  uint16_t upid;
  const char* title;
  const char* type;
  const char* unit;
  int64_t min;
  int64_t max;
  Kind kind;
  const char* source;
};

constexpr Kind P = Kind::kParameter;
constexpr Kind V = Kind::kVariable;
constexpr Kind W = Kind::kWritableVariable;

// §0.4: position SInt32 0.1 µm; velocity UInt32 1E-6 m/s 0..7FFF'FFFFh (MC22 L3806-3812);
// acceleration 1E-5 m/s²; jerk UInt32 1E-4 m/s³ 0..5FFF'FFFFh (MC22 L3836).
constexpr Row kRows[] = {
    {0x0082, "Operating Sub Hours", "u32", "1 ms", 0, kU32Max, V, "linmot-linudp.md §4.2"},
    {0x100E, "Logic Supply Voltage Too Low", "unknown", "", kWireMin, kWireMax, P, "MC22 L4161"},
    {0x1010, "Logic Supply Voltage Too High", "unknown", "", kWireMin, kWireMax, P, "MC22 L4164"},
    {0x1018, "Motor Supply Voltage Low", "unknown", "", kWireMin, kWireMax, P, "MC22 L4171"},
    {0x1019, "Motor Supply Voltage High", "unknown", "", kWireMin, kWireMax, P, "MC22 L4174"},
    {0x101A, "Motor Supply Voltage Too Low", "unknown", "", kWireMin, kWireMax, P, "MC22 L4177"},
    {0x101B, "Motor Supply Voltage Too High", "unknown", "", kWireMin, kWireMax, P, "MC22 L4178"},
    {0x101D, "Regeneration resistor Enable", "bool", "", 0, 1, P,
     "MC22 L4198 (0 disable, 1 enable)"},
    {0x101E, "RR Turn On Voltage", "unknown", "", kWireMin, kWireMax, P, "MC22 L4201-4203"},
    {0x101F, "RR Turn Off Voltage", "unknown", "", kWireMin, kWireMax, P, "MC22 L4204"},
    {0x1039, "Trigger input configuration", "unknown", "", kWireMin, kWireMax, P, "MC22 L1321"},
    {0x1040, "Temp Sens Warn Level", "unknown", "", kWireMin, kWireMax, P, "MC22 L4231"},
    {0x1041, "Temp Sens Error Level", "unknown", "", kWireMin, kWireMax, P, "MC22 L4232"},
    {0x11C2, "Modulo Minimal Position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC22 L4589"},
    {0x11C3, "Modulo Maximal Position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC22 L4591"},
    {0x11C4, "Modulo Start-up Position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC22 L4593"},
    {0x11C5, "Modulo Mode", "bool", "", 0, 1, P, "MC22 L4595-4597 (Off / On)"},
    {0x11F2, "Phase Angle", "unknown", "", kWireMin, kWireMax, P, "MC22 L620"},
    {0x121B, "Limit switch Error Behavior", "enum", "", 0, 2, P,
     "MC22 L4109 (0 no error, 1 power off, 2 quick stop)"},
    {0x128E, "Master Encoder Type", "enum", "", 0, 5, P,
     "MC22 L4127 (0 none, 1 ABZ, 2 AB, 4 Step/Dir, 5 Step/Dir/Zero)"},
    {0x128F, "Master Encoder Decoding", "enum", "", 0, 2, P, "MC22 L4132-4137 (0 1x, 1 2x, 2 4x)"},
    {0x1290, "Master Encoder Direction", "enum", "", 0, 1, P, "MC22 L4140 (0 pos., 1 neg.)"},
    {0x1393, "Active position controller set", "u16", "", 0, 1, P,
     "MC22 L1171 (0 = A, 1 = B; 005x UInt16)"},
    {0x13A6, "Maximal current, controller set A", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L3960-3986"},
    {0x13BA, "Maximal current, controller set B", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L4032"},
    {0x13C7, "Home Position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC22 L1188 (009x SInt32)"},
    {0x13CA, "Slider Home Position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC22 L1188"},
    {0x13E0, "Power Up Position Recovery", "unknown", "", kWireMin, kWireMax, P, "MC22 L4594"},
    {0x1455, "16-bit interface scaling: position", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L1893 (D-14)"},
    {0x1456, "16-bit interface scaling: velocity", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L1893 (D-14)"},
    {0x1457, "16-bit interface scaling: acceleration", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L1893, 1956 (D-14)"},
    {0x1458, "16-bit interface scaling: jerk", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L2623 (D-14)"},
    {0x146E, "Minimal position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC15 L54 (error 0007h)"},
    {0x146F, "Maximal position", "i32", "0.1 µm", kI32Min, kI32Max, P, "MC15 L54 (error 0008h)"},
    {0x1473, "Position lag (moving) maximum", "i32", "0.1 µm", 0, kI32Max, P,
     "MC15 L64 (error 000Bh)"},
    {0x1475, "Position lag (standing) maximum", "i32", "0.1 µm", 0, kI32Max, P,
     "MC15 L64 (error 000Ch)"},
    {0x14BE, "Predefined maximal velocity", "u32", "1E-6 m/s", 0, 0x7FFF'FFFF, P,
     "MC22 L1388, units L3806-3812"},
    {0x14BF, "Predefined acceleration", "u32", "1E-5 m/s²", 0, 0x7FFF'FFFF, P, "MC22 L1388, 2135"},
    {0x14C0, "Predefined deceleration", "u32", "1E-5 m/s²", 0, 0x7FFF'FFFF, P, "MC22 L1388, 2135"},
    {0x14C1, "Predefined jerk", "u32", "1E-4 m/s³", 0, 0x5FFF'FFFF, P, "MC22 L3706, range L3836"},
    {0x14C9, "Default curve offset", "unknown", "", kWireMin, kWireMax, P, "MC22 L1564"},
    {0x14CA, "Default curve amplitude scale", "unknown", "", kWireMin, kWireMax, P, "MC22 L1564"},
    {0x14CB, "Default curve time scale", "unknown", "", kWireMin, kWireMax, P, "MC22 L1564"},
    {0x14E6, "Configured streaming period time", "unknown", "", kWireMin, kWireMax, P,
     "MC22 L1506"},
    {0x1527, "Cam mode", "unknown", "", kWireMin, kWireMax, P, "MC22 L1774, 3915"},
    {0x1528, "Cam start enable", "unknown", "", kWireMin, kWireMax, P, "MC22 L3933"},
    {0x1591, "Cycle-time error generation enable", "bool", "", 0, 1, P, "MC22 L4252"},
    {0x170C, "Trigger Mode", "enum", "", 0, 4, P,
     "MC22 L4064 (0 none, 1 direct, 2 inhibited, 3 delayed, 4 inhibited & delayed)"},
    {0x171B, "Brake Apply Delay Time", "unknown", "", kWireMin, kWireMax, P, "MC22 L4037"},
    {0x171C, "Brake Release Delay Time", "unknown", "", kWireMin, kWireMax, P, "MC22 L4038"},
    {0x1721, "Quick stop deceleration", "u32", "1E-5 m/s²", 0, 0x7FFF'FFFF, P, "MC22 L1427, 2086"},
    {0x1798, "0V Raw Data Offset", "unknown", "", kWireMin, kWireMax, P, "MC22 L3498"},
    {0x1B8A, "Demand Position", "i32", "0.1 µm", kI32Min, kI32Max, V, "MC22 L3182"},
    {0x1B8B, "Demand Velocity", "i32", "1E-6 m/s", kI32Min, kI32Max, V, "MC15 L163"},
    {0x1B8D, "Actual Position", "i32", "0.1 µm", kI32Min, kI32Max, V, "MC22 L3202"},
    {0x1B8E, "Actual Velocity", "i32", "1E-6 m/s", kI32Min, kI32Max, V, "MC15 L163"},
    {0x1B90, "Difference Position", "i32", "0.1 µm", kI32Min, kI32Max, V, "MC22 L3222"},
    {0x1B93, "Demand Current", "unknown", "", kWireMin, kWireMax, V, "MC22 L3242"},
    {0x1B99, "Actual Position Modulo", "i32", "0.1 µm", kI32Min, kI32Max, V, "MC22 L4576"},
    {0x1B9A, "Demand Position Modulo", "i32", "0.1 µm", kI32Min, kI32Max, V, "MC22 L4577"},
    {0x1BCE, "Max drive temperature", "unknown", "", kWireMin, kWireMax, V, "MC22 L4246"},
    {0x1C50, "CAM Counts", "unknown", "counts", kWireMin, kWireMax, V, "MC22 L3316"},
    {0x1CA4, "Analog value X4.4", "unknown", "", kWireMin, kWireMax, V, "MC22 L3262"},
    {0x1D4C, "Control Word", "bits16", "", 0, 0xFFFF, V, "linmot-linudp.md 6.8"},
    {0x1E62, "Capture variable (captured position)", "i32", "0.1 µm", kI32Min, kI32Max, V,
     "MC22 L2380"},
    {0x1E72, "Command Table Var 1", "unknown", "", kWireMin, kWireMax, W, "MC22 L3122"},
    {0x1E73, "Command Table Var 2", "unknown", "", kWireMin, kWireMax, W, "MC22 L3142"},
    {0x1EA0, "Target Force", "i16", "0.1 N", -32768, 32767, W, "MC22 L3569 (399x SInt16)"},
    {0x1EA1, "Measured Force", "unknown", "", kWireMin, kWireMax, V, "MC22 L3498"},
    {0x20A8, "Monitoring channel 1 UPID", "u16", "UPID", 0, 0xFFFF, P, "linmot-linudp.md §4.2"},
    {0x20A9, "Monitoring channel 2 UPID", "u16", "UPID", 0, 0xFFFF, P, "linmot-linudp.md §4.2"},
    {0x20AA, "Monitoring channel 3 UPID", "u16", "UPID", 0, 0xFFFF, P, "linmot-linudp.md §4.2"},
    {0x20AB, "Monitoring channel 4 UPID", "u16", "UPID", 0, 0xFFFF, P, "linmot-linudp.md §4.2"},
    {0x6300, "Ready To Operate mode", "unknown", "", kWireMin, kWireMax, P, "MC22 L550"},
};

std::string UpidText(uint32_t upid) { return absl::StrFormat("0x%04X", upid); }

ParameterDefinition FromRow(const Row& r) {
  ParameterDefinition d;
  d.id = r.upid;
  d.name = UpidText(r.upid);
  d.title = r.title;
  d.type = r.type;
  d.unit = r.unit;
  d.min = r.min;
  d.max = r.max;
  d.writable = r.kind != Kind::kVariable;
  d.has_stored_value = r.kind == Kind::kParameter;
  d.description = absl::StrCat(r.title, " (linmot-mc.md §9.2, ", r.source, ")");
  return d;
}

// A UPID no reference names: raw 32 bits, RAM and ROM (the drive answers 0xC0 if it lacks it).
ParameterDefinition Raw(uint32_t upid) {
  ParameterDefinition d;
  d.id = upid;
  d.name = UpidText(upid);
  d.title = "undocumented UPID";
  d.type = "unknown";
  d.unit = "unknown";
  d.min = kWireMin;
  d.max = kWireMax;
  d.has_stored_value = true;
  d.description = "not named by linmot-mc.md §9.2; raw 32-bit value (decision 009)";
  return d;
}

// "0x14BE", "14BEh", decimal "5310"; a UPID is 16 bits.
std::optional<uint32_t> ParseUpid(std::string_view t) {
  const std::optional<uint32_t> v = ParseParameterId(t);
  if (!v || *v > 0xFFFF) return std::nullopt;
  return v;
}
class LinMotCatalogue final : public ParameterCatalogue {
 public:
  LinMotCatalogue() {
    for (const Row& r : kRows) definitions_.push_back(FromRow(r));
  }
  std::string family() const override { return kFamilyName; }
  const std::vector<ParameterDefinition>& Definitions() const override { return definitions_; }

  absl::StatusOr<ParameterDefinition> Find(std::string_view text) const override {
    const std::optional<uint32_t> upid = ParseUpid(text);
    if (!upid) {
      return absl::NotFoundError(absl::StrCat("linmot: \"", std::string(text),
                                              "\" is not a UPID 0x0000..0xFFFF (\"0x14BE\", "
                                              "\"14BEh\" or decimal)"));
    }
    for (const ParameterDefinition& d : definitions_) {
      if (d.id == *upid) return d;
    }
    return Raw(*upid);
  }

 private:
  std::vector<ParameterDefinition> definitions_;
};

}  // namespace

std::shared_ptr<const ParameterCatalogue> MakeLinMotCatalogue() {
  return std::make_shared<const LinMotCatalogue>();
}

std::shared_ptr<const ParameterCatalogue> LinMotParameterCatalogue() {
  static const std::shared_ptr<const ParameterCatalogue> catalogue = MakeLinMotCatalogue();
  return catalogue;
}

}  // namespace drivegw::linmot::linudp
