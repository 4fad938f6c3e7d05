// storage: {durability: process_crash | power_loss} (decision 1443).
#include "server/config/storage_config.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "server/config/section.h"

namespace drivegw::config::internal {

void ParseStorage(const Section& root, StorageConfig& out) {
  const auto node = root.Get("storage");
  if (!node) return;
  const Section s(*node, root.Child("storage"), {"durability"}, root.errors());
  if (!node->IsNull() && !node->IsMap()) return;
  std::string v;
  if (!s.String("durability", v)) return;
  if (v == "process_crash") {
    out.durability = StorageConfig::Durability::kProcessCrash;
  } else if (v == "power_loss") {
    out.durability = StorageConfig::Durability::kPowerLoss;
  } else {
    s.errors().Add(s.Child("durability"),
                   absl::StrCat("'", v, "' is not one of process_crash, power_loss"),
                   *s.Get("durability"));
  }
}

}  // namespace drivegw::config::internal
