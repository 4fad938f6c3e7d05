// storage: how much a committed write survives (docs/config.md "storage", decision 1443).
#pragma once

namespace drivegw::config {

struct StorageConfig {
  // process_crash (default): commits survive kill -9 of the gateway, not a power cut (SQLite
  // WAL, synchronous=NORMAL). power_loss: every commit is fsynced (synchronous=FULL).
  enum class Durability { kProcessCrash, kPowerLoss };
  Durability durability = Durability::kProcessCrash;
};

namespace internal {
class Section;
// Reads the optional `storage:` mapping of the root; errors name the key and the values allowed.
void ParseStorage(const Section& root, StorageConfig& out);
}  // namespace internal

}  // namespace drivegw::config
