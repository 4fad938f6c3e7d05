// Gateway configuration: YAML text -> validated GatewayConfig (docs/config.md lists every key).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/drive_config.h"
#include "server/config/audit_config.h"
#include "server/config/storage_config.h"
#include "server/config/auth_config.h"
#include "server/config/tls_config.h"

namespace drivegw::config {

// Drive families the composition root can build; each new family appends its name here.
// linmot requires `linudp:`, linmot-devicenet `can:` and `mac_id`, trinamic `trinamic:`, stober
// `can:` and `node_id` (docs/config.md).
inline constexpr std::string_view kKnownFamilies[] = {"linmot", "linmot-devicenet", "trinamic",
                                                      "stober"};

// Larger inputs are refused before parsing (bounds parser work; a real config is a few KiB).
inline constexpr size_t kMaxConfigBytes = 1 << 20;

struct ListenConfig {
  std::string grpc = "0.0.0.0:50051";
  std::string http = "0.0.0.0:8080";
};

// One value that replaces a key of the file (or its default) before validation, e.g. from the
// environment (env_overrides.h): {"listen.http", "0.0.0.0:8080", "DRIVEGW_LISTEN_HTTP"}. The
// value is the text of a plain YAML scalar, so every key's own reader and rules apply to it.
struct ConfigOverride {
  std::string key;       // dotted path of a mapping key: "data_dir", "listen.http"
  std::string value;     // scalar text, taken verbatim
  std::string variable;  // where it came from; errors name it: "listen.http (from VAR): ..."
};

struct GatewayConfig {
  ListenConfig listen;
  std::string data_dir = "./data";
  std::vector<DriveConfig> drives;  // empty in demo mode; the server then uses DemoDrives()
  std::optional<TlsConfig> tls;     // HTTPS and gRPC over TLS when set (decision 023)
  AuditConfig audit;                // audit trail size limit (decision 017)
  StorageConfig storage;            // commit durability (decision 1443)
  AuthConfig auth;                  // auth.enabled and insecure (decision 015)
  // Graceful shutdown bound on SIGTERM, seconds 1..300 (decision 022).
  int shutdown_timeout_s = 10;
  bool demo = true;         // true when the config has no `drives:` key (or no file)
  std::string source_yaml;  // the text that was parsed, verbatim (without overrides)
};

// Parses and validates. Every problem is an InvalidArgument whose message names the key path
// and the limit, e.g. "drives[2].linudp.port: 70000 exceeds 65535 (line 9, column 13)";
// several problems are joined with "; ". YAML syntax errors carry line/column. Never throws.
// `overrides` replace (or add) their keys in the parsed tree before validation; a problem with
// an overridden key names the variable instead of a position.
absl::StatusOr<GatewayConfig> ParseConfig(
    std::string_view yaml_text, std::span<const std::string_view> families = kKnownFamilies,
    std::span<const ConfigOverride> overrides = {});

// A line of `status` ("; "-joined, each starting "<key path>: ") about an overridden key gets the
// variable after its path, "data_dir (from DRIVEGW_DATA_DIR): …": the only hint where a value
// without a file position came from. ParseConfig applies it; drivegw also to start-up errors
// about a key (an unusable data_dir; decision 1493).
absl::Status NameOverrides(const absl::Status& status, std::span<const ConfigOverride> overrides);

// Reads and parses `path`. NotFound naming the path when the file does not exist.
absl::StatusOr<GatewayConfig> LoadConfigFile(
    const std::string& path, std::span<const std::string_view> families = kKnownFamilies,
    std::span<const ConfigOverride> overrides = {});

// The two demo LinMot drives "x1" and "x2" (family linmot, LinUDP on 127.0.0.1 ports
// first_drive_port and first_drive_port + 1) that the server backs with embedded simulators.
std::vector<DriveConfig> DemoDrives(uint16_t first_drive_port = 49360);

// The two demo Trinamic axes "feeder-x" (motor 0) and "feeder-y" (motor 1) of one simulated
// SIXpack at address 1 on the serial device `device` (the pty symlink the server creates):
// 19200 baud, 640 microsteps/mm, limits reachable with the PACK's reset defaults.
std::vector<DriveConfig> DemoTrinamicDrives(const std::string& device);

// The demo STOBER axis "s1": CANopen node 3 on `bus`, a bus of its own (DeviceNet and CANopen
// never share one, decision 407). 1 u = 1 mm; the limits are the simulated axis's power-on
// values (I50/I51 ±10000 mm, I10 1000 mm/s, I11 10000 mm/s², decision 409).
DriveConfig DemoStoberDrive(const CanBusConfig& bus);

}  // namespace drivegw::config
