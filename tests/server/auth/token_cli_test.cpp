// `drivegw token ...` (server/cli): a token created by the CLI in the configured data_dir works
// against a gateway started from the same configuration; list shows no secret; revoke refuses
// the next call; usage and configuration errors exit 2 and say why.
#include "server/cli/token_cli.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/config/config.h"
#include "server/gateway.h"
#include "tests/server/rest/http_client.h"

namespace drivegw::cli {
namespace {

using ::testing::HasSubstr;

struct CliRun {
  int code = 0;
  std::string out;
  std::string err;
};

std::string ReadAll(std::FILE* f) {
  std::rewind(f);
  std::string text;
  char buf[4096];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  std::fclose(f);
  return text;
}

CliRun Token(std::vector<std::string> args) {
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  std::FILE* out = std::tmpfile();
  std::FILE* err = std::tmpfile();
  CliRun r;
  r.code = RunTokenCommand(static_cast<int>(argv.size()), argv.data(), out, err);
  r.out = ReadAll(out);
  r.err = ReadAll(err);
  return r;
}

class TokenCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-cli-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    config_ = dir_ + "/gw.yaml";
    std::ofstream(config_) << "data_dir: " << dir_ << "/data\n"
                           << "auth: {enabled: true}\n"
                           << "listen: {grpc: '127.0.0.1:0', http: '127.0.0.1:0'}\n";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::unique_ptr<server::Gateway> StartGateway() {
    auto cfg = config::LoadConfigFile(config_);
    EXPECT_TRUE(cfg.ok()) << cfg.status();
    if (!cfg.ok()) return nullptr;
    std::random_device rd;
    const auto can_port = static_cast<uint16_t>(20000 + rd() % 20000);
    server::GatewayOptions o;
    o.config = *std::move(cfg);
    o.demo_first_port = 0;
    o.demo_master_port = 0;
    o.demo_can_port = can_port;
    o.demo_canopen_port = static_cast<uint16_t>(can_port + 1);
    auto gw = server::Gateway::Start(o);
    EXPECT_TRUE(gw.ok()) << gw.status();
    return gw.ok() ? std::move(*gw) : nullptr;
  }

  int Get(const server::Gateway& gw, const std::string& token) {
    rest::test_support::HttpClient client(gw.http_port());
    EXPECT_TRUE(client.SendRequest("GET", "/v1/drives", "",
                                   token.empty() ? "" : "Authorization: Bearer " + token + "\r\n"));
    auto r = client.Read();
    return r ? r->status : 0;
  }

  std::string dir_;
  std::string config_;
};

TEST_F(TokenCliTest, Create_ThenUseAgainstTheGateway_RevokeRefusesNextCall) {
  const CliRun created =
      Token({"create", "--role", "operator", "--name", "mes-line-3", "--config", config_});
  ASSERT_EQ(created.code, 0) << created.err;
  ASSERT_THAT(created.out, ::testing::MatchesRegex("dgw_[0-9a-f]{16}_[A-Za-z0-9_-]{43}\n"));
  const std::string token = created.out.substr(0, created.out.size() - 1);
  EXPECT_THAT(created.err, HasSubstr("shown only now"));

  auto gw = StartGateway();
  ASSERT_NE(gw, nullptr);
  EXPECT_EQ(Get(*gw, ""), 401);
  EXPECT_EQ(Get(*gw, token), 200);

  const CliRun list = Token({"list", "--config", config_});
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_THAT(list.out, HasSubstr("mes-line-3"));
  EXPECT_THAT(list.out, HasSubstr("operator"));
  EXPECT_EQ(list.out.find(token.substr(21)), std::string::npos) << "no secret in the list";

  const CliRun revoked = Token({"revoke", "mes-line-3", "--config", config_});
  ASSERT_EQ(revoked.code, 0) << revoked.err;
  EXPECT_EQ(Get(*gw, token), 401);  // the running gateway holds no cache
}

TEST_F(TokenCliTest, DuplicateLiveName_Exit1NamingIt) {
  ASSERT_EQ(Token({"create", "--role", "viewer", "--name", "dash", "--config", config_}).code, 0);
  const CliRun dup = Token({"create", "--role", "viewer", "--name", "dash", "--config", config_});
  EXPECT_EQ(dup.code, 1);
  EXPECT_THAT(dup.err, HasSubstr("a live token 'dash' exists"));
  EXPECT_TRUE(dup.out.empty());
}

TEST_F(TokenCliTest, UsageAndConfigErrors_Exit2) {
  EXPECT_EQ(Token({}).code, 2);
  const CliRun no_role = Token({"create", "--name", "x", "--config", config_});
  EXPECT_EQ(no_role.code, 2);
  EXPECT_THAT(no_role.err, HasSubstr("create needs --name and --role"));
  EXPECT_EQ(Token({"rotate", "--config", config_}).code, 2);
  const CliRun bad_role = Token({"create", "--name", "x", "--role", "root", "--config", config_});
  EXPECT_EQ(bad_role.code, 1);
  EXPECT_THAT(bad_role.err, HasSubstr("role: 'root' is not one of"));
  const CliRun missing = Token({"list", "--config", dir_ + "/nope.yaml"});
  EXPECT_EQ(missing.code, 2);
  EXPECT_THAT(missing.err, HasSubstr("nope.yaml"));
}

}  // namespace
}  // namespace drivegw::cli
