// storage.durability: default, both values, and the messages of every refusal (decision 1443).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "server/config/config.h"

namespace drivegw::config {
namespace {

using ::testing::HasSubstr;
using Durability = StorageConfig::Durability;

std::string Message(const std::string& yaml) {
  auto cfg = ParseConfig(yaml);
  EXPECT_FALSE(cfg.ok()) << "parsed unexpectedly:\n" << yaml;
  return cfg.ok() ? std::string() : std::string(cfg.status().message());
}

TEST(StorageConfigTest, Default_ProcessCrash) {
  auto cfg = ParseConfig("");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->storage.durability, Durability::kProcessCrash);
  auto empty = ParseConfig("storage:\n");
  ASSERT_TRUE(empty.ok()) << empty.status();
  EXPECT_EQ(empty->storage.durability, Durability::kProcessCrash);
}

TEST(StorageConfigTest, BothValues_Read) {
  auto full = ParseConfig("storage: {durability: power_loss}\n");
  ASSERT_TRUE(full.ok()) << full.status();
  EXPECT_EQ(full->storage.durability, Durability::kPowerLoss);
  auto normal = ParseConfig("storage: {durability: process_crash}\n");
  ASSERT_TRUE(normal.ok()) << normal.status();
  EXPECT_EQ(normal->storage.durability, Durability::kProcessCrash);
}

TEST(StorageConfigTest, BadValues_NameTheKeyAndTheChoices) {
  EXPECT_THAT(Message("storage: {durability: full}\n"),
              HasSubstr("storage.durability: 'full' is not one of process_crash, power_loss"));
  EXPECT_THAT(Message("storage: {durability: [power_loss]}\n"),
              HasSubstr("storage.durability: expected a string"));
  EXPECT_THAT(Message("storage: {synchronous: full}\n"), HasSubstr("storage.synchronous"));
  EXPECT_THAT(Message("storage: 3\n"), HasSubstr("storage"));
}

}  // namespace
}  // namespace drivegw::config
