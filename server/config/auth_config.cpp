// auth / insecure: parsing, loopback defaults for listen, and the exposure rule (decision 015).
#include "server/config/auth_config.h"

#include <optional>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/config/section.h"

namespace drivegw::config {
namespace {

std::string_view HostOf(std::string_view host_port) {
  const size_t colon = host_port.rfind(':');
  return colon == std::string_view::npos ? host_port : host_port.substr(0, colon);
}

std::string PortOf(std::string_view host_port) {
  const size_t colon = host_port.rfind(':');
  return std::string(colon == std::string_view::npos ? "" : host_port.substr(colon + 1));
}

std::string ExposureMessage(std::string_view value) {
  return absl::StrCat("'", std::string(value),
                      "' is not a loopback address and auth is disabled: set auth.enabled: true "
                      "(and create tokens with `drivegw token create`), listen on 127.0.0.1, or "
                      "accept an open gateway with insecure: true");
}

}  // namespace

bool IsLoopback(std::string_view host_port) {
  const std::string_view host = HostOf(host_port);
  if (host == "localhost" || host == "[::1]" || host == "::1") return true;
  // 127.0.0.0/8 (RFC 1122 §3.2.1.3): "127." followed by the rest of a dotted quad.
  if (!absl::StartsWith(absl::string_view(host.data(), host.size()), "127.")) return false;
  int dots = 0;
  for (char c : host) {
    if (c == '.') {
      ++dots;
    } else if (c < '0' || c > '9') {
      return false;
    }
  }
  return dots == 3;
}

absl::Status CheckListenExposure(const AuthConfig& auth, std::string_view grpc,
                                 std::string_view http) {
  if (auth.enabled || auth.insecure) return absl::OkStatus();
  if (!IsLoopback(grpc)) {
    return absl::FailedPreconditionError(absl::StrCat("listen.grpc: ", ExposureMessage(grpc)));
  }
  if (!IsLoopback(http)) {
    return absl::FailedPreconditionError(absl::StrCat("listen.http: ", ExposureMessage(http)));
  }
  return absl::OkStatus();
}

namespace internal {

void ParseAuth(const Section& root, AuthConfig& out) {
  root.Bool("insecure", out.insecure);
  const auto node = root.Get("auth");
  if (!node) return;
  const Section s(*node, root.Child("auth"), {"enabled"}, root.errors());
  if (!node->IsNull() && !node->IsMap()) return;
  s.Bool("enabled", out.enabled);
}

void ApplyAuthToListen(const Section& root, const AuthConfig& auth, std::string& grpc,
                       std::string& http) {
  if (auth.enabled || auth.insecure) return;
  const std::optional<YAML::Node> listen = root.Get("listen");
  for (auto [key, value] : {std::pair<const char*, std::string*>{"grpc", &grpc},
                            std::pair<const char*, std::string*>{"http", &http}}) {
    const YAML::Node given =
        listen && listen->IsMap() ? (*listen)[key] : YAML::Node(YAML::NodeType::Undefined);
    if (!given.IsDefined()) {
      // Unset: the default port on loopback instead of every interface.
      *value = absl::StrCat("127.0.0.1:", PortOf(*value));
    } else if (given.IsScalar() && given.Scalar() == *value && !IsLoopback(*value)) {
      // (A value ParseListen refused is reported there, not twice.)
      root.errors().Add(absl::StrCat("listen.", key), ExposureMessage(*value), given);
    }
  }
}

}  // namespace internal
}  // namespace drivegw::config
