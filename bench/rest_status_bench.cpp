// P4 (issue 10): requests/s of GET /v1/drives/x1 through the gateway's REST front end (Beast
// session -> router -> in-process gRPC GetDrive -> core -> JSON) with 16 keep-alive connections,
// against a bare Beast endpoint in the same binary (same io_context threading as server/rest:
// 2 threads, a strand per connection, request_parser + string_body) answering a fixed body of the
// same size. One load generator for both: one thread, raw non-blocking sockets, poll(), one
// request in flight per connection (closed loop), pre-built request bytes. GET /v1/drives/x1 takes
// the direct read path (decision 1331); a second gateway measures the in-process gRPC path too.
// Run: build/bench/rest_status_bench [seconds per round = 2] [rounds = 4] [connections = 16]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/bind_handler.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench/demo_gateway.h"
#include "bench/report.h"
#include "google/protobuf/arena.h"
#include "google/protobuf/util/json_util.h"
#include "server/core/drive_service.h"
#include "server/gateway.h"
#include "server/rest/json_cache.h"
#include "server/rest/json_print.h"

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "rest_status_bench: %s\n", what.c_str());
  std::exit(1);
}

// --- bare Beast endpoint -----------------------------------------------------------------------

// The advanced-server session shape (STYLE.md §5) cut down to what a keep-alive GET needs.
class BareSession : public std::enable_shared_from_this<BareSession> {
 public:
  BareSession(tcp::socket socket, const std::string& body)
      : socket_(std::move(socket)), body_(body) {}
  void Run() { DoRead(); }

 private:
  void DoRead() {
    parser_.emplace();
    parser_->body_limit(1 << 20);
    parser_->header_limit(16384);
    http::async_read(socket_, buffer_, *parser_,
                     beast::bind_front_handler(&BareSession::OnRead, shared_from_this()));
  }
  void OnRead(beast::error_code ec, size_t) {
    if (ec) return;
    auto req = parser_->release();
    auto res = std::make_shared<http::response<http::string_body>>(http::status::ok, req.version());
    res->set(http::field::server, "drivegw");
    res->set(http::field::content_type, "application/json");
    res->keep_alive(req.keep_alive());
    res->body() = body_;
    res->prepare_payload();
    http::async_write(socket_, *res,
                      [self = shared_from_this(), res](beast::error_code wec, size_t) {
                        if (!wec && res->keep_alive()) self->DoRead();
                      });
  }

  tcp::socket socket_;
  const std::string& body_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

class BareServer {
 public:
  explicit BareServer(std::string body) : body_(std::move(body)) {
    const tcp::endpoint ep(net::ip::make_address("127.0.0.1"), 0);
    acceptor_.open(ep.protocol());
    acceptor_.set_option(net::socket_base::reuse_address(true));
    acceptor_.bind(ep);
    acceptor_.listen();
    port_ = acceptor_.local_endpoint().port();
    DoAccept();
    for (int i = 0; i < 2; ++i)
      threads_.emplace_back([this] { ioc_.run(); });  // RestOptions::threads
  }
  ~BareServer() {
    ioc_.stop();
    for (auto& t : threads_) t.join();
  }
  uint16_t port() const { return port_; }

 private:
  void DoAccept() {
    acceptor_.async_accept(net::make_strand(ioc_), [this](beast::error_code ec, tcp::socket s) {
      if (ec) return;
      s.set_option(tcp::no_delay(true));
      std::make_shared<BareSession>(std::move(s), body_)->Run();
      DoAccept();
    });
  }

  std::string body_;
  net::io_context ioc_{2};
  tcp::acceptor acceptor_{net::make_strand(ioc_)};
  std::vector<std::thread> threads_;
  uint16_t port_ = 0;
};

// --- load generator ----------------------------------------------------------------------------

struct LoadResult {
  double cpu_s = 0;  // CPU time of the whole process (server and load generator) during the run
  long requests = 0;
  long errors = 0;  // non-200 responses
  double seconds = 0;
  std::vector<double> latency_us;
  size_t body_bytes = 0;  // of the last response
};

// Keep-alive connections, one request in flight each, for `seconds`.
LoadResult RunLoad(uint16_t port, const std::string& target, int connections, double seconds) {
  const std::string request =
      "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: application/json\r\n\r\n";
  struct Conn {
    int fd = -1;
    std::string in;
    Clock::time_point sent;
  };
  std::vector<Conn> conns(static_cast<size_t>(connections));
  for (auto& c : conns) {
    c.fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(c.fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) Die("connect failed");
    int one = 1;
    ::setsockopt(c.fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    c.in.reserve(4096);
  }
  LoadResult r;
  r.latency_us.reserve(200000);
  auto send = [&](Conn& c) {
    c.sent = Clock::now();
    if (::send(c.fd, request.data(), request.size(), MSG_NOSIGNAL) !=
        static_cast<ssize_t>(request.size())) {
      Die("send failed");
    }
  };
  const double cpu0 = drivegw::bench::ProcessCpuSeconds();
  const auto start = Clock::now();
  const auto end =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  for (auto& c : conns) send(c);
  std::vector<pollfd> pfds(conns.size());
  for (size_t i = 0; i < conns.size(); ++i) pfds[i] = {conns[i].fd, POLLIN, 0};
  size_t outstanding = conns.size();
  char buf[65536];
  while (outstanding > 0) {
    if (::poll(pfds.data(), pfds.size(), 2000) <= 0) Die("no response within 2 s");
    for (size_t i = 0; i < conns.size(); ++i) {
      if ((pfds[i].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
      Conn& c = conns[i];
      const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
      if (n <= 0) Die("connection closed by the server");
      c.in.append(buf, static_cast<size_t>(n));
      // Whole responses only: header end, then Content-Length bytes of body.
      const size_t hdr_end = c.in.find("\r\n\r\n");
      if (hdr_end == std::string::npos) continue;
      const size_t cl = c.in.find("Content-Length: ");
      if (cl == std::string::npos || cl > hdr_end) Die("response without Content-Length");
      const size_t body_len = std::strtoul(c.in.c_str() + cl + 16, nullptr, 10);
      if (c.in.size() < hdr_end + 4 + body_len) continue;
      const auto now = Clock::now();
      if (c.in.compare(0, 12, "HTTP/1.1 200") != 0) ++r.errors;
      r.body_bytes = body_len;
      c.in.erase(0, hdr_end + 4 + body_len);
      ++r.requests;
      r.latency_us.push_back(std::chrono::duration<double, std::micro>(now - c.sent).count());
      if (now < end) {
        send(c);
      } else {
        pfds[i].events = 0;
        --outstanding;
      }
    }
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  r.cpu_s = drivegw::bench::ProcessCpuSeconds() - cpu0;
  for (auto& c : conns) ::close(c.fd);
  return r;
}

struct Summary {
  double rps = 0, p50 = 0, p99 = 0;
  double cpu_us = 0;  // process CPU per request (server + load generator)
  long n = 0, errors = 0;
};

Summary Summarize(const std::vector<LoadResult>& runs) {
  Summary s;
  double secs = 0, cpu = 0;
  std::vector<double> lat;
  for (const auto& r : runs) {
    cpu += r.cpu_s;
    s.n += r.requests;
    s.errors += r.errors;
    secs += r.seconds;
    lat.insert(lat.end(), r.latency_us.begin(), r.latency_us.end());
  }
  s.rps = secs > 0 ? static_cast<double>(s.n) / secs : 0;
  s.cpu_us = s.n > 0 ? 1e6 * cpu / static_cast<double>(s.n) : 0;
  std::sort(lat.begin(), lat.end());
  if (!lat.empty()) {
    s.p50 = lat[lat.size() / 2];
    s.p99 = lat[static_cast<size_t>(0.99 * static_cast<double>(lat.size() - 1))];
  }
  return s;
}

double ThreadCpuSeconds() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// What the gateway path costs without HTTP and gRPC, CPU µs per call of this thread: the core's
// GetDrive alone, the router's JSON printing of its Drive (PrintJson, decision 1332), and, for
// comparison, protobuf's MessageToJsonString with the same options that PrintJson replaces.
struct CoreCosts {
  double get_drive_us = 0;
  // The form the direct route calls (decision 1363): written in place into a message on an arena
  // whose first block is on the stack, as Router::HandleDirect does.
  double get_drive_arena_us = 0;
  double print_json_us = 0;
  double message_to_json_us = 0;
  // JsonCache::Print of the same unchanged Drive (a hit: serialise, hash, compare, copy;
  // decision 1361), and how often x1's Drive message changes while the gateway runs (each
  // change costs the next GET one print).
  double cache_hit_us = 0;
  double changes_per_s = 0;
};
CoreCosts MeasureCore(drivegw::server::DriveServiceCore& core, int n) {
  google::protobuf::util::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  drivegw::v1::GetDriveRequest req;
  req.set_name("drives/x1");
  drivegw::server::CallContext cc;
  auto d = core.GetDrive(req, cc);
  if (!d.ok()) Die("core GetDrive failed");
  size_t bytes = 0;
  CoreCosts c;
  double t0 = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) bytes += core.GetDrive(req, cc)->ByteSizeLong();
  c.get_drive_us = 1e6 * (ThreadCpuSeconds() - t0) / n;
  t0 = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) {
    alignas(std::max_align_t) char block[4096];
    google::protobuf::ArenaOptions ao;
    ao.initial_block = block;
    ao.initial_block_size = sizeof(block);
    google::protobuf::Arena arena(ao);
    auto* out = google::protobuf::Arena::CreateMessage<drivegw::v1::Drive>(&arena);
    if (!core.GetDrive(req, cc, out).ok()) Die("core GetDrive in place failed");
    bytes += out->ByteSizeLong();
  }
  c.get_drive_arena_us = 1e6 * (ThreadCpuSeconds() - t0) / n;
  t0 = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) bytes += drivegw::rest::PrintJson(*d)->size();
  c.print_json_us = 1e6 * (ThreadCpuSeconds() - t0) / n;
  t0 = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) {
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(*d, &json, o).ok()) Die("JSON failed");
    bytes += json.size();
  }
  c.message_to_json_us = 1e6 * (ThreadCpuSeconds() - t0) / n;
  drivegw::rest::JsonCache cache;
  t0 = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) bytes += cache.Print(*d)->size();
  c.cache_hit_us = 1e6 * (ThreadCpuSeconds() - t0) / n;
  // Distinct Drive messages seen polling every 100 µs for 0.5 s.
  std::string last, now;
  long changes = 0;
  const auto poll_end = Clock::now() + std::chrono::milliseconds(500);
  while (Clock::now() < poll_end) {
    if (!core.GetDrive(req, cc)->SerializeToString(&now)) Die("serialise failed");
    if (now != last) ++changes;
    last.swap(now);
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  c.changes_per_s = static_cast<double>(changes) / 0.5;
  if (bytes == 0) Die("empty JSON");
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 2.0;
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 4;
  const int connections = argc > 3 ? std::atoi(argv[3]) : 16;
  drivegw::bench::DemoGateway gw;
  const uint16_t http_port = gw->http_port();

  // The bare endpoint answers a body as long as the gateway's (status JSON of x1 now).
  LoadResult probe = RunLoad(http_port, "/v1/drives/x1", 1, 0.0);
  if (probe.errors != 0 || probe.body_bytes == 0) Die("GET /v1/drives/x1 did not answer 200");
  BareServer bare(std::string(probe.body_bytes, 'x'));

  // Interleaved rounds, so machine noise hits both sides alike; a short warm-up first.
  RunLoad(bare.port(), "/v1/drives/x1", connections, std::min(0.2, seconds));
  RunLoad(http_port, "/v1/drives/x1", connections, std::min(0.2, seconds));
  std::vector<LoadResult> bare_runs, gw_runs, fixed_runs;
  const double load_before = drivegw::bench::LoadAverage();
  for (int r = 0; r < rounds; ++r) {
    bare_runs.push_back(RunLoad(bare.port(), "/v1/drives/x1", connections, seconds));
    gw_runs.push_back(RunLoad(http_port, "/v1/drives/x1", connections, seconds));
    // The gateway's HTTP layer alone: /readyz is a fixed route answered without gRPC.
    fixed_runs.push_back(RunLoad(http_port, "/readyz", connections, seconds / 2));
  }
  const Summary b = Summarize(bare_runs), g = Summarize(gw_runs), f = Summarize(fixed_runs);
  const CoreCosts core_costs = MeasureCore(gw->core(), std::max(1000, rounds * 5000));
  gw.Stop();

  // Informational: the same request over the in-process gRPC call of decision 501 (direct reads
  // off, decision 1331), on a second gateway started now, interleaved with the bare endpoint
  // again so the two ratios compare like with like.
  std::vector<LoadResult> bare2_runs, grpc_runs;
  {
    drivegw::bench::DemoGateway gw_grpc(/*rest_direct_reads=*/false, /*can_offset=*/3);
    const uint16_t grpc_http_port = gw_grpc->http_port();
    RunLoad(grpc_http_port, "/v1/drives/x1", connections, std::min(0.2, seconds));
    for (int r = 0; r < rounds; ++r) {
      bare2_runs.push_back(RunLoad(bare.port(), "/v1/drives/x1", connections, seconds / 2));
      grpc_runs.push_back(RunLoad(grpc_http_port, "/v1/drives/x1", connections, seconds / 2));
    }
  }
  const double load_after = drivegw::bench::LoadAverage();
  const Summary b2 = Summarize(bare2_runs), gg = Summarize(grpc_runs);
  const double grpc_ratio = b2.rps > 0 ? gg.rps / b2.rps : 0;
  const double fixed_ratio = f.rps > 0 ? g.rps / f.rps : 0;

  const double ratio = b.rps > 0 ? g.rps / b.rps : 0;
  std::printf("P4 REST GET /v1/drives/x1, %d keep-alive connections, %d x %.1f s, body %zu B\n",
              connections, rounds, seconds, probe.body_bytes);
  std::printf("%-44s %10s %9s %9s %9s %9s\n", "measurement", "req/s", "p50 us", "p99 us", "n",
              "CPU us/req");
  std::printf("%-44s %10.0f %9.1f %9.1f %9ld %9.1f\n", "baseline: bare Beast endpoint, fixed body",
              b.rps, b.p50, b.p99, b.n, b.cpu_us);
  std::printf("%-44s %10.0f %9.1f %9.1f %9ld %9.1f\n", "gateway: GET /v1/drives/x1", g.rps, g.p50,
              g.p99, g.n, g.cpu_us);
  std::printf("%-44s %10.0f %9.1f %9.1f %9ld %9.1f\n", "  gateway HTTP layer only (GET /readyz)",
              f.rps, f.p50, f.p99, f.n, f.cpu_us);
  std::printf("%-44s %10s %9s %9s %9s %9.1f\n", "  core GetDrive only (one thread)", "", "", "", "",
              core_costs.get_drive_us);
  std::printf("%-44s %10s %9s %9s %9s %9.1f\n", "  core GetDrive in place, arena (one thread)", "",
              "", "", "", core_costs.get_drive_arena_us);
  std::printf("%-44s %10s %9s %9s %9s %9.1f\n", "  PrintJson of that Drive (one thread)", "", "",
              "", "", core_costs.print_json_us);
  std::printf("%-44s %10s %9s %9s %9s %9.1f\n", "  MessageToJsonString of it, replaced", "", "", "",
              "", core_costs.message_to_json_us);
  std::printf("%-44s %10s %9s %9s %9s %9.1f\n", "  JSON cache hit for it (one thread)", "", "", "",
              "", core_costs.cache_hit_us);
  std::printf("x1's Drive changes %.0f times/s (each costs the next GET one print)\n",
              core_costs.changes_per_s);
  std::printf("%-44s %10.0f %9.1f %9.1f %9ld %9.1f\n", "  over in-process gRPC (decision 501)",
              gg.rps, gg.p50, gg.p99, gg.n, gg.cpu_us);
  std::printf("%-44s %10.0f %9.1f %9.1f %9ld %9.1f\n",
              "  bare Beast endpoint, beside the gRPC rounds", b2.rps, b2.p50, b2.p99, b2.n,
              b2.cpu_us);
  std::printf(
      "ratio gateway/bare %.2f (target >= 0.7); gateway/own fixed route %.2f; "
      "gRPC path/bare %.2f; non-200: %ld; load %.2f -> %.2f\n",
      ratio, fixed_ratio, grpc_ratio, g.errors + b.errors + gg.errors + b2.errors, load_before,
      load_after);
  drivegw::bench::Report(
      {"P4",
       "rest_status_ratio",
       ratio,
       "ratio",
       ">=0.7",
       "bare Beast endpoint (same threading, fixed body of the same size)",
       {{"gateway_rps", g.rps},
        {"gateway_p50_us", g.p50},
        {"gateway_p99_us", g.p99},
        {"bare_rps", b.rps},
        {"bare_p50_us", b.p50},
        {"bare_p99_us", b.p99},
        {"http_layer_only_rps", f.rps},
        {"gateway_cpu_us_per_req", g.cpu_us},
        {"bare_cpu_us_per_req", b.cpu_us},
        {"http_layer_only_cpu_us_per_req", f.cpu_us},
        {"core_get_drive_and_json_cpu_us", core_costs.get_drive_us + core_costs.print_json_us},
        {"core_get_drive_cpu_us", core_costs.get_drive_us},
        {"core_get_drive_arena_cpu_us", core_costs.get_drive_arena_us},
        {"print_json_cpu_us", core_costs.print_json_us},
        {"message_to_json_cpu_us", core_costs.message_to_json_us},
        {"json_cache_hit_cpu_us", core_costs.cache_hit_us},
        {"drive_changes_per_s", core_costs.changes_per_s},
        {"ratio_to_own_fixed_route", fixed_ratio},
        {"grpc_path_rps", gg.rps},
        {"grpc_path_ratio", grpc_ratio},
        {"grpc_path_cpu_us_per_req", gg.cpu_us},
        {"grpc_path_p50_us", gg.p50},
        {"connections", connections},
        {"body_bytes", probe.body_bytes},
        {"requests", g.n},
        {"load_avg", load_after}}});
  return g.errors + b.errors + gg.errors + b2.errors == 0 ? 0 : 1;
}
