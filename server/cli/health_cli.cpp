// `drivegw health`: configuration as the gateway loads it, then one GET over Beast (HTTP, or
// HTTPS when `tls:` is configured), bounded by one deadline. Exit codes follow Docker's
// HEALTHCHECK: 0 healthy, 1 unhealthy, 2 reserved (docs.docker.com, Dockerfile reference,
// "HEALTHCHECK": "2: reserved - do not use this exit code").
#include "server/cli/health_cli.h"

#include <algorithm>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>
#include <cstring>
#include <type_traits>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace drivegw::cli {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

constexpr char kUsage[] =
    "usage: drivegw health [--config FILE] [--path /healthz] [--timeout-ms 2000]\n"
    "  GETs the path from listen.http of the configuration (file from --config or\n"
    "  DRIVEGW_CONFIG, DRIVEGW_* overrides applied; 0.0.0.0 / [::] probed on loopback),\n"
    "  over HTTPS when tls: is configured. Exit 0 on HTTP 200, 1 otherwise.\n";

constexpr int64_t kMaxTimeoutMs = 60000;
// A health answer is a few bytes; /metrics is the largest thing anyone would probe.
constexpr uint64_t kMaxBodyBytes = 1 << 20;
// How much of a non-200 body goes into the one-line message (readyz says why it is not ready).
constexpr size_t kBodyHintChars = 200;

struct Args {
  std::string config_flag;
  std::string path = "/healthz";
  int64_t timeout_ms = 2000;
  bool help = false;
};

// Parses args into `a`; returns an error message ("" when fine).
std::string Parse(int argc, const char* const* args, Args& a) {
  for (int i = 0; i < argc; ++i) {
    const std::string arg = args[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--config" && has_value) {
      a.config_flag = args[++i];
    } else if (arg == "--path" && has_value) {
      a.path = args[++i];
      // The request target goes into the request line verbatim: no spaces or control bytes.
      const bool printable =
          std::all_of(a.path.begin(), a.path.end(), [](char c) { return c > 0x20 && c < 0x7f; });
      if (a.path.empty() || a.path.front() != '/' || !printable) {
        return absl::StrCat("--path '", a.path, "' must start with / and hold no spaces");
      }
    } else if (arg == "--timeout-ms" && has_value) {
      const std::string value = args[++i];
      if (!absl::SimpleAtoi(value, &a.timeout_ms) || a.timeout_ms < 1 ||
          a.timeout_ms > kMaxTimeoutMs) {
        return absl::StrCat("--timeout-ms '", value, "' is not 1..", kMaxTimeoutMs);
      }
    } else if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--config" || arg == "--path" || arg == "--timeout-ms") {
      return absl::StrCat(arg, " needs a value");
    } else {
      return absl::StrCat("unknown argument '", arg, "'");
    }
  }
  return "";
}

// "127.0.0.1:8080" or "[::1]:8080": the Host header and the address in messages.
std::string HostPort(const ProbeTarget& t) {
  return t.host.find(':') == std::string::npos ? absl::StrCat(t.host, ":", t.port)
                                               : absl::StrCat("[", t.host, "]:", t.port);
}

std::string BodyHint(const std::string& body) {
  std::string line = body.substr(0, body.find_first_of("\r\n"));
  if (line.size() > kBodyHintChars) line = absl::StrCat(line.substr(0, kBodyHintChars), "...");
  return line.empty() ? "" : absl::StrCat(": ", line);
}

// One GET over `Stream` (beast::tcp_stream, or beast::ssl_stream over one): the do/on chain of
// Beast's client examples. The tcp_stream's expiry, set once, bounds every step after it.
template <class Stream>
absl::Status Exchange(net::io_context& ioc, Stream& stream,
                      const tcp::resolver::results_type& endpoints, const ProbeTarget& target,
                      const ProbeOptions& options) {
  constexpr bool kTls = !std::is_same_v<Stream, beast::tcp_stream>;
  const std::string address = HostPort(target);
  const std::string get =
      absl::StrCat("GET ", kTls ? "https://" : "http://", address, options.path);
  http::request<http::empty_body> request{http::verb::get, options.path, 11};
  request.set(http::field::host, address);
  request.set(http::field::user_agent, "drivegw-health");
  request.keep_alive(false);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(kMaxBodyBytes);

  absl::Status result = absl::InternalError("drivegw health: the probe did not finish");
  auto fail = [&](const std::string& step, beast::error_code ec) {
    if (ec == beast::error::timeout) {
      result = absl::DeadlineExceededError(
          absl::StrCat(step, ": no answer within ", options.timeout.count(), " ms"));
    } else {
      result = absl::UnavailableError(absl::StrCat(step, ": ", ec.message()));
    }
  };
  auto on_read = [&](beast::error_code ec, size_t) {
    if (ec) return fail(get, ec);
    const auto& response = parser.get();
    if (response.result_int() == 200) {
      result = absl::OkStatus();
      return;
    }
    result = absl::UnavailableError(absl::StrCat(get, ": HTTP ", response.result_int(), " ",
                                                 std::string(response.reason()),
                                                 BodyHint(response.body())));
  };
  auto on_write = [&](beast::error_code ec, size_t) {
    if (ec) return fail(get, ec);
    http::async_read(stream, buffer, parser, on_read);
  };
  auto send = [&] { http::async_write(stream, request, on_write); };

  beast::get_lowest_layer(stream).expires_after(options.timeout);
  beast::get_lowest_layer(stream).async_connect(
      endpoints, [&](beast::error_code ec, const tcp::endpoint&) {
        if (ec) return fail(absl::StrCat("connect to ", address), ec);
        if constexpr (kTls) {
          stream.async_handshake(net::ssl::stream_base::client, [&](beast::error_code hs) {
            if (hs) return fail(absl::StrCat("TLS handshake with ", address), hs);
            send();
          });
        } else {
          send();
        }
      });
  ioc.run();
  return result;
}

}  // namespace

absl::StatusOr<ProbeTarget> ProbeTargetFor(std::string_view listen_http) {
  const size_t colon = listen_http.rfind(':');
  uint32_t port = 0;
  if (colon == std::string_view::npos ||
      !absl::SimpleAtoi(
          absl::string_view(listen_http.data() + colon + 1, listen_http.size() - colon - 1),
          &port) ||
      port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen.http: '", std::string(listen_http), "' is not a host:port"));
  }
  if (port == 0) {
    return absl::FailedPreconditionError(
        "listen.http: port 0 is chosen by the system at start, so there is nothing to probe");
  }
  std::string host(listen_http.substr(0, colon));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  // The wildcard addresses accept on every interface, loopback included.
  if (host.empty() || host == "0.0.0.0") host = "127.0.0.1";
  if (host == "::") host = "::1";
  return ProbeTarget{host, static_cast<uint16_t>(port)};
}

absl::Status ProbeHealth(const ProbeTarget& target, const ProbeOptions& options) {
  net::io_context ioc;
  tcp::resolver resolver(ioc);
  beast::error_code ec;
  // Synchronous: the target is loopback or a local name from the gateway's own configuration.
  const auto endpoints = resolver.resolve(target.host, std::to_string(target.port), ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot resolve '", target.host, "': ", ec.message()));
  }
  if (!options.tls) {
    beast::tcp_stream stream(ioc);
    return Exchange(ioc, stream, endpoints, target, options);
  }
  // No certificate verification: the probe asks whether the local process answers, not who it
  // is. It connects to 127.0.0.1 (or the configured host) where a certificate issued for the
  // gateway's public name would not match anyway, and a self-signed or private-CA certificate
  // must not make a healthy container unhealthy (decision 024).
  net::ssl::context ctx(net::ssl::context::tls_client);
  ctx.set_verify_mode(net::ssl::verify_none);
  beast::ssl_stream<beast::tcp_stream> stream(ioc, ctx);
  return Exchange(ioc, stream, endpoints, target, options);
}

bool IsHealthCommand(int argc, const char* const* argv) {
  return argc >= 2 && std::strcmp(argv[1], "health") == 0;
}

int RunHealthCommand(int argc, const char* const* args, const config::EnvLookup& env,
                     std::FILE* out, std::FILE* err) {
  Args a;
  if (std::string problem = Parse(argc, args, a); !problem.empty()) {
    std::fprintf(err, "drivegw health: %s\n%s", problem.c_str(), kUsage);
    return 1;
  }
  if (a.help) {
    std::fprintf(out, "%s", kUsage);
    return 0;
  }
  const std::string path = config::ResolveConfigPath(a.config_flag, env);
  const auto overrides = config::OverridesFromEnvironment(env);
  absl::StatusOr<config::GatewayConfig> cfg = config::LoadGatewayConfig(path, overrides);
  if (!cfg.ok()) {
    std::fprintf(err, "drivegw health: config %s: %s\n", path.empty() ? "(default)" : path.c_str(),
                 std::string(cfg.status().message()).c_str());
    return 1;
  }
  absl::StatusOr<ProbeTarget> target = ProbeTargetFor(cfg->listen.http);
  if (!target.ok()) {
    std::fprintf(err, "drivegw health: %s\n", std::string(target.status().message()).c_str());
    return 1;
  }
  ProbeOptions options;
  options.path = a.path;
  options.timeout = std::chrono::milliseconds(a.timeout_ms);
  options.tls = cfg->tls.has_value();
  const absl::Status s = ProbeHealth(*target, options);
  if (!s.ok()) {
    const bool needs_client_cert = cfg->tls && cfg->tls->require_client_cert;
    std::fprintf(err, "drivegw health: %s%s\n", std::string(s.message()).c_str(),
                 needs_client_cert ? " (tls.require_client_cert: true, and the probe has no "
                                     "client certificate)"
                                   : "");
    return 1;
  }
  std::fprintf(out, "drivegw health: %s%s%s: HTTP 200\n", options.tls ? "https://" : "http://",
               HostPort(*target).c_str(), options.path.c_str());
  return 0;
}

}  // namespace drivegw::cli
