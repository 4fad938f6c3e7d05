// Trinamic parameter catalogue and the gateway's shadow of one axis's parameters.
// The PACK stores nothing and reads nothing back (G-24, L325, L371, L899): the shadow is the only
// record of what was written, it is what ReadParameter returns, and it is what the drive re-sends
// after every detected reset. Sources: trinamic-sixpack.md §4.2 ($10-$19, $31-$33, $40, $41),
// §5.12 (defaults), §8.7 CT-55/CT-56 (validation), decisions docs/decisions/107x.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/trinamic/codec.h"

namespace drivegw::trinamic {

// A parameter is one field of a configuration opcode. Its numeric id (ParameterRef.id, API
// parameter_id) is `opcode << 8 | P-index of the field's first byte`: 0x1403 = `$14` P3 = vmax.
// Its name is "$14.vmax" (opcode in upper-case hex, field name of the codec's table).
constexpr uint32_t ParameterId(Opcode opcode, uint8_t param) {
  return (static_cast<uint32_t>(opcode) << 8) | param;
}

enum class ParameterScope {
  kAxis,        // per motor: the word carries motnr (P0) = the drive's axis
  kController,  // one value for the whole PACK ($12 clkdiv, $17 table, $32/$33, $40, $41)
};

// When the PACK accepts a write (L532, L539, L609; CT-56).
enum class WriteRule {
  kAnyTime,      // e.g. $14 amax/vmax are evaluated permanently (L552)
  kAxisStopped,  // $13, $16: only while this motor stands still
  kAllStopped,   // $12 clkdiv: only while every motor stands still
};

struct ParameterDefinition {
  uint32_t id = 0;
  std::string name;  // "$14.vmax"
  Opcode opcode = Opcode::kSetRamp;
  std::string field;  // codec field name, "vmax"
  ParameterScope scope = ParameterScope::kAxis;
  WriteRule rule = WriteRule::kAnyTime;
  int64_t min = 0;
  int64_t max = 0;
  int64_t default_value = 0;  // §5.12; for `$15` motor type the G-33 factory value
  std::string unit;           // "velocity register", "2 ms", "microsteps", "bits", ...
  std::string description;    // one line, cites the manual line
};

// Every parameter the gateway writes and shadows, in opcode order. Excludes motion, query,
// address ($42), reset ($CC), power-down ($45, a query) and service opcodes.
std::span<const ParameterDefinition> ParameterCatalogue();
// By id or by name ("$14.vmax", case-insensitive hex); NotFound naming the id/name and a hint.
absl::StatusOr<const ParameterDefinition*> FindParameter(uint32_t id);
absl::StatusOr<const ParameterDefinition*> FindParameter(std::string_view name);

// An advisory for a value that is valid but doubtful (G-08: vstart below 8, L363; G-09: a current
// index above 5 for I1..I3 is below the 19 % needed for proper microstepping, L329). Logging it
// is the drive's job; nullopt when there is nothing to say. Does not range-check.
std::optional<std::string> ParameterWarning(uint32_t id, int64_t value);

// The values of one axis plus the controller-wide ones as the gateway believes the PACK holds
// them. Starts at the §5.12 defaults (the PACK's state after reset). Value type: copy freely.
class ParameterShadow {
 public:
  // `axis` = motor number; `axes` = 6 (SIXpack) or 4 (QUADpack).
  ParameterShadow(uint8_t axis, int axes);

  uint8_t axis() const { return axis_; }
  int64_t Get(uint32_t id) const;  // id must be in the catalogue (else 0)
  int64_t Get(Opcode opcode, std::string_view field) const;

  // Checks `value` for `id` against the field range and every cross-field rule of CT-55 given the
  // other current values: amax <= vstart * 64 (L556), vmin <= vstart (L544), vrefmax <= vmax
  // (L613), microstep frequency <= 200 kHz for vmax/vrefmax at clkdiv/div (L497), switchover
  // 1..1000, packet timeout >= 2 and not shorter than one 9-byte word at `baud` (L838).
  // InvalidArgument "$14.amax: 321 exceeds vstart x 64 = 320 (L556)".
  absl::Status Validate(uint32_t id, int64_t value, int baud = 19200) const;

  // The complete command word that sets `id` to `value` with every other field of that opcode
  // from the shadow (address = `address`, motnr = axis for kAxis). Validates first.
  absl::StatusOr<Command> WriteCommand(uint8_t address, uint32_t id, int64_t value,
                                       int baud = 19200) const;
  // Records that `command` was sent (all of its fields); used for API writes and for native
  // pass-through of configuration opcodes. Words for other motors / non-parameter opcodes: no-op.
  void Absorb(const Command& command);
  void Set(uint32_t id, int64_t value);  // shadow only, no checks (configuration load)

  // Every configuration word that brings a freshly reset PACK to this shadow for this axis
  // (axis-scoped opcodes, in catalogue order; controller-scoped ones only if `controller` is
  // true). Words equal to the reset defaults are included too: the gateway always writes `$15`
  // explicitly (G-33) and re-sending is cheap.
  std::vector<Command> ApplyCommands(uint8_t address, bool controller) const;

  // Velocity scale for unit conversion (clkdiv of $12, div of this axis's $13).
  int clkdiv() const;
  int div() const;

 private:
  // The full word of `opcode` from the shadow (motnr = axis, `$10` the even motor of the pair).
  Command Word(uint8_t address, Opcode opcode) const;

  uint8_t axis_;
  int axes_;
  std::map<uint32_t, int64_t> values_;
};

}  // namespace drivegw::trinamic
