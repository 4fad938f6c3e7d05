// audit: {max_entries, warn_at_percent, prune_to_percent} (docs/config.md "audit", decision 017).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/config/config.h"

namespace drivegw::config {
namespace {

using ::testing::HasSubstr;

TEST(AuditConfigTest, Absent_Defaults) {
  auto cfg = ParseConfig("");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->audit.max_entries, 1000000);
  EXPECT_EQ(cfg->audit.warn_at_percent, 90);
  EXPECT_EQ(cfg->audit.prune_to_percent, 80);
}

TEST(AuditConfigTest, AllKeys_Read) {
  auto cfg = ParseConfig("audit: {max_entries: 5000, warn_at_percent: 75, prune_to_percent: 50}");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->audit.max_entries, 5000);
  EXPECT_EQ(cfg->audit.warn_at_percent, 75);
  EXPECT_EQ(cfg->audit.prune_to_percent, 50);
}

TEST(AuditConfigTest, ZeroMeansNoLimit_AndWarnBelowDefaultPruneHalvesIt) {
  auto cfg = ParseConfig("audit: {max_entries: 0, warn_at_percent: 60}");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->audit.max_entries, 0);
  EXPECT_EQ(cfg->audit.prune_to_percent, 30);
}

TEST(AuditConfigTest, Errors_NameKeyAndLimit) {
  const std::pair<const char*, const char*> cases[] = {
      {"audit: {max_entries: 5}", "audit.max_entries: 5 is below 10 (0 = no limit)"},
      {"audit: {max_entries: -1}", "audit.max_entries: -1 is below 0"},
      {"audit: {warn_at_percent: 101}", "audit.warn_at_percent: 101 exceeds 100"},
      {"audit: {warn_at_percent: 70, prune_to_percent: 70}",
       "audit.prune_to_percent: 70 must be below warn_at_percent 70"},
      {"audit: {max_entry: 10}", "audit.max_entry"},
      {"audit: 7", "audit"},
  };
  for (const auto& [yaml, message] : cases) {
    auto cfg = ParseConfig(yaml);
    ASSERT_FALSE(cfg.ok()) << yaml;
    EXPECT_THAT(cfg.status().message(), HasSubstr(message)) << yaml;
  }
}

}  // namespace
}  // namespace drivegw::config
