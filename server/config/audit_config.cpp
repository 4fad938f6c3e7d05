// audit: {max_entries, warn_at_percent, prune_to_percent}, checked so a prune always leaves
// room below the warning (decision 017).
#include "server/config/audit_config.h"

#include "absl/strings/str_cat.h"
#include "server/config/section.h"

namespace drivegw::config::internal {
namespace {

// storage::AuditRetention::kMinEntries: a prune must keep the newest entry and its anchor.
constexpr int64_t kMinEntries = 10;
constexpr int64_t kMaxEntries = 1000000000;

}  // namespace

void ParseAudit(const Section& root, AuditConfig& out) {
  const auto node = root.Get("audit");
  if (!node) return;
  const Section s(*node, root.Child("audit"),
                  {"max_entries", "warn_at_percent", "prune_to_percent"}, root.errors());
  if (!node->IsNull() && !node->IsMap()) return;
  int64_t v = 0;
  if (s.Int("max_entries", 0, kMaxEntries, v)) {
    if (v != 0 && v < kMinEntries) {
      s.errors().Add(s.Child("max_entries"),
                     absl::StrCat(v, " is below ", kMinEntries, " (0 = no limit)"),
                     *s.Get("max_entries"));
    } else {
      out.max_entries = v;
    }
  }
  if (s.Int("warn_at_percent", 2, 100, v)) out.warn_at_percent = static_cast<int>(v);
  if (s.Int("prune_to_percent", 1, 99, v)) {
    if (v >= out.warn_at_percent) {
      s.errors().Add(s.Child("prune_to_percent"),
                     absl::StrCat(v, " must be below warn_at_percent ", out.warn_at_percent),
                     *s.Get("prune_to_percent"));
    } else {
      out.prune_to_percent = static_cast<int>(v);
    }
  } else if (out.prune_to_percent >= out.warn_at_percent) {
    // Only warn_at_percent given, at or below the default prune level: prune halfway down.
    out.prune_to_percent = out.warn_at_percent / 2;
  }
}

}  // namespace drivegw::config::internal
