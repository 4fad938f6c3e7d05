// Config key shutdown_timeout_s (decision 022): default 10, 1..300, errors name key and limit.
#include <gtest/gtest.h>

#include "server/config/config.h"

namespace drivegw::config {
namespace {

TEST(ShutdownTimeout_Absent, Default10) {
  auto cfg = ParseConfig("data_dir: /tmp/x\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->shutdown_timeout_s, 10);
}

TEST(ShutdownTimeout_InRange, Read) {
  auto cfg = ParseConfig("shutdown_timeout_s: 3\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->shutdown_timeout_s, 3);
}

TEST(ShutdownTimeout_OutOfRangeOrNotInteger, ErrorNamesKeyAndLimit) {
  auto zero = ParseConfig("shutdown_timeout_s: 0\n");
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.status().message().find("shutdown_timeout_s: 0 is below 1"), std::string::npos)
      << zero.status();
  auto big = ParseConfig("shutdown_timeout_s: 301\n");
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.status().message().find("shutdown_timeout_s: 301 exceeds 300"), std::string::npos)
      << big.status();
  auto text = ParseConfig("shutdown_timeout_s: soon\n");
  ASSERT_FALSE(text.ok());
  EXPECT_NE(text.status().message().find("shutdown_timeout_s"), std::string::npos);
}

}  // namespace
}  // namespace drivegw::config
