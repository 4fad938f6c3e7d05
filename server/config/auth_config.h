// auth: {enabled} and the top-level `insecure` switch (issue 7, docs/config.md "auth",
// decision 015): whether calls need a bearer token or a mapped client certificate, and the rule
// that a gateway without authentication listens on loopback only unless told `insecure: true`.
#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace drivegw::config {

struct AuthConfig {
  // false: every call runs as principal "anonymous" with role admin (the embedded demo).
  bool enabled = false;
  // Top-level `insecure: true`: allows listening beyond loopback with auth disabled.
  bool insecure = false;
};

// True for a "host:port" whose host is loopback: 127.0.0.0/8, "localhost", "::1" / "[::1]".
// "0.0.0.0", "[::]", ":50051" (every interface) and other hosts are not.
bool IsLoopback(std::string_view host_port);

// FailedPrecondition naming the key when auth is disabled, insecure is not set and `grpc` or
// `http` listens beyond loopback. Gateway::Start checks programmatic configurations with it.
absl::Status CheckListenExposure(const AuthConfig& auth, std::string_view grpc,
                                 std::string_view http);

namespace internal {
class Section;
// Reads `auth` and `insecure` of the root mapping.
void ParseAuth(const Section& root, AuthConfig& out);
// After listen is parsed: with auth disabled (and not insecure) an absent listen.grpc /
// listen.http defaults to loopback (127.0.0.1, same port), and an explicit non-loopback one
// is an error naming the key.
void ApplyAuthToListen(const Section& root, const AuthConfig& auth, std::string& grpc,
                       std::string& http);
}  // namespace internal

}  // namespace drivegw::config
