// `drivegw health`: a local HTTP(S) probe of the gateway's own /healthz, for the Docker
// HEALTHCHECK of an image without curl (issue 9, decision 024).
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/config/env_overrides.h"

namespace drivegw::cli {

// Where the probe connects for a listen.http address.
struct ProbeTarget {
  std::string host;  // without brackets: "127.0.0.1", "::1", "gw.local"
  uint16_t port = 0;
};

// The wildcard hosts "0.0.0.0", "" (":8080") and "[::]" become 127.0.0.1 / ::1: the gateway
// listening on every interface is reached on loopback. FailedPrecondition for port 0 (chosen by
// the system at start, so there is nothing to probe); InvalidArgument for no host:port.
absl::StatusOr<ProbeTarget> ProbeTargetFor(std::string_view listen_http);

struct ProbeOptions {
  std::string path = "/healthz";
  std::chrono::milliseconds timeout{2000};  // one deadline for connect, handshake and exchange
  bool tls = false;                         // HTTPS, without certificate verification
};

// GET options.path on the target. OK on HTTP 200; otherwise one line saying what failed:
// Unavailable (cannot resolve, connect refused, TLS handshake, or another status code),
// DeadlineExceeded (no complete answer within the timeout).
absl::Status ProbeHealth(const ProbeTarget& target, const ProbeOptions& options);

// True when argv[1] is "health": main.cpp dispatches to RunHealthCommand.
bool IsHealthCommand(int argc, const char* const* argv);

// `args` are the words after "health" (argv + 2): [--config FILE] [--path /readyz]
// [--timeout-ms 2000]. The configuration is loaded as the gateway loads it (DRIVEGW_CONFIG and
// the DRIVEGW_* overrides read through `env`). Exit 0 on HTTP 200 (one line on `out`), 1 for
// anything else with one line on `err`; never 2, which Docker reserves.
int RunHealthCommand(int argc, const char* const* args, const config::EnvLookup& env,
                     std::FILE* out, std::FILE* err);

}  // namespace drivegw::cli
