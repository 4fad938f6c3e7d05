// Fuzz target: arbitrary bytes into config::ParseConfig, which must return a Status, never throw.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "server/config/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto cfg = drivegw::config::ParseConfig(text);
  // Touch the result so a bad status or config is fully materialised.
  if (cfg.ok()) {
    volatile size_t n = cfg->drives.size() + cfg->listen.grpc.size();
    (void)n;
  } else {
    volatile size_t n = cfg.status().message().size();
    (void)n;
  }
  return 0;
}
