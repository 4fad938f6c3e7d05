// DRIVEGW_* environment variables -> ConfigOverride list and config path (decision 024).
#include "server/config/env_overrides.h"

#include <cstdlib>

#include "adapters/core/log.h"

namespace drivegw::config {
namespace {

const EnvVariable* Find(std::span<const EnvVariable> table, std::string_view variable) {
  for (const EnvVariable& v : table) {
    if (v.variable == variable) return &v;
  }
  return nullptr;
}

}  // namespace

EnvLookup ProcessEnvironment() {
  return [](const char* name) -> const char* { return std::getenv(name); };
}

std::vector<ConfigOverride> OverridesFromEnvironment(const EnvLookup& env,
                                                     std::span<const EnvVariable> table) {
  std::vector<ConfigOverride> out;
  for (const EnvVariable& v : table) {
    const std::string name(v.variable);
    const char* value = env(name.c_str());
    if (value == nullptr || *value == '\0') continue;
    out.push_back(ConfigOverride{std::string(v.key), value, name});
  }
  return out;
}

absl::Status CheckLogLevelVariables(const EnvLookup& env) {
  for (const char* name : {"DRIVEGW_LOG_LEVEL", "DGW_LOG_LEVEL"}) {
    const char* value = env(name);
    if (value == nullptr || *value == '\0') continue;
    if (!log::ParseLevel(value).has_value()) {
      return absl::InvalidArgumentError(std::string(name) + ": '" + value +
                                        "' is not a log level (debug, info, warn, error, off)");
    }
  }
  return absl::OkStatus();
}

std::string ResolveConfigPath(const std::string& config_flag, const EnvLookup& env) {
  if (!config_flag.empty()) return config_flag;
  const char* value = env(kConfigPathVariable);
  return value == nullptr ? std::string() : std::string(value);
}

absl::StatusOr<GatewayConfig> LoadGatewayConfig(const std::string& path,
                                                std::span<const ConfigOverride> overrides) {
  if (path.empty()) return ParseConfig("", kKnownFamilies, overrides);
  return LoadConfigFile(path, kKnownFamilies, overrides);
}

void LogOverrides(std::span<const ConfigOverride> overrides, std::span<const EnvVariable> table) {
  for (const ConfigOverride& o : overrides) {
    log::Fields fields;
    fields.Add("variable", o.variable).Add("key", o.key);
    // Not in the table counts as secret: never print a value we cannot classify.
    const EnvVariable* v = Find(table, o.variable);
    if (v != nullptr && !v->secret) fields.Add("value", o.value);
    log::Info("config_override", fields);
  }
}

}  // namespace drivegw::config
