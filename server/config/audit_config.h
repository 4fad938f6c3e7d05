// audit: the audit trail's size limit (docs/config.md "audit", decision 017).
#pragma once

#include <cstdint>

namespace drivegw::config {

struct AuditConfig {
  // Entries kept; at the limit the oldest are pruned behind an "audit.pruned" anchor. 0 = no
  // limit. The default holds a busy line's year at a few hundred bytes per entry.
  int64_t max_entries = 1000000;
  int warn_at_percent = 90;   // an "audit.retention_warning" entry (and log line) at this fill
  int prune_to_percent = 80;  // a prune leaves this fill (below warn_at_percent)
};

namespace internal {
class Section;
// Reads the optional `audit:` mapping of the root; errors name the key and the limit.
void ParseAudit(const Section& root, AuditConfig& out);
}  // namespace internal

}  // namespace drivegw::config
