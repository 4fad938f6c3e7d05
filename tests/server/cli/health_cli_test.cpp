// `drivegw health` (decision 024): the probe against a real demo gateway (exit 0), a closed port,
// a silent port, another status code and an HTTPS gateway with test certificates from openssl;
// where it connects for wildcard listen addresses; exit codes never 2 (Docker reserves it).
#include "server/cli/health_cli.h"

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "server/config/config.h"
#include "server/gateway.h"
#include "tests/server/tls/test_pki.h"
#include "tests/support/demo_gateway.h"

namespace drivegw::cli {
namespace {

using ::testing::HasSubstr;

// ---- where the probe connects ----

TEST(ProbeTargetFor_Wildcard, BecomesLoopback) {
  auto v4 = ProbeTargetFor("0.0.0.0:8080");
  ASSERT_TRUE(v4.ok()) << v4.status();
  EXPECT_EQ(v4->host, "127.0.0.1");
  EXPECT_EQ(v4->port, 8080);
  auto any = ProbeTargetFor(":8081");
  ASSERT_TRUE(any.ok()) << any.status();
  EXPECT_EQ(any->host, "127.0.0.1");
  EXPECT_EQ(any->port, 8081);
  auto v6 = ProbeTargetFor("[::]:8082");
  ASSERT_TRUE(v6.ok()) << v6.status();
  EXPECT_EQ(v6->host, "::1");
}

TEST(ProbeTargetFor_Specific, KeptWithoutBrackets) {
  auto v6 = ProbeTargetFor("[::1]:9000");
  ASSERT_TRUE(v6.ok()) << v6.status();
  EXPECT_EQ(v6->host, "::1");
  EXPECT_EQ(v6->port, 9000);
  auto name = ProbeTargetFor("localhost:9001");
  ASSERT_TRUE(name.ok()) << name.status();
  EXPECT_EQ(name->host, "localhost");
}

TEST(ProbeTargetFor_PortZero, FailedPrecondition) {
  EXPECT_EQ(ProbeTargetFor("127.0.0.1:0").status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(ProbeTargetFor("nohostport").status().code(), absl::StatusCode::kInvalidArgument);
}

// ---- the command ----

using Env = std::map<std::string, std::string>;

struct HealthRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string ReadAll(std::FILE* f) {
  std::rewind(f);
  std::string text;
  char buf[512];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  return text;
}

HealthRun RunHealth(std::vector<std::string> args, const Env& env) {
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  const config::EnvLookup lookup = [&env](const char* name) -> const char* {
    auto it = env.find(name);
    return it == env.end() ? nullptr : it->second.c_str();
  };
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> out(std::tmpfile(), &std::fclose);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> err(std::tmpfile(), &std::fclose);
  HealthRun r;
  r.exit_code =
      RunHealthCommand(static_cast<int>(argv.size()), argv.data(), lookup, out.get(), err.get());
  r.out = ReadAll(out.get());
  r.err = ReadAll(err.get());
  return r;
}

std::string Loopback(int port) { return "127.0.0.1:" + std::to_string(port); }

// A TCP socket on an ephemeral loopback port; listening or merely bound (= connections refused).
class LocalSocket {
 public:
  explicit LocalSocket(bool listening) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), len) == 0 &&
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
      port_ = ntohs(addr.sin_port);
    }
    if (listening) ::listen(fd_, 4);
  }
  ~LocalSocket() { ::close(fd_); }
  LocalSocket(const LocalSocket&) = delete;
  LocalSocket& operator=(const LocalSocket&) = delete;
  int port() const { return port_; }

 private:
  int fd_ = -1;
  int port_ = 0;
};

TEST(RunHealthCommand_ClosedPort, ExitOneConnectRefused) {
  // Bound but not listening: the kernel answers a SYN with RST, and the port stays ours.
  LocalSocket bound(/*listening=*/false);
  ASSERT_NE(bound.port(), 0);
  const HealthRun r = RunHealth({}, {{"DRIVEGW_LISTEN_HTTP", Loopback(bound.port())}});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("connect to " + Loopback(bound.port()) + ": Connection refused"));
  EXPECT_EQ(r.out, "");
}

TEST(RunHealthCommand_SilentPort, ExitOneNoAnswerWithinTimeout) {
  // Listening but never accepting: the kernel completes the connection, nobody answers.
  LocalSocket silent(/*listening=*/true);
  ASSERT_NE(silent.port(), 0);
  const HealthRun r =
      RunHealth({"--timeout-ms", "200"}, {{"DRIVEGW_LISTEN_HTTP", Loopback(silent.port())}});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no answer within 200 ms"));
}

TEST(RunHealthCommand_Usage, ErrorsExitOneNeverTwo) {
  HealthRun r = RunHealth({"--bogus"}, {});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("unknown argument '--bogus'"));
  r = RunHealth({"--timeout-ms", "0"}, {});
  EXPECT_EQ(r.exit_code, 1);
  r = RunHealth({"--path", "healthz"}, {});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("must start with /"));
  r = RunHealth({"--config"}, {});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("--config needs a value"));
}

TEST(RunHealthCommand_BadConfig, ExitOneNamingVariable) {
  const HealthRun r = RunHealth({}, {{"DRIVEGW_LISTEN_HTTP", "abc"}});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("listen.http (from DRIVEGW_LISTEN_HTTP): 'abc' is not a host:port"));
  const HealthRun missing = RunHealth({}, {{"DRIVEGW_CONFIG", "/nonexistent/drivegw.yaml"}});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("file not found (path=/nonexistent/drivegw.yaml)"));
}

// A temporary directory removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/drivegw-health-XXXXXX";
    if (::mkdtemp(tmpl) != nullptr) path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

class HealthDemoGatewayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(dir_.path().empty());
    auto gw = server::Gateway::Start(test_support::DemoGatewayOptions(dir_.path()));
    ASSERT_TRUE(gw.ok()) << gw.status();
    gw_ = std::move(*gw);
  }
  void TearDown() override { gw_.reset(); }

  TempDir dir_;
  std::unique_ptr<server::Gateway> gw_;
};

TEST_F(HealthDemoGatewayTest, HealthzExitZero) {
  const HealthRun r = RunHealth({}, {{"DRIVEGW_LISTEN_HTTP", Loopback(gw_->http_port())}});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "drivegw health: http://" + Loopback(gw_->http_port()) + "/healthz: HTTP 200\n");
  EXPECT_EQ(r.err, "");
}

TEST_F(HealthDemoGatewayTest, ConfigFileFromFlagWinsOverDrivegwConfig) {
  const std::string file = dir_.path() + "/gw.yaml";
  testing::WriteFile(file, "listen: {http: \"" + Loopback(gw_->http_port()) + "\"}\n");
  // DRIVEGW_CONFIG names a missing file: only --config may be read.
  HealthRun r = RunHealth({"--config", file}, {{"DRIVEGW_CONFIG", dir_.path() + "/missing.yaml"}});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = RunHealth({}, {{"DRIVEGW_CONFIG", file}});
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST_F(HealthDemoGatewayTest, OtherStatusExitOneNamingCode) {
  const HealthRun r = RunHealth({"--path", "/no-such-route"},
                                {{"DRIVEGW_LISTEN_HTTP", Loopback(gw_->http_port())}});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("GET http://" + Loopback(gw_->http_port()) +
                               "/no-such-route: HTTP 404 Not Found"));
}

class HealthTlsGatewayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    pki_ = new testing::TestPki();
    ASSERT_TRUE(pki_->MakeCa("ca", "drivegw test CA"));
    ASSERT_TRUE(pki_->MakeLeaf("ca", "server", "localhost", /*server=*/true));
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }

  // A gateway without drives whose tls: section is cert + key + `extra`; returns the YAML
  // a probe reads (the same tls: section, listen.http on the gateway's port).
  std::string Start(const std::string& extra) {
    const std::string tls = "tls:\n  cert: \"" + pki_->Path("server.pem") + "\"\n  key: \"" +
                            pki_->Path("server.key") + "\"\n" + extra;
    auto cfg = config::ParseConfig("listen: {grpc: \"127.0.0.1:0\", http: \"127.0.0.1:0\"}\n" +
                                   ("data_dir: \"" + dir_.path() + "\"\n") + tls);
    EXPECT_TRUE(cfg.ok()) << cfg.status();
    if (!cfg.ok()) return "";
    server::GatewayOptions options;
    options.config = *std::move(cfg);
    options.config.demo = false;  // no drives: only the HTTPS port matters here
    auto gw = server::Gateway::Start(std::move(options));
    EXPECT_TRUE(gw.ok()) << gw.status();
    if (!gw.ok()) return "";
    gw_ = std::move(*gw);
    const std::string file = dir_.path() + "/probe.yaml";
    testing::WriteFile(file, "listen: {http: \"" + Loopback(gw_->http_port()) + "\"}\n" + tls);
    return file;
  }
  void TearDown() override { gw_.reset(); }

  static testing::TestPki* pki_;
  TempDir dir_;
  std::unique_ptr<server::Gateway> gw_;
};

testing::TestPki* HealthTlsGatewayTest::pki_ = nullptr;

TEST_F(HealthTlsGatewayTest, HttpsExitZeroWithoutTrustingTheCa) {
  const std::string file = Start("");
  ASSERT_FALSE(file.empty());
  const HealthRun r = RunHealth({"--config", file}, {});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out,
            "drivegw health: https://" + Loopback(gw_->http_port()) + "/healthz: HTTP 200\n");
}

TEST_F(HealthTlsGatewayTest, RequiredClientCertificateExitOneWithHint) {
  const std::string file =
      Start("  client_ca: \"" + pki_->Path("ca.pem") + "\"\n  require_client_cert: true\n");
  ASSERT_FALSE(file.empty());
  const HealthRun r = RunHealth({"--config", file, "--timeout-ms", "5000"}, {});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("the probe has no client certificate"));
}

}  // namespace
}  // namespace drivegw::cli
