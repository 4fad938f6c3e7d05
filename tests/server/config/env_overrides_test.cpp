// DRIVEGW_* overrides: each variable replaces the file's value and the default, every existing
// rule applies to it, errors name the variable, DRIVEGW_CONFIG only without --config. The
// environment is a map behind the injected lookup; the process environment is never touched.
#include "server/config/env_overrides.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "server/config/config.h"

namespace drivegw::config {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

class FakeEnv {
 public:
  FakeEnv(std::initializer_list<std::pair<const std::string, std::string>> vars) : vars_(vars) {}
  EnvLookup Lookup() const {
    return [this](const char* name) -> const char* {
      auto it = vars_.find(name);
      return it == vars_.end() ? nullptr : it->second.c_str();
    };
  }

 private:
  std::map<std::string, std::string> vars_;
};

absl::StatusOr<GatewayConfig> Parse(const std::string& yaml, const FakeEnv& env) {
  const auto overrides = OverridesFromEnvironment(env.Lookup());
  return ParseConfig(yaml, kKnownFamilies, overrides);
}

// Every key a variable can set, with a file value and a value different from it and the default.
constexpr char kFile[] = R"(listen:
  grpc: 127.0.0.1:50051
  http: 127.0.0.1:8080
data_dir: /srv/file
auth: {enabled: false}
insecure: false
shutdown_timeout_s: 20
audit: {max_entries: 5000}
)";

TEST(EnvOverrides_EachVariable, ReplacesFileValue) {
  const FakeEnv env{{"DRIVEGW_LISTEN_GRPC", "127.0.0.2:6000"},
                    {"DRIVEGW_LISTEN_HTTP", "127.0.0.3:7000"},
                    {"DRIVEGW_DATA_DIR", "/data"},
                    {"DRIVEGW_AUTH_ENABLED", "true"},
                    {"DRIVEGW_INSECURE", "true"},
                    {"DRIVEGW_SHUTDOWN_TIMEOUT_S", "45"},
                    {"DRIVEGW_AUDIT_MAX_ENTRIES", "100"}};
  auto cfg = Parse(kFile, env);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.grpc, "127.0.0.2:6000");
  EXPECT_EQ(cfg->listen.http, "127.0.0.3:7000");
  EXPECT_EQ(cfg->data_dir, "/data");
  EXPECT_TRUE(cfg->auth.enabled);
  EXPECT_TRUE(cfg->auth.insecure);
  EXPECT_EQ(cfg->shutdown_timeout_s, 45);
  EXPECT_EQ(cfg->audit.max_entries, 100);
  // The file text stays what the file said; the snapshot stores it verbatim.
  EXPECT_EQ(cfg->source_yaml, kFile);
}

TEST(EnvOverrides_EachVariable, ReplacesDefaultWithoutFile) {
  const FakeEnv env{{"DRIVEGW_LISTEN_GRPC", "0.0.0.0:6000"},
                    {"DRIVEGW_LISTEN_HTTP", "[::]:7000"},
                    {"DRIVEGW_DATA_DIR", "/data"},
                    {"DRIVEGW_AUTH_ENABLED", "true"},
                    {"DRIVEGW_INSECURE", "TRUE"},
                    {"DRIVEGW_SHUTDOWN_TIMEOUT_S", "300"},
                    {"DRIVEGW_AUDIT_MAX_ENTRIES", "0"}};
  auto cfg = Parse("", env);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:6000");
  EXPECT_EQ(cfg->listen.http, "[::]:7000");  // verbatim: not read as a YAML flow sequence
  EXPECT_EQ(cfg->data_dir, "/data");
  EXPECT_TRUE(cfg->auth.enabled);
  EXPECT_TRUE(cfg->auth.insecure);
  EXPECT_EQ(cfg->shutdown_timeout_s, 300);
  EXPECT_EQ(cfg->audit.max_entries, 0);
  EXPECT_TRUE(cfg->demo);
}

TEST(EnvOverrides_EachVariable, FalseOverridesTrueInFile) {
  const FakeEnv env{{"DRIVEGW_AUTH_ENABLED", "false"}, {"DRIVEGW_INSECURE", "false"}};
  auto cfg = Parse("auth: {enabled: true}\ninsecure: true\n", env);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->auth.enabled);
  EXPECT_FALSE(cfg->auth.insecure);
}

TEST(EnvOverrides_EmptySection, OverrideFillsNullMapping) {
  const FakeEnv env{{"DRIVEGW_LISTEN_HTTP", "127.0.0.1:9000"}, {"DRIVEGW_AUTH_ENABLED", "true"}};
  auto cfg = Parse("listen:\nauth:\n", env);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:9000");
  EXPECT_TRUE(cfg->auth.enabled);
}

TEST(EnvOverrides_Unset, FileAndDefaultsStay) {
  auto cfg = Parse(kFile, FakeEnv{});
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:8080");
  EXPECT_EQ(cfg->data_dir, "/srv/file");
  EXPECT_EQ(cfg->shutdown_timeout_s, 20);
}

TEST(EnvOverrides_EmptyValue, IsIgnored) {
  const FakeEnv env{{"DRIVEGW_DATA_DIR", ""}, {"DRIVEGW_SHUTDOWN_TIMEOUT_S", ""}};
  EXPECT_TRUE(OverridesFromEnvironment(env.Lookup()).empty());
  auto cfg = Parse(kFile, env);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->data_dir, "/srv/file");
  EXPECT_EQ(cfg->shutdown_timeout_s, 20);
}

TEST(EnvOverrides_UnknownVariable, IsNotAnError) {
  const FakeEnv env{{"DRIVEGW_FOO", "bar"}, {"DRIVEGW_IMAGE_TAG", "1.2"}};
  EXPECT_TRUE(OverridesFromEnvironment(env.Lookup()).empty());
  EXPECT_TRUE(Parse(kFile, env).ok());
}

TEST(EnvOverrides_List, CarriesKeyValueAndVariable) {
  const FakeEnv env{{"DRIVEGW_DATA_DIR", "/data"}, {"DRIVEGW_LISTEN_HTTP", "127.0.0.1:1"}};
  const auto list = OverridesFromEnvironment(env.Lookup());
  ASSERT_EQ(list.size(), 2u);
  // Table order: listen.http comes before data_dir.
  EXPECT_EQ(list[0].key, "listen.http");
  EXPECT_EQ(list[0].value, "127.0.0.1:1");
  EXPECT_EQ(list[0].variable, "DRIVEGW_LISTEN_HTTP");
  EXPECT_EQ(list[1].key, "data_dir");
  EXPECT_EQ(list[1].variable, "DRIVEGW_DATA_DIR");
}

// ---- errors name the variable ----

std::string ErrorOf(const std::string& yaml, const FakeEnv& env) {
  auto cfg = Parse(yaml, env);
  EXPECT_FALSE(cfg.ok());
  return std::string(cfg.status().message());
}

TEST(EnvOverrides_BadValue, HostPortErrorNamesVariable) {
  EXPECT_EQ(ErrorOf("", FakeEnv{{"DRIVEGW_LISTEN_HTTP", "abc"}}),
            "listen.http (from DRIVEGW_LISTEN_HTTP): 'abc' is not a host:port");
}

TEST(EnvOverrides_BadValue, BoolErrorNamesVariable) {
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_AUTH_ENABLED", "yes"}}),
            "auth.enabled (from DRIVEGW_AUTH_ENABLED): 'yes' is not true or false");
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_INSECURE", "1"}}),
            "insecure (from DRIVEGW_INSECURE): '1' is not true or false");
}

TEST(EnvOverrides_BadValue, LimitErrorsNameVariable) {
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_SHUTDOWN_TIMEOUT_S", "0"}}),
            "shutdown_timeout_s (from DRIVEGW_SHUTDOWN_TIMEOUT_S): 0 is below 1");
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_SHUTDOWN_TIMEOUT_S", "301"}}),
            "shutdown_timeout_s (from DRIVEGW_SHUTDOWN_TIMEOUT_S): 301 exceeds 300");
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_SHUTDOWN_TIMEOUT_S", "ten"}}),
            "shutdown_timeout_s (from DRIVEGW_SHUTDOWN_TIMEOUT_S): 'ten' is not an integer");
  EXPECT_EQ(ErrorOf(kFile, FakeEnv{{"DRIVEGW_AUDIT_MAX_ENTRIES", "5"}}),
            "audit.max_entries (from DRIVEGW_AUDIT_MAX_ENTRIES): 5 is below 10 (0 = no limit)");
}

TEST(EnvOverrides_BadValue, FileErrorsKeepLineAndColumn) {
  const std::string msg =
      ErrorOf("shutdown_timeout_s: 0\ndata_dir: /x\n", FakeEnv{{"DRIVEGW_LISTEN_GRPC", "nope"}});
  EXPECT_THAT(msg, HasSubstr("listen.grpc (from DRIVEGW_LISTEN_GRPC): 'nope' is not a host:port"));
  EXPECT_THAT(msg, HasSubstr("shutdown_timeout_s: 0 is below 1 (line 1, column 21)"));
  // The overridden value has no position in the file.
  EXPECT_THAT(msg, Not(HasSubstr("host:port (line")));
}

TEST(EnvOverrides_BadValue, ParentNotAMappingReportedAtFilePosition) {
  EXPECT_THAT(ErrorOf("listen: 5\n", FakeEnv{{"DRIVEGW_LISTEN_HTTP", "127.0.0.1:1"}}),
              HasSubstr("listen: expected a mapping, got a scalar (line 1, column 9)"));
}

// ---- the loopback rule (decision 015) applies to overridden addresses ----

TEST(EnvOverrides_Exposure, WildcardWithAuthOffRefused) {
  const std::string msg = ErrorOf("", FakeEnv{{"DRIVEGW_LISTEN_HTTP", "0.0.0.0:8080"}});
  EXPECT_THAT(msg, HasSubstr("listen.http (from DRIVEGW_LISTEN_HTTP): '0.0.0.0:8080' is not a "
                             "loopback address and auth is disabled"));
}

TEST(EnvOverrides_Exposure, AuthOffFromEnvironmentRefusesWildcardInFile) {
  const std::string msg = ErrorOf("auth: {enabled: true}\nlisten: {http: 0.0.0.0:8080}\n",
                                  FakeEnv{{"DRIVEGW_AUTH_ENABLED", "false"}});
  EXPECT_THAT(msg, HasSubstr("listen.http: '0.0.0.0:8080' is not a loopback address"));
  EXPECT_THAT(msg, HasSubstr("(line 2, column 16)"));
}

TEST(EnvOverrides_Exposure, WildcardWithInsecureAccepted) {
  auto cfg = Parse("", FakeEnv{{"DRIVEGW_LISTEN_HTTP", "0.0.0.0:8080"},
                               {"DRIVEGW_LISTEN_GRPC", "0.0.0.0:50051"},
                               {"DRIVEGW_INSECURE", "true"}});
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.http, "0.0.0.0:8080");
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:50051");
}

TEST(EnvOverrides_Exposure, WildcardWithAuthEnabledAccepted) {
  auto cfg =
      Parse("", FakeEnv{{"DRIVEGW_LISTEN_HTTP", "0.0.0.0:8080"}, {"DRIVEGW_AUTH_ENABLED", "true"}});
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.http, "0.0.0.0:8080");
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:50051");  // default, every interface with auth on
}

// ---- which file ----

TEST(ResolveConfigPath_Flag, WinsOverEnvironment) {
  EXPECT_EQ(ResolveConfigPath("/etc/a.yaml", FakeEnv{{"DRIVEGW_CONFIG", "/etc/b.yaml"}}.Lookup()),
            "/etc/a.yaml");
}

TEST(ResolveConfigPath_NoFlag, UsesEnvironment) {
  EXPECT_EQ(ResolveConfigPath("", FakeEnv{{"DRIVEGW_CONFIG", "/etc/b.yaml"}}.Lookup()),
            "/etc/b.yaml");
}

TEST(ResolveConfigPath_NoFlag, UnsetOrEmptyIsNoFile) {
  EXPECT_EQ(ResolveConfigPath("", FakeEnv{}.Lookup()), "");
  EXPECT_EQ(ResolveConfigPath("", FakeEnv{{"DRIVEGW_CONFIG", ""}}.Lookup()), "");
}

TEST(LoadGatewayConfig_File, OverridesApplyAndErrorsNameFile) {
  const std::string path = ::testing::TempDir() + "env_overrides_test.yaml";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("data_dir: /srv/file\nshutdown_timeout_s: 20\n", f);
    std::fclose(f);
  }
  auto good = LoadGatewayConfig(
      path, OverridesFromEnvironment(FakeEnv{{"DRIVEGW_DATA_DIR", "/data"}}.Lookup()));
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_EQ(good->data_dir, "/data");
  EXPECT_EQ(good->shutdown_timeout_s, 20);
  auto bad = LoadGatewayConfig(
      path, OverridesFromEnvironment(FakeEnv{{"DRIVEGW_SHUTDOWN_TIMEOUT_S", "0"}}.Lookup()));
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().message(),
            path + ": shutdown_timeout_s (from DRIVEGW_SHUTDOWN_TIMEOUT_S): 0 is below 1");
  std::remove(path.c_str());
  EXPECT_EQ(LoadGatewayConfig(path, {}).status().code(), absl::StatusCode::kNotFound);
}

// ---- start log ----

TEST(LogOverrides_Values, ShownExceptSecret) {
  constexpr EnvVariable kTable[] = {{"DRIVEGW_DATA_DIR", "data_dir"},
                                    {"DRIVEGW_SECRET_THING", "data_dir", /*secret=*/true}};
  const ConfigOverride overrides[] = {{"data_dir", "/data", "DRIVEGW_DATA_DIR"},
                                      {"data_dir", "hunter2", "DRIVEGW_SECRET_THING"},
                                      {"data_dir", "unlisted", "DRIVEGW_NOT_IN_TABLE"}};
  ::testing::internal::CaptureStderr();
  LogOverrides(overrides, kTable);
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_THAT(log, HasSubstr("config_override variable=DRIVEGW_DATA_DIR key=data_dir value=/data"));
  EXPECT_THAT(log, HasSubstr("variable=DRIVEGW_SECRET_THING key=data_dir"));
  EXPECT_THAT(log, HasSubstr("variable=DRIVEGW_NOT_IN_TABLE key=data_dir"));
  EXPECT_THAT(log, Not(HasSubstr("hunter2")));
  EXPECT_THAT(log, Not(HasSubstr("unlisted")));
}

// A mistyped level must stop the start with the variable named, not log silently at info.
TEST(EnvOverridesTest, LogLevelVariablesMustNameALevel) {
  for (const char* level : {"debug", "info", "warn", "error", "off"}) {
    EXPECT_TRUE(CheckLogLevelVariables(FakeEnv{{"DRIVEGW_LOG_LEVEL", level}}.Lookup()).ok())
        << level;
  }
  EXPECT_TRUE(CheckLogLevelVariables(FakeEnv{}.Lookup()).ok());
  // Empty = unset (compose files), as for every DRIVEGW_* variable.
  EXPECT_TRUE(CheckLogLevelVariables(FakeEnv{{"DRIVEGW_LOG_LEVEL", ""}}.Lookup()).ok());

  const absl::Status bad =
      CheckLogLevelVariables(FakeEnv{{"DRIVEGW_LOG_LEVEL", "verbose"}}.Lookup());
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("DRIVEGW_LOG_LEVEL: 'verbose' is not a log level"));
  EXPECT_THAT(bad.message(), HasSubstr("debug, info, warn, error, off"));
  // Case matters (the façade compares exactly), and the older alias is checked too.
  EXPECT_FALSE(CheckLogLevelVariables(FakeEnv{{"DRIVEGW_LOG_LEVEL", "INFO"}}.Lookup()).ok());
  const absl::Status alias = CheckLogLevelVariables(FakeEnv{{"DGW_LOG_LEVEL", "warning"}}.Lookup());
  EXPECT_THAT(alias.message(), HasSubstr("DGW_LOG_LEVEL: 'warning'"));
}

}  // namespace
}  // namespace drivegw::config
