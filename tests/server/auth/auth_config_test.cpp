// auth / insecure configuration (decision 015): defaults keep an unauthenticated gateway on
// loopback, a non-loopback listen address without auth is an error naming the key, insecure:
// true allows it, and the loopback test itself.
#include "server/config/auth_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/config/config.h"

namespace drivegw::config {
namespace {

using ::testing::HasSubstr;

TEST(AuthConfigTest, NoFile_AuthDisabled_ListensOnLoopbackOnly) {
  auto cfg = ParseConfig("");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->auth.enabled);
  EXPECT_FALSE(cfg->auth.insecure);
  EXPECT_EQ(cfg->listen.grpc, "127.0.0.1:50051");
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:8080");
}

TEST(AuthConfigTest, AuthEnabled_DefaultsListenEverywhere) {
  auto cfg = ParseConfig("auth: {enabled: true}\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_TRUE(cfg->auth.enabled);
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:50051");
  EXPECT_EQ(cfg->listen.http, "0.0.0.0:8080");
}

TEST(AuthConfigTest, NonLoopbackWithoutAuth_ErrorNamesKeyAndWayOut) {
  auto cfg = ParseConfig("listen:\n  grpc: 0.0.0.0:50051\n  http: 127.0.0.1:8080\n");
  ASSERT_FALSE(cfg.ok());
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(cfg.status().message(),
              HasSubstr("listen.grpc: '0.0.0.0:50051' is not a loopback address and auth is "
                        "disabled"));
  EXPECT_THAT(cfg.status().message(), HasSubstr("insecure: true"));
  EXPECT_THAT(cfg.status().message(), HasSubstr("line 2"));
  EXPECT_THAT(cfg.status().message(), ::testing::Not(HasSubstr("listen.http")));
}

TEST(AuthConfigTest, NonLoopbackHttpWithoutAuth_Error) {
  auto cfg = ParseConfig("listen: {http: ':8080'}\nauth: {enabled: false}\n");
  ASSERT_FALSE(cfg.ok());
  EXPECT_THAT(cfg.status().message(), HasSubstr("listen.http: ':8080' is not a loopback address"));
}

TEST(AuthConfigTest, NonLoopbackWithInsecure_Accepted) {
  auto cfg = ParseConfig("insecure: true\nlisten: {grpc: '0.0.0.0:1', http: '[::]:2'}\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_TRUE(cfg->auth.insecure);
  EXPECT_FALSE(cfg->auth.enabled);
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:1");
}

TEST(AuthConfigTest, NonLoopbackWithAuth_Accepted) {
  auto cfg = ParseConfig("auth: {enabled: true}\nlisten: {grpc: '0.0.0.0:1'}\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:1");
}

TEST(AuthConfigTest, BadShapes_NamedByKey) {
  auto not_bool = ParseConfig("auth: {enabled: maybe}\n");
  ASSERT_FALSE(not_bool.ok());
  EXPECT_THAT(not_bool.status().message(), HasSubstr("auth.enabled"));
  auto typo = ParseConfig("auth: {enable: true}\n");
  ASSERT_FALSE(typo.ok());
  EXPECT_THAT(typo.status().message(), HasSubstr("auth.enable: unknown key"));
  auto insecure = ParseConfig("insecure: yes-please\n");
  ASSERT_FALSE(insecure.ok());
  EXPECT_THAT(insecure.status().message(), HasSubstr("insecure"));
}

TEST(AuthConfigTest, IsLoopback) {
  for (const char* yes : {"127.0.0.1:1", "127.1.2.3:80", "localhost:8080", "[::1]:50051"}) {
    EXPECT_TRUE(IsLoopback(yes)) << yes;
  }
  for (const char* no : {"0.0.0.0:1", ":8080", "[::]:1", "10.0.0.1:1", "127.0.0.1.evil.com:1",
                         "gateway.local:1", "127.0.0:1"}) {
    EXPECT_FALSE(IsLoopback(no)) << no;
  }
}

TEST(AuthConfigTest, CheckListenExposure_ForConfigsBuiltInCode) {
  AuthConfig off;
  EXPECT_TRUE(CheckListenExposure(off, "127.0.0.1:0", "127.0.0.1:0").ok());
  absl::Status s = CheckListenExposure(off, "127.0.0.1:0", "0.0.0.0:8080");
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("listen.http: '0.0.0.0:8080'"));
  AuthConfig on;
  on.enabled = true;
  EXPECT_TRUE(CheckListenExposure(on, "0.0.0.0:1", "0.0.0.0:2").ok());
}

}  // namespace
}  // namespace drivegw::config
