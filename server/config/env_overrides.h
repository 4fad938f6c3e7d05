// Environment overrides of the configuration (issue 9, Docker; docs/config.md "Environment",
// decision 024): DRIVEGW_CONFIG picks the file, DRIVEGW_<KEY> variables replace single keys.
#pragma once

#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "server/config/config.h"

namespace drivegw::config {

// Reads one environment variable: nullptr when unset. Injected so tests never touch the
// process environment; ProcessEnvironment() is std::getenv.
using EnvLookup = std::function<const char*(const char*)>;
EnvLookup ProcessEnvironment();

// The config file used when `--config` is not given.
inline constexpr char kConfigPathVariable[] = "DRIVEGW_CONFIG";

// One variable that replaces one key. `secret`: the start log names the variable only.
struct EnvVariable {
  std::string_view variable;
  std::string_view key;
  bool secret = false;
};

// Exactly these; other DRIVEGW_* names are left to other tools (decision 024).
// DRIVEGW_LOG_LEVEL is read by the log façade itself (adapters/core/log.cpp).
inline constexpr EnvVariable kEnvVariables[] = {
    {"DRIVEGW_LISTEN_GRPC", "listen.grpc"},
    {"DRIVEGW_LISTEN_HTTP", "listen.http"},
    {"DRIVEGW_DATA_DIR", "data_dir"},
    {"DRIVEGW_AUTH_ENABLED", "auth.enabled"},
    {"DRIVEGW_INSECURE", "insecure"},
    {"DRIVEGW_SHUTDOWN_TIMEOUT_S", "shutdown_timeout_s"},
    {"DRIVEGW_AUDIT_MAX_ENTRIES", "audit.max_entries"},
};

// The overrides set in the environment, in table order; unset and empty variables are skipped
// (an empty value is how compose files leave a variable "not set").
std::vector<ConfigOverride> OverridesFromEnvironment(
    const EnvLookup& env, std::span<const EnvVariable> table = kEnvVariables);

// DRIVEGW_LOG_LEVEL and its alias DGW_LOG_LEVEL, when set and not empty, must name a level
// (debug, info, warn, error, off): a typo would otherwise silently log at info (issue 11,
// bad-input inventory). InvalidArgument names the variable, the value and the allowed values.
absl::Status CheckLogLevelVariables(const EnvLookup& env);

// `--config` wins; otherwise DRIVEGW_CONFIG when set and not empty; "" = no file (demo).
std::string ResolveConfigPath(const std::string& config_flag, const EnvLookup& env);

// Loads the configuration the way the gateway does: `path` ("" = none) with `overrides`.
absl::StatusOr<GatewayConfig> LoadGatewayConfig(const std::string& path,
                                                std::span<const ConfigOverride> overrides);

// Logs one info line per override, "config_override variable=... key=... value=...", without
// the value for a secret variable (or one missing from `table`).
void LogOverrides(std::span<const ConfigOverride> overrides,
                  std::span<const EnvVariable> table = kEnvVariables);

}  // namespace drivegw::config
