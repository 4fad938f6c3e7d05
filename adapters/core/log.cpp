// Logging façade implementation: stderr, one write per line.
#include "adapters/core/log.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace drivegw::log {
namespace {

// DRIVEGW_LOG_LEVEL (docs/config.md "Environment", decision 024) wins; DGW_LOG_LEVEL stays as
// its older alias. An empty value counts as unset, as for every DRIVEGW_* variable.
const char* LevelVariable() {
  for (const char* name : {"DRIVEGW_LOG_LEVEL", "DGW_LOG_LEVEL"}) {
    const char* v = std::getenv(name);
    if (v != nullptr && *v != '\0') return v;
  }
  return nullptr;
}

// An invalid value falls back to info here; the gateway refuses to start with it
// (config::CheckLogLevelVariables), so only tools without that check ever run on the fallback.
Level LevelFromEnv() {
  const char* v = LevelVariable();
  if (v == nullptr) return Level::kInfo;
  return ParseLevel(v).value_or(Level::kInfo);
}

std::atomic<Level>& Threshold() {
  static std::atomic<Level> level{LevelFromEnv()};
  return level;
}

const char* Name(Level level) {
  switch (level) {
    case Level::kDebug:
      return "debug";
    case Level::kInfo:
      return "info";
    case Level::kWarn:
      return "warn";
    case Level::kError:
      return "error";
    case Level::kOff:
      break;
  }
  return "off";
}

}  // namespace

std::optional<Level> ParseLevel(std::string_view name) {
  if (name == "debug") return Level::kDebug;
  if (name == "info") return Level::kInfo;
  if (name == "warn") return Level::kWarn;
  if (name == "error") return Level::kError;
  if (name == "off") return Level::kOff;
  return std::nullopt;
}

void SetLevel(Level level) { Threshold().store(level); }
Level GetLevel() { return Threshold().load(); }
bool Enabled(Level level) { return level >= Threshold().load() && level != Level::kOff; }

void Write(Level level, std::string_view event, std::string_view fields) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &tm);
  std::string line;
  line.reserve(64 + event.size() + fields.size());
  line += stamp;
  char frac[8];
  std::snprintf(frac, sizeof frac, ".%03dZ", static_cast<int>(ms));
  line += frac;
  line += ' ';
  line += Name(level);
  line += " event=";
  line += event;
  if (!fields.empty()) {
    line += ' ';
    line += fields;
  }
  line += '\n';
  // One write() per line keeps concurrent lines whole.
  [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, line.data(), line.size());
}

}  // namespace drivegw::log
