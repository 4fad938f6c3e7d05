// Logging façade: one line per event, key=value fields (STYLE.md §6 "Logging").
// error = an operator must act; warn = recovered; info = lifecycle; debug = per command.
#pragma once

#include <optional>
#include <sstream>
#include <string>
#include <string_view>

namespace drivegw::log {

enum class Level { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3, kOff = 4 };

// Global threshold; default kInfo, DGW_LOG_LEVEL=debug|info|warn|error|off overrides at start.
void SetLevel(Level level);
Level GetLevel();
// "debug", "info", "warn", "error", "off" (exactly, lower case); anything else is nullopt.
std::optional<Level> ParseLevel(std::string_view name);
bool Enabled(Level level);

// Writes "<utc time> <level> <event> <fields>" to stderr as one write (thread-safe).
void Write(Level level, std::string_view event, std::string_view fields);

// Builds key=value fields: log::Fields().Add("drive", name).Add("to", "ENABLED").
class Fields {
 public:
  template <typename T>
  Fields& Add(std::string_view key, const T& value) {
    out_ << (first_ ? "" : " ") << key << '=' << value;
    first_ = false;
    return *this;
  }
  std::string str() const { return out_.str(); }

 private:
  std::ostringstream out_;
  bool first_ = true;
};

inline void Debug(std::string_view event, const Fields& f = Fields()) {
  if (Enabled(Level::kDebug)) Write(Level::kDebug, event, f.str());
}
inline void Info(std::string_view event, const Fields& f = Fields()) {
  if (Enabled(Level::kInfo)) Write(Level::kInfo, event, f.str());
}
inline void Warn(std::string_view event, const Fields& f = Fields()) {
  if (Enabled(Level::kWarn)) Write(Level::kWarn, event, f.str());
}
inline void Error(std::string_view event, const Fields& f = Fields()) {
  if (Enabled(Level::kError)) Write(Level::kError, event, f.str());
}

}  // namespace drivegw::log
