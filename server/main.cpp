// drivegw: the gateway process. `drivegw [--config FILE]`; exit code 2 for a bad configuration.
// The file may also come from DRIVEGW_CONFIG, and DRIVEGW_* variables override single keys
// (docs/config.md "Environment", decision 024).
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "adapters/core/log.h"
#include "server/cli/health_cli.h"
#include "server/cli/token_cli.h"
#include "server/config/config.h"
#include "server/config/env_overrides.h"
#include "server/gateway.h"

namespace {

void Usage() {
  std::fprintf(
      stderr,
      "usage: drivegw [--config FILE]\n"
      "       drivegw token create|list|revoke ...   (API tokens; `drivegw token` for help)\n"
      "       drivegw health [--config FILE] [--path /healthz] [--timeout-ms 2000]\n"
      "  Without --config, DRIVEGW_CONFIG names the file; DRIVEGW_LISTEN_HTTP and the\n"
      "  other DRIVEGW_* variables of docs/config.md \"Environment\" override its keys.\n"
      "  Without --config (or with a config that has no `drives:`), drivegw starts its\n"
      "  embedded demo: simulated LinMot drives on loopback UDP, a LinMot DeviceNet\n"
      "  drive on the user-space CAN bus, two axes of a Trinamic SIXpack on a pty and\n"
      "  a STOBER axis (CANopen node 3) on a second user-space CAN bus.\n"
      "  See docs/config.md.\n");
}

// Decision 022: the gateway's graceful shutdown within `bound`; a watchdog ends the process
// (exit 3) should it hang past the bound plus a grace second. 0 = clean, 1 = a drive still moved.
int GracefulShutdown(drivegw::server::Gateway& gateway, std::chrono::seconds bound) {
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;
  std::thread watchdog([&] {
    std::unique_lock lock(mu);
    if (!cv.wait_for(lock, bound + std::chrono::seconds(1), [&] { return done; })) {
      drivegw::log::Error("shutdown_timeout",
                          drivegw::log::Fields().Add("bound_s", bound.count()));
      std::_Exit(3);
    }
  });
  const bool all_stood = gateway.Shutdown(bound);
  {
    std::lock_guard lock(mu);
    done = true;
  }
  cv.notify_all();
  watchdog.join();
  return all_stood ? 0 : 1;
}

// Issue 7: a gateway without authentication says so loudly (the log has WARN lines too).
void PrintNoAuthBanner(bool insecure) {
  std::fprintf(stderr,
               "\n"
               "  ****************************************************************************\n"
               "  *  AUTHENTICATION IS DISABLED (auth.enabled: false)                        *\n"
               "  *  Every call runs as principal 'anonymous' with role ADMIN.               *\n"
               "%s"
               "  *  To enable: auth: {enabled: true} + `drivegw token create` (config.md)   *\n"
               "  ****************************************************************************\n\n",
               insecure ? "  *  insecure: true -- the gateway may be reachable from other hosts!        *\n"
                        : "  *  Listening on loopback only.                                             *\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (drivegw::cli::IsTokenCommand(argc, argv)) {
    return drivegw::cli::RunTokenCommand(argc - 2, argv + 2, stdout, stderr);
  }
  const drivegw::config::EnvLookup env = drivegw::config::ProcessEnvironment();
  if (drivegw::cli::IsHealthCommand(argc, argv)) {
    return drivegw::cli::RunHealthCommand(argc - 2, argv + 2, env, stdout, stderr);
  }
  std::string config_flag;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--config") == 0) {
      if (i + 1 >= argc || argv[i + 1][0] == '\0') {
        std::fprintf(stderr, "drivegw: --config needs a FILE (drivegw --config FILE)\n");
        return 2;
      }
      config_flag = argv[++i];
    } else if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      Usage();
      return 0;
    } else {
      std::fprintf(stderr,
                   "drivegw: unknown argument '%s' (known: --config FILE, --help, token, health)\n",
                   argv[i]);
      Usage();
      return 2;
    }
  }

  if (absl::Status level = drivegw::config::CheckLogLevelVariables(env); !level.ok()) {
    std::fprintf(stderr, "drivegw: %s\n", std::string(level.message()).c_str());
    return 2;
  }
  const std::string config_path = drivegw::config::ResolveConfigPath(config_flag, env);
  if (config_flag.empty() && !config_path.empty()) {
    drivegw::log::Info(
        "config_file",
        drivegw::log::Fields().Add("path", config_path).Add("from", "DRIVEGW_CONFIG"));
  }
  const auto overrides = drivegw::config::OverridesFromEnvironment(env);
  drivegw::config::LogOverrides(overrides);
  absl::StatusOr<drivegw::config::GatewayConfig> cfg =
      drivegw::config::LoadGatewayConfig(config_path, overrides);
  if (!cfg.ok()) {
    std::fprintf(stderr, "drivegw: config %s: %s\n", config_path.empty() ? "(default)" : config_path.c_str(),
                 std::string(cfg.status().message()).c_str());
    return 2;
  }

  const drivegw::config::AuthConfig auth = cfg->auth;  // for the banner after start

  // Block the stop signals in every thread; the main thread waits for them below.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const int shutdown_timeout_s = cfg->shutdown_timeout_s;
  drivegw::server::GatewayOptions options;
  options.config = *std::move(cfg);
  // DGW_WEB_DIR replaces the embedded dashboard (docs/config.md "Environment"); a path that is no
  // directory would answer 404 for every page, so it stops the start instead (decision 1493).
  const char* web = env("DGW_WEB_DIR");
  if (web != nullptr && *web != '\0') {
    std::error_code ec;
    if (!std::filesystem::is_directory(web, ec)) {
      std::fprintf(stderr,
                   "drivegw: DGW_WEB_DIR: '%s' is not a directory (unset it to serve the embedded "
                   "dashboard)\n",
                   web);
      return 2;
    }
    options.static_dir = web;
  }
  auto gateway = drivegw::server::Gateway::Start(std::move(options));
  if (!gateway.ok()) {
    // A start-up error about a key names the variable the value came from (decision 1493).
    const absl::Status named = drivegw::config::NameOverrides(gateway.status(), overrides);
    std::fprintf(stderr, "drivegw: %s\n", std::string(named.message()).c_str());
    return 1;
  }
  std::fprintf(stderr, "drivegw: gRPC on :%u, HTTP on :%u — Ctrl-C stops\n", (*gateway)->grpc_port(),
               (*gateway)->http_port());
  if (!auth.enabled) PrintNoAuthBanner(auth.insecure);

  int sig = 0;
  sigwait(&signals, &sig);
  drivegw::log::Info("signal", drivegw::log::Fields().Add("signal", sig));
  return GracefulShutdown(**gateway, std::chrono::seconds(shutdown_timeout_s));
}
